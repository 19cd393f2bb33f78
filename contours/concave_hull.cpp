// The concave fallback of boundary selection: a "chi-shape" (Duckham et al. 2008, "Efficient
// generation of simple polygons for characterizing the shape of a set of points in the
// plane"), i.e. a Delaunay triangulation with its long boundary edges removed.
//
// Start from CGAL's Delaunay triangulation of the points (its outline is the convex hull) and
// repeatedly take away the boundary triangle whose boundary edge is the longest, while that
// edge is longer than `relative_max_edge` x the median nearest-neighbour distance and the triangle's third vertex is not on the boundary yet.
// The second condition keeps the remaining triangles a topological disc, so the outline stays
// one simple polygon, and every point stays inside it or on it (points are never removed,
// only triangles). The outline is walked counter-clockwise from the lowest point.
//
// This is the only translation unit of the contours stage that includes CGAL.

#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_data_structure_2.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

#include "contours/contours.h"

namespace sm {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<std::uint32_t, Kernel>;
using FaceBase = CGAL::Triangulation_face_base_with_info_2<std::int32_t, Kernel>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase, FaceBase>;
using Delaunay = CGAL::Delaunay_triangulation_2<Kernel, Tds>;

}  // namespace

std::vector<std::uint32_t> concave_hull(const std::vector<dvec2>& p, double relative_max_edge, bool* connected) {
  if (connected) *connected = false;
  if (p.size() < 3) return {};
  std::vector<std::pair<Kernel::Point_2, std::uint32_t>> input;
  input.reserve(p.size());
  for (std::uint32_t i = 0; i < p.size(); ++i) input.emplace_back(Kernel::Point_2(p[i].x, p[i].y), i);
  Delaunay dt(input.begin(), input.end());  // duplicates keep the first index inserted
  if (dt.dimension() < 2) return {};

  // Flat copy of the finite faces: vertices CCW, neighbour across the edge opposite each
  // vertex (-1 outside the hull).
  struct Tri {
    std::array<std::uint32_t, 3> v;
    std::array<std::int32_t, 3> nb;
  };
  std::vector<Tri> tri;
  tri.reserve(dt.number_of_faces());
  std::int32_t next_id = 0;
  for (auto f = dt.finite_faces_begin(); f != dt.finite_faces_end(); ++f) f->info() = next_id++;
  for (auto f = dt.finite_faces_begin(); f != dt.finite_faces_end(); ++f) {
    Tri t;
    for (int k = 0; k < 3; ++k) {
      t.v[k] = f->vertex(k)->info();
      const auto g = f->neighbor(k);
      t.nb[k] = dt.is_infinite(g) ? -1 : g->info();
    }
    tri.push_back(t);
  }

  auto edge_len2 = [&](const Tri& t, int k) {
    const dvec2 d = p[t.v[(k + 1) % 3]] - p[t.v[(k + 2) % 3]];
    return glm::dot(d, d);
  };
  // The scale: the median distance from a point to its nearest neighbour (always a Delaunay
  // edge).
  std::vector<double> nearest2(p.size(), std::numeric_limits<double>::infinity());
  for (const Tri& t : tri) {
    for (int k = 0; k < 3; ++k) {
      const double l2 = edge_len2(t, k);
      for (int j : {(k + 1) % 3, (k + 2) % 3}) nearest2[t.v[j]] = std::min(nearest2[t.v[j]], l2);
    }
  }
  std::erase_if(nearest2, [](double d) { return !std::isfinite(d); });  // merged duplicates
  std::nth_element(nearest2.begin(), nearest2.begin() + nearest2.size() / 2, nearest2.end());
  const double max2 = relative_max_edge * relative_max_edge * nearest2[nearest2.size() / 2];

  std::vector<char> alive(tri.size(), 1), on_boundary(p.size(), 0);
  // Longest boundary edge first; ties broken by face and edge index (deterministic).
  struct Edge {
    double len2;
    std::int32_t face;
    int k;
    bool operator<(const Edge& o) const {
      return len2 != o.len2 ? len2 < o.len2 : (face != o.face ? face > o.face : k > o.k);
    }
  };
  std::priority_queue<Edge> heap;
  for (std::int32_t f = 0; f < std::int32_t(tri.size()); ++f) {
    for (int k = 0; k < 3; ++k) {
      if (tri[f].nb[k] >= 0) continue;
      on_boundary[tri[f].v[(k + 1) % 3]] = on_boundary[tri[f].v[(k + 2) % 3]] = 1;
      heap.push({edge_len2(tri[f], k), f, k});
    }
  }
  while (!heap.empty() && heap.top().len2 > max2) {
    const Edge e = heap.top();
    heap.pop();
    const Tri& t = tri[e.face];
    if (!alive[e.face] || on_boundary[t.v[e.k]]) continue;
    // The opposite vertex is interior, so the two other edges have living neighbours and
    // become boundary edges.
    alive[e.face] = 0;
    on_boundary[t.v[e.k]] = 1;
    for (int j = 0; j < 3; ++j) {
      if (j == e.k) continue;
      const std::int32_t g = t.nb[j];
      const Tri& u = tri[g];
      for (int m = 0; m < 3; ++m) {
        if (u.nb[m] == e.face) heap.push({edge_len2(u, m), g, m});
      }
    }
  }

  // Walk the outline: every boundary vertex has exactly one outgoing boundary edge.
  std::vector<std::uint32_t> next(p.size(), UINT32_MAX);
  std::size_t edges = 0;
  for (std::size_t f = 0; f < tri.size(); ++f) {
    if (!alive[f]) continue;
    for (int k = 0; k < 3; ++k) {
      const std::int32_t g = tri[f].nb[k];
      if (g >= 0 && alive[g]) continue;
      next[tri[f].v[(k + 1) % 3]] = tri[f].v[(k + 2) % 3];
      ++edges;
    }
  }
  std::uint32_t start = UINT32_MAX;
  for (std::uint32_t i = 0; i < p.size(); ++i) {
    if (next[i] == UINT32_MAX) continue;
    if (start == UINT32_MAX || p[i].y < p[start].y || (p[i].y == p[start].y && p[i].x < p[start].x)) start = i;
  }
  std::vector<std::uint32_t> loop;
  loop.reserve(edges);
  for (std::uint32_t v = start; loop.size() <= edges;) {
    loop.push_back(v);
    v = next[v];
    if (v == start || v == UINT32_MAX) break;
  }
  if (loop.size() != edges) return {};  // not one simple outline (cannot happen; be safe)
  if (connected) {
    // Long edges left on the outline are bridges the carving could not remove without
    // splitting the shape in two: the points are several clusters.
    *connected = true;
    for (std::size_t k = 0; k < loop.size(); ++k) {
      const dvec2 d = p[loop[(k + 1) % loop.size()]] - p[loop[k]];
      if (glm::dot(d, d) > max2) *connected = false;
    }
  }

  // Points on a straight stretch of the outline (collinear with their neighbours) would give
  // the stitching zero-area triangles: drop them (the outline keeps every point on or inside).
  std::vector<std::uint32_t> kept;
  kept.reserve(loop.size());
  for (std::size_t k = 0; k < loop.size(); ++k) {
    const dvec2& a = p[kept.empty() ? loop.back() : kept.back()];
    const dvec2& b = p[loop[k]];
    const dvec2& c = p[loop[(k + 1) % loop.size()]];
    const dvec2 u = b - a, w = c - b;
    if (std::abs(cross2(u, w)) > 1e-9 * glm::length(u) * glm::length(w) || glm::dot(u, w) < 0) kept.push_back(loop[k]);
  }
  return kept.size() >= 3 ? kept : loop;
}

}  // namespace sm
