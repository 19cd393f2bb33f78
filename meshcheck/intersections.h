#pragma once
/// \file intersections.h
/// CGAL's exact geometry for the repairs, behind a CGAL-free interface: triangle-triangle
/// intersection tests on a mesh, with the same definition as `check_mesh`'s self-intersection
/// count (two triangles intersect when they meet other than in their shared vertex or shared
/// edge), and the triangulation of a closed polyline (hole filling). Both live in
/// meshcheck/checks_cgal.cpp, because they share its exact tests with check_mesh.

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include <glm/glm.hpp>

#include "core/mesh.h"

namespace sm {

class TriangleIntersections {
 public:
  /// Keeps a reference to `mesh`, whose positions and triangles are read at each call: they
  /// may be edited in between (edge flips, vertex moves).
  explicit TriangleIntersections(const Mesh& mesh);
  ~TriangleIntersections();
  TriangleIntersections(const TriangleIntersections&) = delete;
  TriangleIntersections& operator=(const TriangleIntersections&) = delete;

  /// Whether triangles i and j (distinct) intersect.
  [[nodiscard]] bool intersect(std::uint32_t i, std::uint32_t j) const;
  /// The intersecting pairs among `triangles` (i < j), sorted; degenerate triangles skipped.
  [[nodiscard]] std::vector<std::array<std::uint32_t, 2>> pairs(const std::vector<std::uint32_t>& triangles) const;
  /// The intersecting pairs (i < j) of the whole mesh with at least one triangle in `triangles`,
  /// sorted: after a local edit, the pairs the edited triangles take part in. Its cost is a
  /// pass over the mesh's boxes plus the tests near `triangles`, not the whole mesh's.
  [[nodiscard]] std::vector<std::array<std::uint32_t, 2>> pairs_touching(
      const std::vector<std::uint32_t>& triangles) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Triangulates the closed polyline `loop` (at least 3 points, the first not repeated at the
/// end) with CGAL's hole filling (Liepa's search, minimising the largest dihedral angle, then
/// the area). `outside[i]`, when given (one per edge), is the third vertex of the triangle
/// outside the hole on the edge (loop[i], loop[i + 1]); the dihedral angles there count too.
/// Triangles are index triples into `loop`, in no particular orientation; empty when CGAL
/// finds no triangulation.
std::vector<std::array<std::uint32_t, 3>> triangulate_polyline(const std::vector<glm::dvec3>& loop,
                                                               const std::vector<glm::dvec3>& outside = {});

}  // namespace sm
