#pragma once
/// Step 4 of the repair stage, the outer surface: for self-intersecting pairs and thick
/// skeleton nodes outside the mesh that the fold repair, the fork retry and the near-miss push
/// leave (RepairParams::outer_surface).
///
/// Where two parts of the tree's surface run into each other (a branch into its sibling or its
/// own sub-branch near a crotch), no retriangulation of either part removes the crossing: the
/// surfaces have to be cut where they meet and joined, keeping what lies outside both. CGAL's
/// autorefinement does that (outer_surface_cgal.h, outer_surface). It is judged like any other
/// change: the result must pass `check_mesh` (meshcheck/checks.h) at least as well in every
/// respect as the mesh it replaces (closed, edge- and vertex-manifold, oriented, one component,
/// the same genus, no degenerate triangles, no more thick skeleton nodes outside, fidelity p95
/// no worse beyond its tolerance) and have fewer self-intersecting pairs; otherwise the mesh
/// is kept as it was. Folds of the surface (a fan of triangles over its own vertex), which
/// are not parts inside parts, are where CGAL's choice of patches goes wrong (a surface of
/// negative volume, refused): there the patches are chosen again by winding numbers
/// (outer_surface_by_winding, outer_surface_cgal.h), which keeps those bounding the union of the
/// solids the surface wraps. Where that is refused too, it is tried cluster by cluster
/// (WindingPatches), each cluster of crossings kept if the mesh does better with it.
///
/// Thick nodes outside (a stub's base in the crotch between two tubes, a tip just past its
/// cap: a millimetre or so outside) get a small sphere centred on the node, reaching a
/// quarter of its radius beyond the mesh (else a tenth: a larger one may bridge a crotch and
/// make a handle), joined to the mesh by CGAL's corefinement union, which leaves the mesh's
/// own folds elsewhere alone; judged the same way, with more nodes inside as the gain. Only
/// near misses (within half their radius of the mesh), and only up to 16 of them: more are a
/// tangle of branches through each other, which spheres do not mend.
///
/// The new triangles keep the branch and kind of the triangle they were cut from, and UVs
/// interpolated over it (a sphere takes those of the mesh triangle nearest its node, one UV
/// for all of it); new vertices (on the cut lines) belong to no strand and to the skeleton
/// node of the nearest corner of that triangle; normals are recomputed.

#include <cstddef>
#include <string>

#include "meshing/meshing.h"
#include "repair/junction_folds.h"
#include "skeleton/skeleton.h"

namespace sm {

struct OuterSurfaceStats {
  bool tried = false;                   ///< pairs or thick nodes outside were left, and RepairParams::outer_surface is on
  bool applied = false;                 ///< an outer surface replaced the mesh
  std::size_t pairs_before = 0;         ///< self-intersecting pairs of the mesh given
  std::size_t pairs_after = 0;          ///< of the mesh kept
  std::size_t nodes_inside_before = 0;  ///< thick skeleton nodes inside the mesh given
  std::size_t nodes_inside_after = 0;   ///< of the mesh kept
  std::size_t triangles_before = 0;
  std::size_t triangles_after = 0;
  std::size_t blobs = 0;   ///< thick nodes outside given a sphere that was kept
  std::size_t clusters = 0;       ///< clusters of crossings tried one by one (WindingPatches; 0: not tried)
  std::size_t clusters_kept = 0;  ///< of those, the ones whose outer surface was kept
  std::string refused;     ///< each attempt refused and why ("; "-separated; empty if none was)
  double seconds = 0;
};

/// One line of the figures ("8 -> 0 self-intersecting pairs, ...", without `refused`), for
/// `strandmesh -v mesh` and the viewer.
std::string to_text(const OuterSurfaceStats& stats);

/// Replaces `result`'s mesh by its outer surface where pairs or thick nodes outside are left
/// (see above), updating the mesh's attributes, triangle kinds, figures and `crossings`.
/// `skeleton` is the sanitized skeleton the mesh was made from. Runs where the pairs were
/// counted (Crossings::counted) and some found, or where the caller knows of thick nodes
/// outside (`thick_nodes_outside`: the fork retry's count).
OuterSurfaceStats keep_outer_surface(MeshResult& result, Crossings& crossings, const Skeleton& skeleton,
                                     bool thick_nodes_outside = false);

}  // namespace sm
