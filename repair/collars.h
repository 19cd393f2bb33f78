#pragma once
/// \file collars.h
/// A step of the repair stage for close-ups: the surface where a lateral leaves its parent is
/// remeshed finer and laid onto a collar. The slicing joins a lateral to its parent with a few
/// large fusion triangles and a sharp ridge (a socket); a real junction's wood wraps from the
/// lateral into the parent over about the lateral's radius, as the strands do.
///
/// The collar is the zero level of a field: the union of the parent's round cones and the
/// union of the lateral's (the input skeleton's cones, those `check` measures against), joined
/// by a smooth minimum of width `blend` lateral radii, which lies at most blend / 4 outside
/// their plain union. Each lateral's region is the surface within `reach` lateral radii of the
/// point where its axis leaves the parent's tube (one connected piece, a disc with holes),
/// grown across border edges too long for the target edge. CGAL's isotropic remeshing (target
/// edge `edge` lateral radii; the region's border is kept: its long edges are split, and the
/// triangle outside on such an edge becomes a fan) makes even triangles, and a flow moves
/// them onto the field's zero level: each step part of the way to it (a Newton step) and
/// towards the neighbours' centroid, so that the triangles do not fold where the nearest
/// points of a socket's flat triangles jump; fully from the third ring of the border in, less
/// towards it. Regions are independent and made on all threads; those sharing a vertex wait
/// for the next round.
///
/// A region is made only where
///  - it holds no triangle of a self-intersecting pair the repair left (a crossing is not a
///    junction to smooth);
///  - no vertex is farther from the field's zero level, nor moves farther, than `max_move`
///    times the larger of the lateral's radius and the local one (elsewhere the surface is
///    not this fork's, e.g. a fused crossing);
///  - no fan at its border has an angle under `min_angle` (unless the triangle fanned had);
/// and kept only where
///  - the surface stays closed around every vertex it changed;
///  - its new triangles (and the fans at its border) take part in no self-intersecting pair
///    (exact tests against the whole mesh);
///  - no skeleton node, of the sanitized skeleton or the input, inside the mesh before is left
///    outside.
/// Otherwise the region's triangles stay as they were. The cost grows with the laterals, each
/// region bounded by `max_region_triangles`.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "meshing/meshing.h"
#include "skeleton/skeleton.h"

namespace sm {

struct CollarOptions {
  double reach = 2.5;  ///< region radius around the lateral's base (lateral radii)
  double edge = 0.3;   ///< target edge length of the remeshed region (lateral radii)
  double blend = 0.6;  ///< width of the blend between lateral and parent (lateral radii)
  double max_move = 1.0;  ///< largest move of a vertex (x the larger of the lateral's and the local radius)
  std::size_t max_region_triangles = 4000;  ///< a region larger than this gets a longer target edge
  double min_angle = 1;  ///< smallest angle of the fans at a region's border (degrees), unless the triangle fanned had less
  int grow_rounds = 4;  ///< rounds of growing a region across its long border edges
  int flow_steps = 20;  ///< steps of the flow onto the collar's surface
  int rounds = 3;  ///< rounds of regions (those sharing a vertex with one made wait for the next)
  /// The skeleton the collars follow (the input as the file gives it, which `check` measures
  /// against); null: the skeleton the mesh was made from.
  const Skeleton* measure = nullptr;
  /// Points that must stay inside the mesh where they are inside it (skeleton nodes).
  std::span<const glm::dvec3> keep_inside;
};

struct CollarStats {
  std::size_t laterals = 0;        ///< laterals of the skeleton
  std::size_t regions = 0;         ///< regions tried
  std::size_t made = 0;            ///< regions remeshed and laid onto their collar, kept
  std::size_t skipped_pairs = 0;   ///< regions holding a triangle of a pair left
  std::size_t skipped_shape = 0;   ///< regions not a disc with holes, needing needle fans, not closed after, or CGAL could not remesh them
  std::size_t refused_move = 0;    ///< regions with a vertex beyond max_move
  std::size_t refused_pairs = 0;   ///< regions whose new triangles crossed others
  std::size_t refused_inside = 0;  ///< regions that left a skeleton node outside
  std::size_t triangles_before = 0, triangles_after = 0;
};

/// Remeshes the junction collars of `r` and lays them onto their surface, in place (positions on r.grid). `pairs`,
/// where known: the mesh's self-intersecting pairs (sorted), renumbered on return to the
/// triangles of the result. Degenerate triangles are dropped.
CollarStats make_collars(MeshResult& r, const Skeleton& skeleton, const CollarOptions& options,
                         std::optional<std::vector<std::array<std::uint32_t, 2>>>* pairs);

}  // namespace sm
