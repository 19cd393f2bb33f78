#pragma once
/// \file intersections.h
/// Exact triangle-triangle intersection tests on a mesh (CGAL's exact predicates, behind a
/// CGAL-free interface: only checks_cgal.cpp compiles CGAL). The same definition as
/// `check_mesh`'s self-intersection count: two triangles intersect when they meet other than
/// in their shared vertex or shared edge.

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include <glm/glm.hpp>

#include "core/mesh.h"

namespace sm {

class TriangleIntersections {
 public:
  /// Copies the vertex positions (changed only through set_position) and keeps a reference to
  /// `mesh`, whose triangles are read at each call: they may be edited in between (edge flips).
  explicit TriangleIntersections(const Mesh& mesh);
  ~TriangleIntersections();
  TriangleIntersections(const TriangleIntersections&) = delete;
  TriangleIntersections& operator=(const TriangleIntersections&) = delete;

  /// Moves vertex v to p (the caller moves it in the mesh too).
  void set_position(std::uint32_t v, const glm::dvec3& p);
  /// Whether triangles i and j (distinct) intersect.
  [[nodiscard]] bool intersect(std::uint32_t i, std::uint32_t j) const;
  /// The intersecting pairs among `triangles` (i < j), sorted; degenerate triangles skipped.
  [[nodiscard]] std::vector<std::array<std::uint32_t, 2>> pairs(const std::vector<std::uint32_t>& triangles) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sm
