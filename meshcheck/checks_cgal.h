#pragma once
/// Internal to sm_meshcheck: the checks that need CGAL, behind a CGAL-free interface so that
/// only checks_cgal.cpp compiles CGAL's headers.

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "core/mesh.h"
#include "core/report.h"

namespace sm::detail {

struct CgalCheckResult {
  bool self_intersections_checked = false;
  std::size_t self_intersecting_pairs = 0;             ///< pairs of distinct, non-degenerate triangles
  std::vector<std::array<std::uint32_t, 2>> examples;  ///< the smallest pairs (i < j), sorted
  bool inside_checked = false;                         ///< `inside` was computed
  Timings timings;                                     ///< seconds per phase
  std::vector<std::uint8_t> inside;                    ///< #queries: 1 when inside the mesh or on its surface
  std::size_t inside_by_winding = 0;                   ///< of those, inside overlapping parts (winding number >= 2)
};

/// Self-intersecting triangle pairs (when `self_intersections`) and which `queries` lie inside
/// the mesh (when `closed_polygon_mesh` and `queries` is not empty). `polygon_mesh` says the
/// triangles form a valid CGAL polygon mesh (edge- and vertex-manifold, oriented, no repeated
/// index in a triangle), as check_mesh has already established; `closed_polygon_mesh` adds no
/// boundary. Precondition: indices in range, coordinates finite.
///
/// Inside means a winding number of at least 1 (core/mesh.h winding_numbers: signed ray
/// crossings, all queries in one pass), so a point inside two overlapping parts (a stub's
/// tube running into its parent's; winding number 2, inside_by_winding) is inside, where a
/// parity test would call it outside; a point CGAL's exact Side_of_triangle_mesh puts on the
/// surface counts as inside too.
CgalCheckResult run_cgal_checks(const Mesh& mesh, bool polygon_mesh, bool closed_polygon_mesh, bool self_intersections,
                                const std::vector<glm::dvec3>& queries, std::size_t max_examples);

}  // namespace sm::detail
