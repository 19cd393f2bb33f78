// Mesh checks: topology from sorted edge records, geometry in one pass, CGAL for
// self-intersections and point-in-mesh (checks_cgal.cpp), and fidelity to the skeleton's
// round cones through a bounding-volume hierarchy.
//
// Why these definitions: strandmesh promises a closed, manifold, oriented genus-0 surface
// without self-intersections that follows the skeleton's radii. Each count here is one of those
// promises, measured exactly (integer topology, exact CGAL predicates), so a test or a user
// can trust a zero. Fidelity compares against the round cone (convex hull of the two end
// spheres of an edge), the smooth surface a pipe-model skeleton describes; dividing by the
// local radius makes a 5 mm twig and a 50 cm trunk comparable.
//
// The skeleton index is a small BVH over the cones rather than a point kd-tree (nanoflann):
// the distance to a cone depends on its radii, and a box per cone gives exact lower bounds for
// branch-and-bound, so the nearest cone is found exactly in O(log N) on typical trees.

#include "meshcheck/checks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>

#include <nlohmann/json.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/errors.h"
#include "core/union_find.h"
#include "meshcheck/checks_cgal.h"
#include "meshcheck/cone_tree.h"
#include "meshcheck/implied_genus.h"

namespace sm {

namespace {

using glm::dvec3;
using detail::Cone;
using detail::ConeDistance;
using detail::ConeTree;

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const auto k = static_cast<std::size_t>(std::max(1.0, std::ceil(q * static_cast<double>(v.size())))) - 1;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

template <class T>
void add_example(std::vector<T>& list, const T& value, std::size_t max) {
  if (list.size() < max) list.push_back(value);
}

void measure_fidelity(const Mesh& mesh, const std::vector<std::uint8_t>& used, const Skeleton& skel,
                      std::size_t max_examples, std::size_t worst, MeshCheckReport& r) {
  std::vector<Cone> cones = detail::skeleton_cones(skel);
  if (cones.empty()) return;
  const ConeTree tree(std::move(cones));
  std::vector<std::uint32_t> verts;
  for (std::size_t v = 0; v < used.size(); ++v) {
    if (used[v]) verts.push_back(static_cast<std::uint32_t>(v));
  }
  std::vector<double> dev(verts.size());
  std::vector<FidelityVertex> where(worst > 0 ? verts.size() : 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, verts.size(), 1024),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        const ConeDistance d = tree.nearest(mesh.positions[verts[i]]);
                        const double rel = d.distance / std::max(d.radius, 1e-300);
                        dev[i] = std::abs(rel);
                        if (!where.empty()) where[i] = {verts[i], rel, d.id, d.t};
                      }
                    });
  if (!where.empty()) {
    const std::size_t k = std::min(worst, where.size());
    const auto farther = [](const FidelityVertex& a, const FidelityVertex& b) {
      return std::abs(a.deviation) > std::abs(b.deviation) || (std::abs(a.deviation) == std::abs(b.deviation) && a.vertex < b.vertex);
    };
    std::partial_sort(where.begin(), where.begin() + static_cast<std::ptrdiff_t>(k), where.end(), farther);
    where.resize(k);
    r.fidelity_worst = std::move(where);
  }
  r.fidelity_checked = true;
  for (std::size_t i = 0; i < verts.size(); ++i) {
    if (!(dev[i] > r.fidelity_tolerance)) continue;
    ++r.fidelity_outliers;
    add_example(r.fidelity_outlier_examples, verts[i], max_examples);
  }
  r.fidelity_p50 = percentile(dev, 0.50);
  r.fidelity_p95 = percentile(dev, 0.95);
  r.fidelity_max = dev.empty() ? 0 : *std::max_element(dev.begin(), dev.end());
}

std::string yes_no(bool b) {
  return b ? "yes" : "no";
}

// x with `digits` significant digits (%g style).
std::string fmt(double x, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, x);
  return buf;
}

}  // namespace

std::vector<std::uint32_t> thick_node_ids(const Skeleton& skeleton) {
  const double median = skeleton.median_radius();
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < skeleton.size(); ++i) {
    if (skeleton.radius[i] >= median) out.push_back(static_cast<std::uint32_t>(i));
  }
  return out;
}

