#pragma once
/// Self-union: where a closed, outward-oriented surface runs into itself (two branches
/// crossing, a twig through its parent, a fold at a tight crotch), the surface there is
/// replaced by the boundary of the union of the solids it wraps: the region whose winding
/// number is at least 1.
///
/// Only the triangles of the intersecting pairs are cut (CGAL's autorefinement, exact
/// constructions rounded to double); the cut lines divide them into patches, and a patch is
/// kept where it bounds the union: winding number 0 in front of it and at least 1 behind,
/// judged at one point on either side of its roundest triangle by ray crossings against the
/// whole surface (core/mesh.h inside_closed_mesh). Triangles that no cut touches but that lie
/// in a dropped patch (a twig's tube inside its parent) are found by a flood from the dropped
/// patches that stops at cut lines. The cost grows with the triangles cut and dropped, plus
/// one pass over the mesh for the winding numbers and one for the connectivity.
///
/// Around a transversal crossing the kept surface is a 2-manifold by construction; where cut
/// lines end at a vertex (a fold) the kept patches may meet at that vertex only, and it is
/// split, one copy per fan, each drawn a hundredth of the way into its fan. A side turned
/// inside out (winding number -1 in front, 0 behind) is kept flipped rather than dropped,
/// which would cut its branch off the tree. Components other than the largest go where they
/// hold none of the `anchors` (skeleton nodes): inner shells of voids and loose lumps.
/// Crossings whose union cannot be judged, would cut a part holding an anchor off, or would
/// leave outside an anchor the surface held are left out, each whole crossing curve through
/// them, and the rest is tried again (at most 24 attempts; `left_out_pairs`).

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/mesh.h"

namespace sm {

struct SelfUnionStats {
  std::size_t pairs = 0;              ///< intersecting triangle pairs given
  std::size_t cut_triangles = 0;      ///< triangles of those pairs (replaced by their kept parts)
  std::size_t patches = 0;            ///< patches of the cut triangles
  std::size_t dropped_triangles = 0;  ///< uncut triangles dropped (inside other parts)
  std::size_t flipped_triangles = 0;  ///< uncut triangles flipped (a part turned inside out)
  std::size_t new_vertices = 0;       ///< vertices on the cut lines
  std::size_t split_vertices = 0;     ///< vertices split where kept patches met at a point
  std::size_t inner_shells = 0;       ///< components of negative volume dropped
  std::size_t lumps = 0;              ///< other components without an anchor inside, dropped
  std::size_t left_out = 0;           ///< pairs left as they were: their patches could not be judged
  std::size_t unrefined_clusters = 0; ///< attempts where CGAL could not refine some clusters (left out)
  std::vector<std::array<std::uint32_t, 2>> left_out_pairs;  ///< those pairs, as given
  std::string problem;                ///< why the mesh was left as it was (empty: done)
};

/// A point 1 % of the way from p to `target`, but at least two steps of `grid` (when > 0) and at
/// most all the way, on that grid: a copy of a vertex that the float32 file keeps apart from it.
glm::dvec3 step_towards(const glm::dvec3& p, const glm::dvec3& target, double grid);

/// Signed volume of a closed surface (m^3; > 0 when its triangles face outward).
double signed_volume(const Mesh& mesh);

/// Replaces the triangles of `pairs` (and the triangles inside other parts that they bound)
/// by the boundary of the union, in place. `grid` > 0 puts new vertices on that float grid
/// (core/mesh.h float_grid). New triangles keep their origin triangle's branch and
/// interpolate its corner UVs; new vertices belong to no strand and to the skeleton node of
/// the origin's nearest corner; normals, when present, are recomputed. `origin` receives, per
/// triangle of the result, the index of the input triangle it is (part of).
/// Preconditions: `mesh` closed, edge-manifold and consistently oriented outward; `pairs`
/// are intersecting (as TriangleIntersections finds them). On failure (`problem` set) the
/// mesh and `origin` (the identity) are unchanged.
SelfUnionStats self_union(Mesh& mesh, const std::vector<std::array<std::uint32_t, 2>>& pairs, double grid,
                          std::span<const glm::dvec3> anchors, std::vector<std::uint32_t>& origin);

}  // namespace sm
