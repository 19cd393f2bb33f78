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

namespace sm {

namespace {

using glm::dvec3;

// ---------------------------------------------------------------- round cones

struct Cone {
  dvec3 a, b;     // end sphere centres (b == a for a lone node)
  double ra, rb;  // end sphere radii (> 0)
};

struct ConeDistance {
  double distance;  // signed: negative inside
  double radius;    // cone radius at the closest point
};

// Signed distance from p to the convex hull of the spheres (a, ra) and (b, rb). In the half
// plane through the axis, the hull's outline is two circles joined by their common tangent;
// the point's coordinate along that tangent decides whether sphere a, sphere b or the
// tangent (the conical side) is closest.
ConeDistance cone_distance(const Cone& c, const dvec3& p) {
  const dvec3 axis = c.b - c.a;
  const double len = glm::length(axis);
  if (len <= std::abs(c.ra - c.rb)) {  // one sphere contains the other (or a single node)
    const bool a_big = c.ra >= c.rb;
    const dvec3& centre = a_big ? c.a : c.b;
    const double r = a_big ? c.ra : c.rb;
    return {glm::length(p - centre) - r, r};
  }
  const dvec3 e = axis / len;
  const dvec3 w = p - c.a;
  const double y = glm::dot(w, e);          // along the axis
  const double x = glm::length(w - y * e);  // away from the axis
  const double s = (c.ra - c.rb) / len;     // sine of the cone's half angle
  const double co = std::sqrt(std::max(0.0, 1.0 - s * s));
  const double u = y * co - x * s;  // along the tangent, 0 at a's tangent point
  if (u <= 0) return {glm::length(w) - c.ra, c.ra};
  if (u >= len * co) return {glm::length(p - c.b) - c.rb, c.rb};
  const double d = y * s + x * co - c.ra;                    // distance to the tangent line
  const double t = std::clamp((y - d * s) / len, 0.0, 1.0);  // axial position of the closest point
  return {d, c.ra + t * (c.rb - c.ra)};
}

// A bounding-volume hierarchy over cones: nearest cone by signed distance, exactly.
class ConeTree {
 public:
  explicit ConeTree(std::vector<Cone> cones) {
    const std::size_t n = cones.size();
    std::vector<std::uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    std::vector<dvec3> centre(n);
    for (std::size_t i = 0; i < n; ++i) centre[i] = 0.5 * (cones[i].a + cones[i].b);
    struct Task {
      std::uint32_t node, begin, end;
    };
    std::vector<Task> stack;
    nodes_.push_back({});
    stack.push_back({0, 0, static_cast<std::uint32_t>(n)});
    while (!stack.empty()) {
      const Task task = stack.back();
      stack.pop_back();
      Node node;
      node.lo = dvec3(std::numeric_limits<double>::infinity());
      node.hi = -node.lo;
      dvec3 clo = node.lo, chi = node.hi;
      for (std::uint32_t i = task.begin; i < task.end; ++i) {
        const Cone& c = cones[order[i]];
        node.lo = glm::min(node.lo, glm::min(c.a - c.ra, c.b - c.rb));
        node.hi = glm::max(node.hi, glm::max(c.a + c.ra, c.b + c.rb));
        node.rmax = std::max(node.rmax, std::max(c.ra, c.rb));
        clo = glm::min(clo, centre[order[i]]);
        chi = glm::max(chi, centre[order[i]]);
      }
      if (task.end - task.begin <= kLeafSize) {
        node.first = task.begin;
        node.count = task.end - task.begin;
        nodes_[task.node] = node;
        continue;
      }
      const dvec3 ext = chi - clo;
      const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
      const std::uint32_t mid = task.begin + (task.end - task.begin) / 2;
      std::nth_element(order.begin() + task.begin, order.begin() + mid, order.begin() + task.end,
                       [&](std::uint32_t i, std::uint32_t j) {
                         return centre[i][axis] < centre[j][axis] || (centre[i][axis] == centre[j][axis] && i < j);
                       });
      node.left = static_cast<std::uint32_t>(nodes_.size());
      node.right = node.left + 1;
      nodes_[task.node] = node;
      nodes_.push_back({});
      nodes_.push_back({});
      stack.push_back({node.left, task.begin, mid});
      stack.push_back({node.right, mid, task.end});
    }
    cones_.reserve(n);
    for (const std::uint32_t i : order) cones_.push_back(cones[i]);
  }