double fidelity_p95(const Mesh& mesh, const Skeleton& skeleton) {
  std::vector<std::uint8_t> used(mesh.positions.size(), 0);
  for (const auto& t : mesh.triangles) {
    for (const std::uint32_t v : t) used[v] = 1;
  }
  for (const dvec3& p : mesh.positions) {
    if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))) return 0;
  }
  if (skeleton.empty()) return 0;
  MeshCheckReport r;
  r.fidelity_tolerance = MeshCheckParams{}.fidelity_tolerance;
  measure_fidelity(mesh, used, skeleton, 0, 0, r);
  return r.fidelity_p95;
}

MeshCheckReport check_mesh(const Mesh& mesh, const MeshCheckParams& params) {
  MeshCheckReport r;
  Stopwatch watch;
  const std::size_t nv = mesh.positions.size(), nf = mesh.triangles.size();
  r.vertices = nv;
  r.triangles = nf;
  r.fidelity_tolerance = params.fidelity_tolerance;
  for (std::size_t t = 0; t < nf; ++t) {
    for (const std::uint32_t v : mesh.triangles[t]) {
      if (v >= nv) {
        throw InvalidInputError("mesh: triangle " + std::to_string(t) + " references vertex " + std::to_string(v) +
                                " but the mesh has " + std::to_string(nv) + " vertices");
      }
    }
  }

  // ---- vertices
  std::vector<std::uint8_t> used(nv, 0);
  for (const auto& t : mesh.triangles) {
    for (const std::uint32_t v : t) used[v] = 1;
  }
  std::size_t used_count = 0;
  dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (std::size_t v = 0; v < nv; ++v) {
    const dvec3& p = mesh.positions[v];
    const bool finite = std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
    r.nonfinite_vertices += !finite;
    if (!used[v]) continue;
    ++used_count;
    if (finite) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  }
  r.unreferenced_vertices = nv - used_count;
  r.bbox_diagonal = used_count > 0 && lo.x <= hi.x ? glm::length(hi - lo) : 0.0;

  // ---- edges: one record per directed triangle side, sorted by undirected edge
  struct Side {
    std::uint64_t key;  // (min vertex << 32) | max vertex
    std::uint32_t triangle;
    std::uint32_t forward;  // 1 when the triangle goes from the min to the max vertex
    bool operator<(const Side& o) const {
      return key != o.key ? key < o.key : triangle != o.triangle ? triangle < o.triangle : forward < o.forward;
    }
  };
  std::vector<Side> sides;
  sides.reserve(3 * nf);
  bool repeated_index = false;
  for (std::size_t t = 0; t < nf; ++t) {
    const auto& tri = mesh.triangles[t];
    for (std::size_t k = 0; k < 3; ++k) {
      const std::uint32_t a = tri[k], b = tri[(k + 1) % 3];
      if (a == b) {
        repeated_index = true;
        continue;
      }
      const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      sides.push_back({key, static_cast<std::uint32_t>(t), a < b ? 1u : 0u});
    }
  }
  std::sort(sides.begin(), sides.end());
  for (std::size_t i = 0; i < sides.size();) {
    std::size_t j = i;
    while (j < sides.size() && sides[j].key == sides[i].key) ++j;
    const std::size_t n = j - i;
    const std::array<std::uint32_t, 2> edge{static_cast<std::uint32_t>(sides[i].key >> 32),
                                            static_cast<std::uint32_t>(sides[i].key & 0xffffffffu)};
    ++r.edges;
    if (n == 1) {
      ++r.boundary_edges;
      add_example(r.boundary_edge_examples, edge, params.max_examples);
    } else if (n >= 3) {
      ++r.nonmanifold_edges;
      add_example(r.nonmanifold_edge_examples, edge, params.max_examples);
    } else if (sides[i].forward == sides[i + 1].forward) {
      ++r.misoriented_edges;
      add_example(r.misoriented_edge_examples, edge, params.max_examples);
    }
    i = j;
  }
  sides = {};

  // ---- components (through shared vertices)
  {
    UnionFind uf(nv);
    for (const auto& t : mesh.triangles) {
      uf.unite(t[0], t[1]);
      uf.unite(t[1], t[2]);
    }
    for (std::size_t v = 0; v < nv; ++v) r.components += used[v] && uf.find(static_cast<std::uint32_t>(v)) == v;
  }

  // ---- vertex manifoldness: the triangles around a vertex, linked through the edges at the
  // vertex, must form one fan.
  {
    std::vector<std::uint32_t> start(nv + 1, 0);
    for (const auto& t : mesh.triangles) {
      for (const std::uint32_t v : t) ++start[v + 1];
    }
    for (std::size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
    std::vector<std::uint32_t> incident(3 * nf);
    {
      std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
      for (std::size_t t = 0; t < nf; ++t) {
        for (const std::uint32_t v : mesh.triangles[t]) incident[fill[v]++] = static_cast<std::uint32_t>(t);
      }
    }
    std::vector<std::pair<std::uint32_t, std::uint32_t>> spokes;  // (other vertex, local triangle)
    std::vector<std::uint32_t> local;
    for (std::size_t v = 0; v < nv; ++v) {
      const std::uint32_t b = start[v], e = start[v + 1];
      if (e - b < 2) continue;
      spokes.clear();
      for (std::uint32_t i = b; i < e; ++i) {
        for (const std::uint32_t w : mesh.triangles[incident[i]]) {
          if (w != v) spokes.emplace_back(w, i - b);
        }
      }
      std::sort(spokes.begin(), spokes.end());
      local.resize(e - b);
      std::iota(local.begin(), local.end(), 0u);
      auto find = [&](std::uint32_t x) {
        while (local[x] != x) x = local[x] = local[local[x]];
        return x;
      };
      for (std::size_t i = 1; i < spokes.size(); ++i) {
        if (spokes[i].first == spokes[i - 1].first) {
          const std::uint32_t x = find(spokes[i].second), y = find(spokes[i - 1].second);
          if (x != y) local[std::max(x, y)] = std::min(x, y);
        }
      }
      std::size_t fans = 0;
      for (std::uint32_t i = 0; i < e - b; ++i) fans += find(i) == i;
      if (fans > 1) {
        ++r.nonmanifold_vertices;
        add_example(r.nonmanifold_vertex_examples, static_cast<std::uint32_t>(v), params.max_examples);
      }
    }
  }
  r.closed = r.boundary_edges == 0;
  r.edge_manifold = r.nonmanifold_edges == 0;
  r.vertex_manifold = r.nonmanifold_vertices == 0;
  r.oriented = r.edge_manifold && r.misoriented_edges == 0;
  r.euler_characteristic =
      static_cast<std::int64_t>(used_count) - static_cast<std::int64_t>(r.edges) + static_cast<std::int64_t>(nf);
  if (r.closed && r.edge_manifold && r.vertex_manifold && r.oriented && !repeated_index && nf > 0) {
    const std::int64_t twice = 2 * static_cast<std::int64_t>(r.components) - r.euler_characteristic;
    if (twice >= 0 && twice % 2 == 0) r.genus = twice / 2;
  }
  r.timings.add("topology", watch.lap());

  // ---- geometry: areas and volume, relative to the box centre for precision
  {
    const dvec3 centre = r.bbox_diagonal > 0 ? 0.5 * (lo + hi) : dvec3(0);
    const double threshold = params.degenerate_area_ratio * r.bbox_diagonal * r.bbox_diagonal;
    double volume = 0;
    double min_area = std::numeric_limits<double>::infinity();
    for (std::size_t t = 0; t < nf; ++t) {
      const auto& tri = mesh.triangles[t];
      const dvec3 p0 = mesh.positions[tri[0]] - centre, p1 = mesh.positions[tri[1]] - centre,
                  p2 = mesh.positions[tri[2]] - centre;
      const double area = 0.5 * glm::length(glm::cross(p1 - p0, p2 - p0));
      volume += glm::dot(p0, glm::cross(p1, p2)) / 6.0;
      min_area = std::min(min_area, area);
      const bool repeated = tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2];
      if (repeated || !(area > threshold)) {
        ++r.degenerate_triangles;
        add_example(r.degenerate_triangle_examples, static_cast<std::uint32_t>(t), params.max_examples);
      }
    }
    r.signed_volume = volume;
    r.min_triangle_area = nf > 0 ? min_area : 0.0;
  }
  r.timings.add("geometry", watch.lap());

  // ---- fidelity
  std::vector<dvec3> thick;
  std::vector<std::uint32_t> thick_ids;
  if (params.skeleton && !params.skeleton->empty() && r.nonfinite_vertices == 0) {
    const Skeleton& skel = *params.skeleton;
    measure_fidelity(mesh, used, skel, params.max_examples, params.fidelity_worst, r);
    thick_ids = thick_node_ids(skel);
    for (const std::uint32_t i : thick_ids) thick.push_back(skel.position[i]);
    r.thick_nodes = thick.size();
  }
  r.timings.add("fidelity", watch.lap());

  // ---- the genus the skeleton's crossings imply (informative)
  if (params.implied_genus && params.skeleton && !params.skeleton->empty()) {
    const ImpliedGenus g = sm::implied_genus(
        *params.skeleton, {.max_examples = params.max_examples, .robust_margin = std::min(params.fidelity_tolerance, 0.9)});
    r.implied_genus_checked = g.complete;  // (not over a tangle of more than 5e7 candidate pairs)
    r.implied_genus = g.genus;
    r.implied_genus_min = g.genus_min;
    r.implied_genus_robust = g.robust_genus;
    r.crossing_pairs = g.crossing_pairs;
    r.handle_examples = g.handle_examples;
    r.timings.add("implied genus", watch.lap());
  }

  // ---- triangle quality (informative unless limits are given)
  if (params.quality && r.nonfinite_vertices == 0) {
    r.quality = measure_quality(mesh, params.skeleton && !params.skeleton->empty() ? params.skeleton : nullptr,
                                {.junction_radii = params.junction_radii, .max_examples = params.max_examples});
    r.quality_checked = true;
    r.quality_limits = params.quality_limits;
  }
  r.timings.add("quality", watch.lap());
  if (params.uvs && r.nonfinite_vertices == 0 && !mesh.corner_uvs.empty() && mesh.corner_uvs.size() == nf) {
    r.uv = measure_uv_quality(mesh, params.skeleton && !params.skeleton->empty() ? params.skeleton : nullptr,
                              {.junction_radii = params.junction_radii, .max_examples = params.max_examples});
    r.uv_checked = true;
  }
  r.timings.add("uv_quality", watch.lap());

  // ---- CGAL: self-intersections and thick nodes inside
  if (r.nonfinite_vertices == 0 && nf > 0 && (params.self_intersections || !thick.empty())) {
    const bool polygon_mesh = r.edge_manifold && r.vertex_manifold && r.oriented && !repeated_index;
    const detail::CgalCheckResult c = detail::run_cgal_checks(mesh, polygon_mesh, polygon_mesh && r.closed,
                                                              params.self_intersections, thick, params.max_examples);
    r.self_intersections_checked = c.self_intersections_checked;
    r.self_intersecting_pairs = c.self_intersecting_pairs;
    r.self_intersection_examples = c.examples;
    r.inside_checked = c.inside_checked;
    if (c.inside_checked) {
      r.thick_nodes_inside = static_cast<std::size_t>(std::count(c.inside.begin(), c.inside.end(), 1));
      r.thick_nodes_in_overlaps = c.inside_by_winding;
      for (std::size_t k = 0; k < c.inside.size() && r.outside_node_examples.size() < params.max_examples; ++k) {
        if (!c.inside[k]) r.outside_node_examples.push_back(thick_ids[k]);
      }
      // Every node, by winding number in one pass (informative: ok() asks the thick ones only).
      const std::vector<glm::dvec3>& all = params.skeleton->position;
      const std::vector<int> w = winding_numbers(mesh, std::span<const glm::dvec3>(all.data(), all.size()));
      r.nodes = all.size();
      r.nodes_inside = static_cast<std::size_t>(std::count_if(w.begin(), w.end(), [](int x) { return x >= 1; }));
    }
    for (const auto& e : c.timings.entries) r.timings.add(e.name, e.seconds);
  }
  return r;
}

