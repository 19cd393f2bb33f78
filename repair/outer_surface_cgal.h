#pragma once
/// \file outer_surface_cgal.h
/// CGAL's outer surfaces for the repair stage, behind a CGAL-free interface
/// (outer_surface_cgal.cpp; the outer surface step, outer_surface.h, judges them).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "core/mesh.h"

namespace sm {

/// The outer surface of a closed, manifold mesh whose parts run into each other: CGAL's
/// autorefinement cuts every pair of intersecting triangles along their intersection, and the
/// patches that then lie inside another part are removed
/// (PMP::experimental::autorefine_and_remove_self_intersections; outer_surface_cgal.cpp).
/// Where the self-intersections are folds of the surface rather than parts inside parts, CGAL
/// may keep the wrong patches: the result is to be checked.
struct OuterSurface {
  bool fixed = false;                     ///< CGAL reports every self-intersection removed
  std::vector<glm::dvec3> positions;      ///< the input's vertices (same indices), then the new ones
  std::vector<Mesh::Triangle> triangles;  ///< oriented like the input
  std::vector<std::uint32_t> origin;      ///< #triangles: the input triangle each one is part of
  std::string problem;                    ///< why there is none, where known (else CGAL failed)
};
/// Empty (no triangles) when `mesh` is not a manifold triangle mesh or CGAL throws.
OuterSurface outer_surface(const Mesh& mesh);

/// The same surface chosen by winding numbers, where CGAL's choice of patches goes wrong:
/// CGAL's autorefinement alone (PMP::experimental::autorefine) cuts the intersecting
/// triangles along their intersections; the cut lines divide the surface into patches, and a
/// patch is kept where it bounds the union of the solids the surface wraps (the region of
/// winding number 1 or more): winding number 0 in front of it (and so 1 behind), judged at
/// points on either side of one of its triangles. Where a fold's cut line ends at a vertex
/// of the mesh, the patches kept meet at that vertex alone: it is split, one copy per fan,
/// each drawn a hundredth of the way into its fan. `fixed` when every patch was judged; empty
/// with `problem` set when a patch has no triangle of any area or there are more than 512
/// patches.
OuterSurface outer_surface_by_winding(const Mesh& mesh);

/// The patches of outer_surface_by_winding, from which outer surfaces are made cluster by
/// cluster: a cluster is a set of crossings (the input triangles the refinement cut, joined
/// where they share a vertex, and the patches dropped between them). Where the whole choice
/// fails (a branch cut off through a pinched neck; a handle where two parts run through each
/// other), the crossings elsewhere may still be mended: `surface(apply)` applies the choice
/// at the clusters marked in `apply` (#clusters()) and keeps the input triangles at the others.
class WindingPatches {
 public:
  explicit WindingPatches(const Mesh& mesh);
  ~WindingPatches();
  WindingPatches(const WindingPatches&) = delete;
  WindingPatches& operator=(const WindingPatches&) = delete;
  [[nodiscard]] std::size_t clusters() const;
  /// Why no surface can be made (empty if it can).
  [[nodiscard]] const std::string& problem() const;
  [[nodiscard]] OuterSurface surface(const std::vector<std::uint8_t>& apply) const;

 private:
  struct Data;
  std::unique_ptr<Data> d_;
};

/// The union of the solids bounded by `a` and `b` (closed, manifold, outward; each free of
/// self-intersections where it meets the other): CGAL's corefinement
/// (PMP::corefine_and_compute_union). Positions: `a`'s vertices (same indices), then new ones
/// (cut lines, and `b`'s vertices kept); `origin` indexes `a`'s triangles, then `b`'s
/// (a.triangles.size() + j). `fixed` is CGAL's success; empty when either is not a manifold
/// triangle mesh or CGAL throws.
OuterSurface union_of(const Mesh& a, const Mesh& b);

}  // namespace sm