  [[nodiscard]] ConeDistance nearest(const dvec3& p) const {
    ConeDistance best{std::numeric_limits<double>::infinity(), 1.0};
    std::uint32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes_[stack[--top]];
      if (lower_bound(node, p) >= best.distance) continue;
      if (node.count > 0) {
        for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
          const ConeDistance d = cone_distance(cones_[i], p);
          if (d.distance < best.distance) best = d;
        }
        continue;
      }
      // Visit the nearer child first (pushed last); the depth is at most ~2 log2 N.
      const double bl = lower_bound(nodes_[node.left], p), br = lower_bound(nodes_[node.right], p);
      if (top + 2 > 128) continue;  // unreachable for balanced trees of < 2^60 cones
      if (bl <= br) {
        stack[top++] = node.right;
        stack[top++] = node.left;
      } else {
        stack[top++] = node.left;
        stack[top++] = node.right;
      }
    }
    return best;
  }

 private:
  static constexpr std::uint32_t kLeafSize = 4;
  struct Node {
    dvec3 lo{0}, hi{0};
    double rmax = 0;
    std::uint32_t first = 0, count = 0, left = 0, right = 0;
  };
  // Outside the box, a cone is at least as far as the box; inside, no point is deeper in a
  // cone than its largest radius.
  static double lower_bound(const Node& n, const dvec3& p) {
    const dvec3 d = glm::max(glm::max(n.lo - p, p - n.hi), dvec3(0));
    const double dist = glm::length(d);
    return dist > 0 ? dist : -n.rmax;
  }
  std::vector<Cone> cones_;
  std::vector<Node> nodes_;
};

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
                      std::size_t max_examples, MeshCheckReport& r) {
  std::vector<Cone> cones;
  for (std::size_t i = 0; i < skel.size(); ++i) {
    const NodeId parent = skel.parent[i];
    if (parent.valid()) {
      cones.push_back({skel.position[parent.idx()], skel.position[i], skel.radius[parent.idx()], skel.radius[i]});
    } else if (skel.size() == 1) {
      cones.push_back({skel.position[i], skel.position[i], skel.radius[i], skel.radius[i]});
    }
  }
  if (cones.empty()) return;
  const ConeTree tree(std::move(cones));
  std::vector<std::uint32_t> verts;
  for (std::size_t v = 0; v < used.size(); ++v) {
    if (used[v]) verts.push_back(static_cast<std::uint32_t>(v));
  }
  std::vector<double> dev(verts.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, verts.size(), 1024),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        const ConeDistance d = tree.nearest(mesh.positions[verts[i]]);
                        dev[i] = std::abs(d.distance) / std::max(d.radius, 1e-300);
                      }
                    });
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
    measure_fidelity(mesh, used, skel, params.max_examples, r);
    thick_ids = thick_node_ids(skel);
    for (const std::uint32_t i : thick_ids) thick.push_back(skel.position[i]);
    r.thick_nodes = thick.size();
  }
  r.timings.add("fidelity", watch.lap());

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
  return f;
}

bool MeshCheckReport::ok() const {
  return failures().empty();
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
    std::string ex;
    for (const auto v : r.outside_node_examples) ex += (ex.empty() ? " (outside: node " : ", ") + std::to_string(v);
    if (!ex.empty()) ex += ")";
    if (r.thick_nodes_in_overlaps > 0)
      ex = " (" + n(r.thick_nodes_in_overlaps) + " of them where parts overlap, by winding number)" + ex;
    line("thick nodes inside",
         r.inside_checked ? n(r.thick_nodes_inside) + " / " + n(r.thick_nodes) + ex : std::string("not checked"));
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
  }
  j["examples"] = {{"boundary_edges", pairs(r.boundary_edge_examples)},
                   {"nonmanifold_edges", pairs(r.nonmanifold_edge_examples)},
                   {"nonmanifold_vertices", r.nonmanifold_vertex_examples},
                   {"misoriented_edges", pairs(r.misoriented_edge_examples)},
                   {"degenerate_triangles", r.degenerate_triangle_examples},
                   {"self_intersections", pairs(r.self_intersection_examples)},
                   {"outside_nodes", r.outside_node_examples},
                   {"fidelity_outliers", r.fidelity_outlier_examples}};
  nlohmann::json t = nlohmann::json::object();
  for (const auto& e : r.timings.entries) t[e.name] = e.seconds;
  j["timings"] = t;
  return j;
}

}  // namespace sm