std::vector<std::string> MeshCheckReport::failures() const {
  std::vector<std::string> f;
  auto n = [](std::size_t x) { return std::to_string(x); };
  if (triangles == 0) f.push_back("the mesh has no triangles");
  if (nonfinite_vertices > 0) f.push_back(n(nonfinite_vertices) + " vertices with non-finite coordinates");
  if (!closed) f.push_back(n(boundary_edges) + " boundary edges (not closed)");
  if (!edge_manifold) f.push_back(n(nonmanifold_edges) + " edges with more than two triangles (not edge-manifold)");
  if (!vertex_manifold) f.push_back(n(nonmanifold_vertices) + " vertices with several fans (not vertex-manifold)");
  if (edge_manifold && misoriented_edges > 0)
    f.push_back(n(misoriented_edges) + " misoriented edges (not consistently oriented)");
  if (components != 1 && triangles > 0) f.push_back(n(components) + " connected components (expected 1)");
  if (degenerate_triangles > 0) f.push_back(n(degenerate_triangles) + " degenerate triangles");
  if (self_intersections_checked && self_intersecting_pairs > 0) {
    f.push_back(n(self_intersecting_pairs) + " self-intersecting triangle pairs");
  }
  if (triangles > 0 && !(signed_volume > 0))
    f.push_back("signed volume " + fmt(signed_volume, 6) + " is not positive (faces point inward?)");
  if (fidelity_checked && !(fidelity_p95 <= fidelity_tolerance)) {
    f.push_back("fidelity p95 " + fmt(fidelity_p95, 3) + " exceeds the tolerance " + fmt(fidelity_tolerance, 3));
  }
  if (thick_nodes > 0 && !inside_checked)
    f.push_back("thick nodes not tested for inside (mesh is not a closed manifold)");
  if (inside_checked && thick_nodes_inside != thick_nodes) {
    f.push_back(n(thick_nodes - thick_nodes_inside) + " of " + n(thick_nodes) +
                " thick skeleton nodes lie outside the mesh");
  }
  if (quality_checked && quality_limits) {
    for (const std::string& q : quality.failures(*quality_limits)) f.push_back(q);
  }
  return f;
}

bool MeshCheckReport::ok() const {
  return failures().empty();
}

std::optional<bool> MeshCheckReport::genus_agrees() const {
  if (!implied_genus_checked || !genus) return std::nullopt;
  return *genus >= implied_genus_min && *genus <= implied_genus;
}

std::string to_text(const MeshCheckReport& r) {
  std::string s;
  auto line = [&](const char* key, const std::string& value) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%-22s", key);
    s += buf;
    s += value;
    s += '\n';
  };
  auto n = [](std::size_t x) { return std::to_string(x); };
  auto pairs = [](const std::vector<std::array<std::uint32_t, 2>>& list, const char* sep) {
    std::string out;
    for (const auto& p : list) out += (out.empty() ? "" : ", ") + std::to_string(p[0]) + sep + std::to_string(p[1]);
    return out.empty() ? out : " e.g. " + out;
  };
  line("vertices",
       n(r.vertices) + (r.unreferenced_vertices ? " (" + n(r.unreferenced_vertices) + " unreferenced)" : ""));
  if (r.nonfinite_vertices) line("non-finite vertices", n(r.nonfinite_vertices));
  line("triangles", n(r.triangles));
  line("edges", n(r.edges));
  line("components", n(r.components));
  line("closed",
       yes_no(r.closed) + " (" + n(r.boundary_edges) + " boundary edges)" + pairs(r.boundary_edge_examples, "-"));
  line("edge-manifold", yes_no(r.edge_manifold) + " (" + n(r.nonmanifold_edges) + " non-manifold edges)" +
                            pairs(r.nonmanifold_edge_examples, "-"));
  {
    std::string ex;
    for (const auto v : r.nonmanifold_vertex_examples) ex += (ex.empty() ? " e.g. " : ", ") + std::to_string(v);
    line("vertex-manifold",
         yes_no(r.vertex_manifold) + " (" + n(r.nonmanifold_vertices) + " non-manifold vertices)" + ex);
  }
  line("oriented", yes_no(r.oriented) + " (" + n(r.misoriented_edges) + " misoriented edges)" +
                       pairs(r.misoriented_edge_examples, "-"));
  line("euler characteristic", std::to_string(r.euler_characteristic));
  line("genus", r.genus ? std::to_string(*r.genus) + (*r.genus > 0 ? " (handles where branches cross and fuse)" : "")
                       : std::string("undefined (not a closed oriented manifold)"));
  if (r.implied_genus_checked) {
    std::string v = r.implied_genus_min == r.implied_genus
                        ? std::to_string(r.implied_genus)
                        : std::to_string(r.implied_genus_min) + " to " + std::to_string(r.implied_genus);
    v += " (" + std::to_string(r.implied_genus_robust) + " robust: kept from radii x" +
         fmt(1 - std::min(r.fidelity_tolerance, 0.9), 3) + " to x" + fmt(1 + std::min(r.fidelity_tolerance, 0.9), 3) +
         "; " + n(r.crossing_pairs) + " crossing edge pairs in the skeleton";
    if (!r.handle_examples.empty()) v += "; handles e.g. at nodes" + pairs(r.handle_examples, "/").substr(5);
    v += ")";
    line("implied genus", v);
    if (r.genus) {
      const std::int64_t g = *r.genus;
      line("  mesh vs implied",
           g >= r.implied_genus_min && g <= r.implied_genus ? std::string("agree")
           : g > r.implied_genus ? "the mesh has more handles (fused where the round cones do not meet?)"
           : g >= r.implied_genus_robust
               ? std::string("the mesh has fewer, none of them robust (near tangency, or holes thinner than the band)")
               : "the mesh has fewer than the robust count: a crossing's handle is missing (informative)");
    }
  }
  {
    std::string ex;
    for (const auto t : r.degenerate_triangle_examples) ex += (ex.empty() ? " e.g. " : ", ") + std::to_string(t);
    line("degenerate triangles",
         n(r.degenerate_triangles) + " (smallest area " + fmt(r.min_triangle_area, 3) + " m^2)" + ex);
  }
  line("signed volume",
       fmt(r.signed_volume, 6) + " m^3 (" + (r.signed_volume > 0 ? "outward" : "inward or empty") + ")");
  line("self-intersections", r.self_intersections_checked ? n(r.self_intersecting_pairs) + " triangle pairs" +
                                                                pairs(r.self_intersection_examples, "/")
                                                          : std::string("not checked"));
  if (r.fidelity_checked) {
    line("fidelity", "p50 " + fmt(r.fidelity_p50, 3) + ", p95 " + fmt(r.fidelity_p95, 3) + ", max " +
                         fmt(r.fidelity_max, 3) + " of the local radius (tolerance " + fmt(r.fidelity_tolerance, 3) +
                         " for p95)");
    std::string far;
    for (const auto v : r.fidelity_outlier_examples) far += (far.empty() ? " e.g. vertex " : ", ") + std::to_string(v);
    line("beyond tolerance", n(r.fidelity_outliers) + " vertices" + far);
    for (const FidelityVertex& f : r.fidelity_worst) {
      line("far vertex", std::to_string(f.vertex) + ": " + fmt(f.deviation, 3) + " of the radius, nearest edge to node " +
                             std::to_string(f.node) + " at t " + fmt(f.t, 2));
    }
    std::string ex;
    for (const auto v : r.outside_node_examples) ex += (ex.empty() ? " (outside: node " : ", ") + std::to_string(v);
    if (!ex.empty()) ex += ")";
    if (r.thick_nodes_in_overlaps > 0)
      ex = " (" + n(r.thick_nodes_in_overlaps) + " of them where parts overlap, by winding number)" + ex;
    line("thick nodes inside",
         r.inside_checked ? n(r.thick_nodes_inside) + " / " + n(r.thick_nodes) + ex : std::string("not checked"));
    if (r.inside_checked) line("all nodes inside", n(r.nodes_inside) + " / " + n(r.nodes) + " (by winding number)");
  }
  if (r.quality_checked) {
    const TriangleQuality& q = r.quality;
    auto pct = [](double share) { return fmt(100.0 * share, 3) + " %"; };
    line("small angles", pct(q.share_under_10()) + " of the triangles under 10 degrees, " + pct(q.share_under_5()) +
                             " under 5, " + pct(q.share_under_1()) + " (" + n(q.under_1) + ") under 1; smallest " +
                             fmt(q.min_angle, 3));
    line("aspect ratio", "p95 " + fmt(q.aspect_p95, 3) + ", max " + fmt(q.aspect_max, 3) + " (1 = equilateral)");
    std::string sharp = pairs(q.sharpest_edges, "-");
    line("dihedral angle", "p99 " + fmt(q.dihedral_p99, 3) + ", max " + fmt(q.dihedral_max, 3) + " degrees over " +
                               n(q.edges) + " edges" +
                               (q.caps_known ? " (" + n(q.cap_edges) + " cap edges left out)" : " (caps included)") +
                               sharp);
    if (q.caps_known) {
      line("  at junctions", "p99 " + fmt(q.junction_dihedral_p99, 3) + ", max " + fmt(q.junction_dihedral_max, 3) +
                                 " degrees over " + n(q.junction_edges) + " edges");
    }
    std::string ex;
    for (const auto v : q.backward_normal_examples) ex += (ex.empty() ? " e.g. " : ", ") + std::to_string(v);
    line("backward normals", n(q.backward_normals) + " vertices" +
                                 (q.normals_computed     ? " (angle-weighted; the mesh has no normals)"
                                  : q.normals_per_corner ? " (per corner: the mesh has smoothing groups)"
                                                         : std::string()) +
                                 ex);
  }
  if (r.uv_checked) {
    const UvQuality& u = r.uv;
    line("uv seams", n(u.seam_edges) + " edges: " + n(u.around_seams) + " around the branches, " + n(u.other_seams) +
                         " other" +
                         (u.caps_known ? "; at junctions " + n(u.junction_around_seams) + " around, " +
                                             n(u.junction_other_seams) + " other"
                                       : std::string()) +
                         pairs(u.other_seam_examples, "-"));
    line("uv stretch", "anisotropy p95 " + fmt(u.anisotropy_p95, 3) + ", max " + fmt(u.anisotropy_max, 3) +
                           "; texel density p95 " + fmt(u.density_p95, 3) + " x the median " +
                           fmt(u.density_median, 3) + " per m" +
                           (u.caps_known ? " (caps left out)" : std::string()));
    if (u.caps_known) {
      line("  at junctions", "anisotropy p95 " + fmt(u.junction_anisotropy_p95, 3) + ", texel density p95 " +
                                 fmt(u.junction_density_p95, 3) + " x the median over " + n(u.junction_triangles) +
                                 " triangles");
    }
    line("uv flipped", n(u.flipped) + " triangles mirrored, " + n(u.collapsed) + " collapsed, of " + n(u.triangles));
  }
  const auto failures = r.failures();
  for (const auto& f : failures) s += "problem: " + f + "\n";
  s += failures.empty() ? "result: ok\n" : "result: FAILED\n";
  return s;
}

nlohmann::json to_json(const MeshCheckReport& r) {
  auto pairs = [](const std::vector<std::array<std::uint32_t, 2>>& v) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& p : v) a.push_back({p[0], p[1]});
    return a;
  };
  nlohmann::json j;
  j["ok"] = r.ok();
  j["failures"] = r.failures();
  j["vertices"] = r.vertices;
  j["unreferenced_vertices"] = r.unreferenced_vertices;
  j["nonfinite_vertices"] = r.nonfinite_vertices;
  j["triangles"] = r.triangles;
  j["edges"] = r.edges;
  j["components"] = r.components;
  j["boundary_edges"] = r.boundary_edges;
  j["nonmanifold_edges"] = r.nonmanifold_edges;
  j["nonmanifold_vertices"] = r.nonmanifold_vertices;
  j["misoriented_edges"] = r.misoriented_edges;
  j["closed"] = r.closed;
  j["edge_manifold"] = r.edge_manifold;
  j["vertex_manifold"] = r.vertex_manifold;
  j["oriented"] = r.oriented;
  j["euler_characteristic"] = r.euler_characteristic;
  j["genus"] = r.genus ? nlohmann::json(*r.genus) : nlohmann::json(nullptr);
  if (r.implied_genus_checked) {
    j["implied_genus"] = r.implied_genus;
    j["implied_genus_min"] = r.implied_genus_min;
    j["implied_genus_robust"] = r.implied_genus_robust;
    j["crossing_pairs"] = r.crossing_pairs;
    const std::optional<bool> agree = r.genus_agrees();
    j["genus_agrees"] = agree ? nlohmann::json(*agree) : nlohmann::json(nullptr);
  }
  j["degenerate_triangles"] = r.degenerate_triangles;
  j["min_triangle_area"] = r.min_triangle_area;
  j["signed_volume"] = r.signed_volume;
  j["bbox_diagonal"] = r.bbox_diagonal;
  j["self_intersections_checked"] = r.self_intersections_checked;
  j["self_intersecting_pairs"] = r.self_intersecting_pairs;
  j["fidelity_checked"] = r.fidelity_checked;
  if (r.fidelity_checked) {
    j["fidelity"] = {
        {"p50", r.fidelity_p50}, {"p95", r.fidelity_p95}, {"max", r.fidelity_max}, {"tolerance", r.fidelity_tolerance},
        {"beyond_tolerance", r.fidelity_outliers}};
    j["inside_checked"] = r.inside_checked;
    j["thick_nodes"] = r.thick_nodes;
    j["thick_nodes_inside"] = r.thick_nodes_inside;
    j["thick_nodes_in_overlaps"] = r.thick_nodes_in_overlaps;
    j["nodes"] = r.nodes;
    j["nodes_inside"] = r.nodes_inside;
  }
  if (r.quality_checked) {
    const TriangleQuality& q = r.quality;
    nlohmann::json qj{{"share_under_1", q.share_under_1()},
                      {"share_under_5", q.share_under_5()},
                      {"share_under_10", q.share_under_10()},
                      {"under_1", q.under_1},
                      {"under_5", q.under_5},
                      {"under_10", q.under_10},
                      {"min_angle", q.min_angle},
                      {"aspect_p95", q.aspect_p95},
                      {"aspect_max", q.aspect_max},
                      {"caps_known", q.caps_known},
                      {"dihedral_edges", q.edges},
                      {"cap_edges", q.cap_edges},
                      {"dihedral_p99", q.dihedral_p99},
                      {"dihedral_max", q.dihedral_max},
                      {"sharpest_edges", pairs(q.sharpest_edges)},
                      {"normals_computed", q.normals_computed},
                      {"normals_per_corner", q.normals_per_corner},
                      {"backward_normals", q.backward_normals},
                      {"backward_normal_examples", q.backward_normal_examples}};
    if (q.caps_known) {
      qj["junction_edges"] = q.junction_edges;
      qj["junction_dihedral_p99"] = q.junction_dihedral_p99;
      qj["junction_dihedral_max"] = q.junction_dihedral_max;
    }
    if (r.quality_limits) {
      qj["limits"] = {{"max_share_under_10", r.quality_limits->max_share_under_10},
                      {"max_under_1", r.quality_limits->max_under_1},
                      {"max_junction_dihedral_p99", r.quality_limits->max_junction_dihedral_p99},
                      {"max_backward_normals", r.quality_limits->max_backward_normals}};
    }
    j["quality"] = qj;
  }
  if (r.uv_checked) {
    const UvQuality& u = r.uv;
    nlohmann::json uj{{"seam_edges", u.seam_edges},
                      {"around_seams", u.around_seams},
                      {"other_seams", u.other_seams},
                      {"other_seam_examples", pairs(u.other_seam_examples)},
                      {"caps_known", u.caps_known},
                      {"triangles", u.triangles},
                      {"collapsed", u.collapsed},
                      {"flipped", u.flipped},
                      {"density_median", u.density_median},
                      {"anisotropy_p95", u.anisotropy_p95},
                      {"anisotropy_max", u.anisotropy_max},
                      {"density_p95", u.density_p95}};
    if (u.caps_known) {
      uj["junction_around_seams"] = u.junction_around_seams;
      uj["junction_other_seams"] = u.junction_other_seams;
      uj["junction_triangles"] = u.junction_triangles;
      uj["junction_anisotropy_p95"] = u.junction_anisotropy_p95;
      uj["junction_density_p95"] = u.junction_density_p95;
    }
    j["uv"] = uj;
  }
  j["examples"] = {{"boundary_edges", pairs(r.boundary_edge_examples)},
                   {"nonmanifold_edges", pairs(r.nonmanifold_edge_examples)},
                   {"nonmanifold_vertices", r.nonmanifold_vertex_examples},
                   {"misoriented_edges", pairs(r.misoriented_edge_examples)},
                   {"degenerate_triangles", r.degenerate_triangle_examples},
                   {"self_intersections", pairs(r.self_intersection_examples)},
                   {"outside_nodes", r.outside_node_examples},
                   {"fidelity_outliers", r.fidelity_outlier_examples},
                   {"handles", pairs(r.handle_examples)}};
  if (!r.fidelity_worst.empty()) {
    nlohmann::json w = nlohmann::json::array();
    for (const FidelityVertex& f : r.fidelity_worst) {
      w.push_back({{"vertex", f.vertex}, {"deviation", f.deviation}, {"node", f.node}, {"t", f.t}});
    }
    j["fidelity_worst"] = std::move(w);
  }
  nlohmann::json t = nlohmann::json::object();
  for (const auto& e : r.timings.entries) t[e.name] = e.seconds;
  j["timings"] = t;
  return j;
}

}  // namespace sm
