#include "repair/collars.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <unordered_map>
#include <utility>

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <tbb/parallel_for.h>

#include "core/math.h"
#include "core/mesh.h"
#include "meshcheck/intersections.h"
#include "repair/repair.h"

namespace sm {
namespace {

using K = CGAL::Simple_cartesian<double>;
using SMesh = CGAL::Surface_mesh<K::Point_3>;
using VD = SMesh::Vertex_index;
namespace PMP = CGAL::Polygon_mesh_processing;
constexpr std::uint32_t kNone = UINT32_MAX;

K::Point_3 to_cgal(const glm::dvec3& p) { return {p.x, p.y, p.z}; }
glm::dvec3 to_glm(const K::Point_3& p) { return {p.x(), p.y(), p.z()}; }

/// One lateral's junction: the ball its region lies in.
struct CollarSite {
  glm::dvec3 centre;
  double radius = 0;  ///< of the ball
  double lateral = 0;  ///< the lateral's radius
  /// The fork's node and the lateral's first node in the skeleton measured against.
  std::uint32_t fork_m = 0, child_m = 0;
};

/// A round cone: the skeleton edge from `a` (radius ra) to `b` (radius rb), measured from its
/// axis point nearest p (not the exact hull of the two spheres: the edges' radii change slowly).
struct Cone {
  glm::dvec3 a, b;
  double ra = 0, rb = 0;
  struct Near {
    double distance;  ///< signed, negative inside
    double radius;    ///< the cone's radius there
  };
  [[nodiscard]] Near at(const glm::dvec3& p) const {
    const double t = segment_param(p, a, b);
    const double r = ra + t * (rb - ra);
    return {glm::length(p - (a + t * (b - a))) - r, r};
  }
};

/// The surface a collar follows: the union of the parent's cones and the lateral's, blended
/// (polynomial smooth minimum over `blend`), each side the plain union of its own cones.
struct CollarField {
  std::vector<Cone> parent, lateral;
  double blend = 0;
  [[nodiscard]] double operator()(const glm::dvec3& p) const {
    double dp = 1e300, dl = 1e300;
    for (const Cone& c : parent) dp = std::min(dp, c.at(p).distance);
    for (const Cone& c : lateral) dl = std::min(dl, c.at(p).distance);
    const double h = std::max(blend - std::abs(dp - dl), 0.0) / blend;
    return std::min(dp, dl) - h * h * blend * 0.25;
  }
  /// The radius of the cone nearest `p`.
  [[nodiscard]] double radius(const glm::dvec3& p) const {
    double best = 1e300, r = 0;
    for (const auto* side : {&parent, &lateral}) {
      for (const Cone& c : *side) {
        const Cone::Near n = c.at(p);
        if (n.distance < best) best = n.distance, r = n.radius;
      }
    }
    return r;
  }
  /// The nearest point of the zero level (Newton steps along the numerical gradient).
  [[nodiscard]] glm::dvec3 project(glm::dvec3 p, double step, int steps = 6) const {
    for (int it = 0; it < steps; ++it) {
      const double d = (*this)(p);
      const glm::dvec3 g((*this)(p + glm::dvec3(step, 0, 0)) - (*this)(p - glm::dvec3(step, 0, 0)),
                         (*this)(p + glm::dvec3(0, step, 0)) - (*this)(p - glm::dvec3(0, step, 0)),
                         (*this)(p + glm::dvec3(0, 0, step)) - (*this)(p - glm::dvec3(0, 0, step)));
      const double gl = glm::length(g) / (2 * step);
      if (!(gl > 1e-6)) break;
      p -= d * (g / (2 * step)) / (gl * gl);
      if (std::abs(d) < 1e-4 * step) break;
    }
    return p;
  }
};

/// The cones of `m` (the skeleton measured against) within `reach` of the site: the lateral's
/// subtree's and the rest's.
CollarField field_of(const Skeleton& m, const CollarSite& j, double reach, double blend) {
  CollarField f;
  f.blend = blend;
  for (std::size_t x = 0; x < m.size(); ++x) {
    const NodeId p = m.parent[x];
    if (!p.valid()) continue;
    // (The cones `check` measures against: a lateral starts at its parent's radius.)
    const Cone c{m.position[p.idx()], m.position[x], m.start_radius(NodeId(static_cast<std::uint32_t>(x))), m.radius[x]};
    if (c.at(j.centre).distance > reach) continue;
    // In the lateral's subtree: x reaches the lateral's first node before the fork.
    bool lateral = false;
    for (std::size_t y = x;;) {
      if (y == j.child_m) {
        lateral = true;
        break;
      }
      if (y == j.fork_m || !m.parent[y].valid()) break;
      y = m.parent[y].idx();
    }
    (lateral ? f.lateral : f.parent).push_back(c);
  }
  return f;
}

/// The sites of `s`'s laterals, with their nodes in `m` (the input, or `s` itself): the fork's
/// nearest input ancestor and the lateral's first input node down its main line.
std::vector<CollarSite> junctions(const Skeleton& s, const Skeleton& m, const CollarOptions& o) {
  std::unordered_map<std::int64_t, std::uint32_t> index;
  const bool same = &m == &s;
  if (!same) {
    for (std::size_t i = 0; i < m.size(); ++i) index.emplace(m.source_id[i], static_cast<std::uint32_t>(i));
  }
  auto in_m = [&](std::size_t x) -> std::optional<std::uint32_t> {
    if (same) return static_cast<std::uint32_t>(x);
    if (s.source_id[x] < 0) return std::nullopt;
    const auto it = index.find(s.source_id[x]);
    return it == index.end() ? std::nullopt : std::optional<std::uint32_t>(it->second);
  };
  std::vector<CollarSite> out;
  for (std::size_t n = 0; n < s.size(); ++n) {
    const NodeId l = s.children[n][1];
    if (!l.valid()) continue;
    const NodeId mc = s.children[n][0], p = s.parent[n];
    const glm::dvec3 at = s.position[n];
    glm::dvec3 axis = (mc.valid() ? s.position[mc.idx()] : at) - (p.valid() ? s.position[p.idx()] : at);
    const glm::dvec3 to = s.position[l.idx()] - at;
    const double len = glm::length(to);
    if (len <= 0 || glm::length(axis) <= 0) continue;
    axis = glm::normalize(axis);
    const glm::dvec3 d = to / len;
    const double sine = glm::length(glm::cross(axis, d));
    // Where the lateral's axis leaves the parent's tube (near the crotch for an acute one).
    const double t = std::min(len, s.radius[n] / std::max(sine, 0.5));
    const double rl = s.radius[l.idx()];
    std::optional<std::uint32_t> fork, child;
    for (std::size_t y = n; !fork;) {
      fork = in_m(y);
      if (!s.parent[y].valid()) break;
      y = s.parent[y].idx();
    }
    for (std::size_t y = l.idx(); !child;) {
      child = in_m(y);
      if (!s.children[y][0].valid()) break;
      y = s.children[y][0].idx();
    }
    if (!fork || !child) continue;
    out.push_back({at + d * t, o.reach * rl, rl, *fork, *child});
  }
  return out;
}

/// What a region became: its new vertices and triangles, in the mesh's numbering where they
/// are the mesh's border vertices, else (kNone) as new vertex k: `fresh[k]`.
struct Made {
  std::vector<std::uint32_t> faces;              ///< the mesh's triangles replaced
  std::vector<glm::dvec3> fresh;                 ///< new vertices
  std::vector<std::array<std::int64_t, 3>> triangles;  ///< >= 0: mesh vertex; < 0: fresh[-1 - i]
  std::vector<std::uint32_t> origin;             ///< per new triangle: the replaced triangle nearest it
  /// Per split border edge (a, b) of the mesh: the new vertices on it, from a to b.
  std::vector<std::pair<std::array<std::uint32_t, 2>, std::vector<std::int64_t>>> splits;
  enum class Verdict { made, shape, move } verdict = Verdict::shape;
};

/// `faces` (sorted) and every triangle whose corners are all theirs, sorted: a region closed so,
/// no triangle outside it has two border edges (its split would need more than a fan).
std::vector<std::uint32_t> closed_region(const Mesh& mesh, const VertexCorners& vc, std::vector<std::uint32_t> faces) {
  std::vector<std::uint32_t> verts;
  for (const std::uint32_t f : faces) verts.insert(verts.end(), mesh.triangles[f].begin(), mesh.triangles[f].end());
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  std::vector<std::uint32_t> closing;
  for (const std::uint32_t v : verts) {
    for (std::uint32_t i = vc.begin[v]; i < vc.begin[v + 1]; ++i) {
      const std::uint32_t f = vc.corner[i] / 3;
      const auto& t = mesh.triangles[f];
      if (t[0] == t[1] || std::binary_search(faces.begin(), faces.end(), f)) continue;
      if (std::all_of(t.begin(), t.end(), [&](std::uint32_t w) { return std::binary_search(verts.begin(), verts.end(), w); })) {
        closing.push_back(f);
      }
    }
  }
  faces.insert(faces.end(), closing.begin(), closing.end());
  std::sort(faces.begin(), faces.end());
  faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
  return faces;
}

/// The region of one junction: of the triangles reaching into its ball (`near`: the vertices
/// around it), the connected piece with the most of them (through shared edges), closed.
std::vector<std::uint32_t> region_of(const Mesh& mesh, const VertexCorners& vc, const CollarSite& j,
                                     std::span<const std::uint32_t> near) {
  // The triangles that reach into the ball (their nearest point to its centre within it).
  std::vector<std::uint32_t> faces;
  for (const std::uint32_t v : near) {
    for (std::uint32_t i = vc.begin[v]; i < vc.begin[v + 1]; ++i) faces.push_back(vc.corner[i] / 3);
  }
  std::sort(faces.begin(), faces.end());
  faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
  std::erase_if(faces, [&](std::uint32_t f) {
    const auto& t = mesh.triangles[f];
    if (t[0] == t[1]) return true;
    const glm::dvec3 q = closest_on_triangle(j.centre, mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]);
    return glm::length(q - j.centre) > j.radius;
  });
  if (faces.empty()) return faces;
  // Pieces through shared edges.
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> edge_faces;
  for (std::uint32_t k = 0; k < faces.size(); ++k) {
    const auto& t = mesh.triangles[faces[k]];
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = t[e], b = t[(e + 1) % 3];
      edge_faces[{std::min(a, b), std::max(a, b)}].push_back(k);
    }
  }
  std::vector<std::uint32_t> piece(faces.size(), kNone);
  std::vector<std::size_t> sizes;
  for (std::uint32_t k = 0; k < faces.size(); ++k) {
    if (piece[k] != kNone) continue;
    const auto id = static_cast<std::uint32_t>(sizes.size());
    std::vector<std::uint32_t> stack{k};
    piece[k] = id;
    std::size_t n = 0;
    while (!stack.empty()) {
      const std::uint32_t q = stack.back();
      stack.pop_back();
      ++n;
      const auto& t = mesh.triangles[faces[q]];
      for (int e = 0; e < 3; ++e) {
        const std::uint32_t a = t[e], b = t[(e + 1) % 3];
        for (const std::uint32_t w : edge_faces[{std::min(a, b), std::max(a, b)}]) {
          if (piece[w] == kNone) {
            piece[w] = id;
            stack.push_back(w);
          }
        }
      }
    }
    sizes.push_back(n);
  }
  const auto best = static_cast<std::uint32_t>(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
  std::vector<std::uint32_t> out;
  for (std::uint32_t k = 0; k < faces.size(); ++k) {
    if (piece[k] == best) out.push_back(faces[k]);
  }
  return closed_region(mesh, vc, std::move(out));
}

/// The longest edge the remeshing keeps for target edge h (CGAL's 4/3 h, a little less): the
/// region's longer border edges are split, and grown across before that.
double longest_kept(double h) { return 4.0 / 3.0 * h * 0.99; }

/// The target edge of a region: `edge` lateral radii, longer where the region is too large for
/// `max_region_triangles` of it.
double target_edge(const Mesh& mesh, std::span<const std::uint32_t> faces, const CollarSite& j, const CollarOptions& o) {
  double area = 0;
  for (const std::uint32_t f : faces) area += 0.5 * glm::length(mesh.face_normal(mesh.triangles[f]));
  // (About 2.3 area / h^2 triangles of edge h.)
  return std::max(o.edge * j.lateral, std::sqrt(2.3 * area / double(o.max_region_triangles)));
}

/// `faces` grown across its border edges longer than the remeshing keeps (4/3 of the target
/// edge) by the triangle outside, `rounds` times at most, then closed (every triangle with
/// all corners in it joins): the border then runs along a coarse tube's short ring edges, not
/// its long strips, whose split would fan the triangle outside into needles.
std::vector<std::uint32_t> grown(const Mesh& mesh, const VertexCorners& vc, std::vector<std::uint32_t> faces,
                                 const CollarSite& j, const CollarOptions& o) {
  if (faces.empty()) return faces;
  const double longest = longest_kept(target_edge(mesh, faces, j, o));
  for (int round = 0; round < o.grow_rounds; ++round) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> count;
    for (const std::uint32_t f : faces) {
      const auto& t = mesh.triangles[f];
      for (int e = 0; e < 3; ++e) ++count[{std::min(t[e], t[(e + 1) % 3]), std::max(t[e], t[(e + 1) % 3])}];
    }
    std::vector<std::uint32_t> more;
    for (const auto& [e, n] : count) {
      if (n != 1 || glm::length(mesh.positions[e.first] - mesh.positions[e.second]) <= longest) continue;
      for (std::uint32_t i = vc.begin[e.first]; i < vc.begin[e.first + 1]; ++i) {
        const std::uint32_t f = vc.corner[i] / 3;
        const auto& t = mesh.triangles[f];
        if (t[0] != t[1] && std::find(t.begin(), t.end(), e.second) != t.end() &&
            !std::binary_search(faces.begin(), faces.end(), f)) {
          more.push_back(f);
        }
      }
    }
    if (more.empty()) break;
    faces.insert(faces.end(), more.begin(), more.end());
    std::sort(faces.begin(), faces.end());
    faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
  }
  return closed_region(mesh, vc, std::move(faces));
}

/// Remeshes a region and lays it onto the collar's surface (read-only on the mesh).
Made make_region(const Mesh& mesh, const VertexCorners& vc, std::vector<std::uint32_t> faces, const CollarSite& j,
                 const CollarField& field, const CollarOptions& o) {
  Made out;
  out.faces = faces;
  std::vector<std::uint32_t> verts;
  for (const std::uint32_t f : faces) verts.insert(verts.end(), mesh.triangles[f].begin(), mesh.triangles[f].end());
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  SMesh sm;
  auto global = sm.add_property_map<VD, std::uint32_t>("v:global", kNone).first;
  for (const std::uint32_t v : verts) global[sm.add_vertex(to_cgal(mesh.positions[v]))] = v;
  auto local = [&](std::uint32_t v) {
    return VD(static_cast<std::uint32_t>(std::lower_bound(verts.begin(), verts.end(), v) - verts.begin()));
  };
  for (const std::uint32_t f : faces) {
    const auto& t = mesh.triangles[f];
    if (sm.add_face(local(t[0]), local(t[1]), local(t[2])) == SMesh::null_face()) return out;
  }
  // A disc with holes: genus 0 with its border loops.
  std::vector<SMesh::Halfedge_index> border;
  PMP::border_halfedges(sm.faces(), sm, std::back_inserter(border));
  if (border.empty()) return out;
  {
    std::vector<std::uint8_t> seen(sm.number_of_halfedges(), 0);
    long loops = 0;
    for (const auto h : border) {
      if (seen[h.idx()]) continue;
      ++loops;
      for (auto g = h; !seen[g.idx()]; g = sm.next(g)) seen[g.idx()] = 1;
    }
    const long euler = long(sm.number_of_vertices()) - long(sm.number_of_edges()) + long(sm.number_of_faces());
    if (euler != 2 - loops) return out;
  }
  const SMesh original = sm;  // for the attributes of the new triangles
  const double h = target_edge(mesh, faces, j, o);
  // Before the work, what would refuse it: a vertex farther from the collar's surface than a
  // move allows, or a border edge whose split would fan the triangle outside it into ones
  // thinner than `min_angle` (or than it was: on a twig's long strips they would be needles).
  for (const auto v : sm.vertices()) {
    if (sm.is_border(v)) continue;
    const glm::dvec3 p = to_glm(sm.point(v));
    if (std::abs(field(p)) > o.max_move * std::max(j.lateral, field.radius(p))) {
      out.verdict = Made::Verdict::move;
      return out;
    }
  }
  const double longest = longest_kept(h);
  for (const auto e : border) {
    const std::uint32_t a = global[sm.source(e)], b = global[sm.target(e)];
    const glm::dvec3 pa = mesh.positions[a], pb = mesh.positions[b];
    const double len = glm::length(pb - pa);
    if (len <= longest) continue;
    int pieces = 1;  // (split_long_edges halves an edge until its parts are short enough)
    while (len / pieces > longest) pieces *= 2;
    for (std::uint32_t i = vc.begin[a]; i < vc.begin[a + 1]; ++i) {
      const std::uint32_t f = vc.corner[i] / 3;
      const auto& t = mesh.triangles[f];
      if (std::find(t.begin(), t.end(), b) == t.end() || std::binary_search(faces.begin(), faces.end(), f)) continue;
      std::uint32_t z = t[0];
      for (const std::uint32_t v : t) z = v != a && v != b ? v : z;
      const double limit = std::min(o.min_angle * std::numbers::pi / 180.0,
                                    smallest_angle(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]));
      for (int q = 0; q < pieces; ++q) {
        const glm::dvec3 u = pa + (pb - pa) * (double(q) / pieces), w = pa + (pb - pa) * (double(q + 1) / pieces);
        if (smallest_angle(mesh.positions[z], u, w) < limit) {
          out.verdict = Made::Verdict::shape;
          return out;
        }
      }
    }
  }
  try {
    std::vector<SMesh::Edge_index> border_edges;
    for (const auto e : border) border_edges.push_back(sm.edge(e));
    PMP::split_long_edges(border_edges, longest, sm);
    PMP::isotropic_remeshing(sm.faces(), h, sm,
                             PMP::parameters::number_of_iterations(3).protect_constraints(true));
  } catch (...) {
    return out;
  }
  sm.collect_garbage();
  // Rings from the border: how far in a vertex lies (the flow fades out towards it).
  std::vector<int> ring(sm.number_of_vertices(), -1);
  std::vector<VD> front;
  for (const auto v : sm.vertices()) {
    if (sm.is_border(v)) {
      ring[v.idx()] = 0;
      front.push_back(v);
    }
  }
  for (int k = 1; !front.empty(); ++k) {
    std::vector<VD> next;
    for (const VD v : front) {
      for (const auto w : CGAL::vertices_around_target(sm.halfedge(v), sm)) {
        if (ring[w.idx()] < 0) {
          ring[w.idx()] = k;
          next.push_back(w);
        }
      }
    }
    front = std::move(next);
  }
  // The surface flows onto the collar's: each step moves every vertex part of the way to the
  // field's zero level (a Newton step) and towards its neighbours' centroid, which keeps the
  // triangles from folding where nearest points jump (over a socket's flat triangles); fully
  // from the third ring in, less towards the border. A last step projects.
  const auto nvtx = sm.number_of_vertices();
  std::vector<glm::dvec3> start(nvtx), cur(nvtx), next(nvtx);
  for (const auto v : sm.vertices()) start[v.idx()] = cur[v.idx()] = to_glm(sm.point(v));
  auto weight = [&](VD v) {
    const double w = std::min(1.0, ring[v.idx()] / 3.0);
    return w * w * (3 - 2 * w);
  };
  const double step = 0.05 * j.lateral;
  for (int it = 0; it <= o.flow_steps; ++it) {
    const bool last = it == o.flow_steps;
    for (const auto v : sm.vertices()) {
      const glm::dvec3 p = cur[v.idx()];
      next[v.idx()] = p;
      if (ring[v.idx()] <= 0) continue;
      const glm::dvec3 q = field.project(p, step, last ? 6 : 1);
      if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) return out;
      glm::dvec3 c(0);
      int n = 0;
      for (const auto w : CGAL::vertices_around_target(sm.halfedge(v), sm)) c += cur[w.idx()], ++n;
      c /= double(std::max(n, 1));
      next[v.idx()] = last ? p + (q - p) * weight(v) : p + weight(v) * (0.5 * (q - p) + 0.3 * (c - p));
    }
    std::swap(cur, next);
  }
  for (const auto v : sm.vertices()) {
    const glm::dvec3 p = cur[v.idx()];
    if (ring[v.idx()] >= 3 && std::abs(field(p)) > 0.05 * j.lateral) return out;
    if (glm::length(p - start[v.idx()]) > o.max_move * std::max(j.lateral, field.radius(p))) {
      out.verdict = Made::Verdict::move;
      return out;
    }
    sm.point(v) = to_cgal(p);
  }
  // The result: border vertices that were the mesh's keep their numbers.
  std::vector<std::int64_t> id(sm.number_of_vertices(), 0);
  for (const auto v : sm.vertices()) {
    if (global[v] != kNone && sm.is_border(v)) {
      id[v.idx()] = global[v];
    } else {
      id[v.idx()] = -1 - static_cast<std::int64_t>(out.fresh.size());
      out.fresh.push_back(to_glm(sm.point(v)));
    }
  }
  // Split border edges: walk each border loop from one of the mesh's vertices.
  {
    std::vector<std::uint8_t> seen(sm.number_of_halfedges(), 0);
    for (const auto h0 : sm.halfedges()) {
      if (!sm.is_border(h0) || seen[h0.idx()] || global[sm.source(h0)] == kNone) continue;
      // Along the border halfedges (the face-less side runs opposite to the region's turn).
      std::vector<std::int64_t> between;
      std::uint32_t from = global[sm.source(h0)];
      for (auto g = h0; !seen[g.idx()]; g = sm.next(g)) {
        seen[g.idx()] = 1;
        const VD t = sm.target(g);
        if (global[t] != kNone) {
          if (!between.empty()) out.splits.push_back({{from, global[t]}, between});
          between.clear();
          from = global[t];
        } else {
          between.push_back(id[t.idx()]);
        }
      }
    }
  }
  // New triangles, each with the original triangle nearest its centroid (attributes).
  using Primitive = CGAL::AABB_face_graph_triangle_primitive<SMesh>;
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;
  Tree tree(original.faces().begin(), original.faces().end(), original);
  for (const auto f : sm.faces()) {
    std::array<std::int64_t, 3> t{};
    glm::dvec3 c(0);
    int k = 0;
    for (const auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) {
      t[k++] = id[v.idx()];
      c += to_glm(sm.point(v)) / 3.0;
    }
    out.triangles.push_back(t);
    const auto hit = tree.closest_point_and_primitive(to_cgal(c));
    out.origin.push_back(faces[hit.second.idx()]);
  }
  out.verdict = Made::Verdict::made;
  return out;
}

/// The corner UVs of triangle `p` (positions) from the affine map of triangle `o` of `mesh`
/// (its plane, extended beyond it).
std::array<glm::vec2, 3> uvs_from(const Mesh& mesh, std::uint32_t o, const std::array<glm::dvec3, 3>& p) {
  const auto& t = mesh.triangles[o];
  const auto& uv = mesh.corner_uvs[o];
  std::array<glm::vec2, 3> out{};
  for (int k = 0; k < 3; ++k) {
    const glm::dvec3 w = barycentric(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]], p[k]);
    out[k] = glm::vec2(glm::dvec2(uv[0]) * w.x + glm::dvec2(uv[1]) * w.y + glm::dvec2(uv[2]) * w.z);
  }
  return out;
}

}  // namespace

CollarStats make_collars(MeshResult& r, const Skeleton& skeleton, const CollarOptions& o,
                         std::optional<std::vector<std::array<std::uint32_t, 2>>>* pairs) {
  CollarStats st;
  Mesh& mesh = r.mesh;
  st.triangles_before = mesh.triangle_count();
  const Skeleton& measured = o.measure ? *o.measure : skeleton;
  const std::vector<CollarSite> all = junctions(skeleton, measured, o);
  st.laterals = all.size();
  if (all.empty() || mesh.empty()) {
    st.triangles_after = st.triangles_before;
    return st;
  }
  std::vector<std::uint8_t> done(all.size(), 0);
  for (int round = 0; round < o.rounds; ++round) {
    const std::size_t nv = mesh.vertex_count(), nf = mesh.triangle_count();
    const VertexCorners vc = vertex_corners(mesh);
    // Vertices of the pairs left: no region may hold them.
    std::vector<std::uint8_t> blocked(nv, 0);
    if (pairs && *pairs) {
      for (const auto& pr : **pairs) {
        for (const std::uint32_t f : pr) {
          for (const std::uint32_t v : mesh.triangles[f]) blocked[v] = 1;
        }
      }
    }
    std::vector<std::size_t> todo;  // the sites not yet made or given up
    for (std::size_t i = 0; i < all.size(); ++i) {
      if (!done[i]) todo.push_back(i);
    }
    if (todo.empty()) break;
    std::vector<std::vector<std::uint32_t>> regions(todo.size());
    {
      // Vertices sorted by x; each site scans those of its slab for the ones in its box.
      std::vector<std::uint32_t> order(nv);
      for (std::uint32_t v = 0; v < nv; ++v) order[v] = v;
      std::sort(order.begin(), order.end(),
                [&](std::uint32_t a, std::uint32_t b) { return mesh.positions[a].x < mesh.positions[b].x; });
      std::vector<double> xs(nv);
      for (std::size_t k = 0; k < nv; ++k) xs[k] = mesh.positions[order[k]].x;
      tbb::parallel_for(std::size_t{0}, todo.size(), [&](std::size_t k) {
        const CollarSite& j = all[todo[k]];
        const double reach = 3 * j.radius;  // (a triangle reaching into the ball from farther is left out)
        const auto lo = std::lower_bound(xs.begin(), xs.end(), j.centre.x - reach) - xs.begin();
        const auto hi = std::upper_bound(xs.begin(), xs.end(), j.centre.x + reach) - xs.begin();
        std::vector<std::uint32_t> near;
        for (auto q = lo; q < hi; ++q) {
          const glm::dvec3 d = mesh.positions[order[q]] - j.centre;
          if (std::abs(d.y) <= reach && std::abs(d.z) <= reach) near.push_back(order[q]);
        }
        regions[k] = grown(mesh, vc, region_of(mesh, vc, j, near), j, o);
      });
    }
    // This round's regions: vertex-disjoint, in skeleton order; the rest wait.
    std::vector<std::uint8_t> claimed(nv, 0);
    std::vector<std::size_t> chosen;  // indices into todo
    for (std::size_t k = 0; k < todo.size(); ++k) {
      if (regions[k].empty()) {
        done[todo[k]] = 1;
        continue;
      }
      bool free = true, pair = false;
      for (const std::uint32_t f : regions[k]) {
        for (const std::uint32_t v : mesh.triangles[f]) {
          free = free && !claimed[v];
          pair = pair || blocked[v];
        }
      }
      if (pair) {
        ++st.skipped_pairs;
        done[todo[k]] = 1;
        continue;
      }
      if (!free) continue;
      for (const std::uint32_t f : regions[k]) {
        for (const std::uint32_t v : mesh.triangles[f]) claimed[v] = 1;
      }
      chosen.push_back(k);
      done[todo[k]] = 1;
    }
    if (chosen.empty()) break;
    std::vector<Made> made(chosen.size());
    tbb::parallel_for(std::size_t{0}, chosen.size(), [&](std::size_t c) {
      const CollarSite& j = all[todo[chosen[c]]];
      made[c] = make_region(mesh, vc, regions[chosen[c]], j, field_of(measured, j, 2 * j.radius, o.blend * j.lateral), o);
    });
    st.regions += chosen.size();
    std::vector<std::uint8_t> keep(made.size(), 0);
    for (std::size_t c = 0; c < made.size(); ++c) {
      keep[c] = made[c].verdict == Made::Verdict::made;
      st.skipped_shape += made[c].verdict == Made::Verdict::shape;
      st.refused_move += made[c].verdict == Made::Verdict::move;
    }
    // Applies the kept regions to a copy of the mesh; new and fanned triangles name their region.
    const MeshResult before = r;
    std::vector<std::vector<std::uint32_t>> fanned(made.size());  // per region: the triangles outside it fanned
    std::vector<std::uint32_t> owner;  // per triangle of the result: region + 1, or 0
    std::vector<std::uint32_t> origin;  // per triangle of the result: triangle of `before`, or kNone
    auto apply = [&]() {
      r = before;
      Mesh& m = r.mesh;
      owner.assign(nf, 0);
      origin.resize(nf);
      for (std::uint32_t f = 0; f < nf; ++f) origin[f] = f;
      const bool uvs = m.corner_uvs.size() == nf, kinds = r.triangle_kind.size() == nf,
                 branches = m.triangle_branch.size() == nf, nodes = m.vertex_node.size() == nv,
                 strands = m.vertex_strand.size() == nv, normals = m.normals.size() == nv;
      auto push_triangle = [&](const Mesh::Triangle& t, std::uint32_t from, std::uint32_t region) {
        m.triangles.push_back(t);
        if (uvs) {
          const std::array<glm::dvec3, 3> p{m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]};
          m.corner_uvs.push_back(uvs_from(before.mesh, from, p));
        }
        if (kinds) r.triangle_kind.push_back(before.triangle_kind[from]);
        if (branches) m.triangle_branch.push_back(before.mesh.triangle_branch[from]);
        owner.push_back(region + 1);
        origin.push_back(kNone);
      };
      for (std::size_t c = 0; c < made.size(); ++c) {
        if (!keep[c]) continue;
        const Made& md = made[c];
        const auto base = static_cast<std::int64_t>(m.positions.size());
        for (std::size_t k = 0; k < md.fresh.size(); ++k) {
          m.positions.push_back(r.grid > 0 ? snap_to_grid(md.fresh[k], r.grid) : md.fresh[k]);
        }
        auto vertex = [&](std::int64_t i) { return static_cast<std::uint32_t>(i >= 0 ? i : base + (-1 - i)); };
        // Attributes of fresh vertices from the nearest corner of their triangle's origin.
        std::vector<std::uint32_t> like(md.fresh.size(), kNone);
        for (std::size_t k = 0; k < md.triangles.size(); ++k) {
          for (const std::int64_t i : md.triangles[k]) {
            if (i >= 0 || like[-1 - i] != kNone) continue;
            const auto& t = before.mesh.triangles[md.origin[k]];
            const glm::dvec3 p = md.fresh[-1 - i];
            std::uint32_t best = t[0];
            for (const std::uint32_t v : t) {
              if (glm::length(before.mesh.positions[v] - p) < glm::length(before.mesh.positions[best] - p)) best = v;
            }
            like[-1 - i] = best;
          }
        }
        for (std::size_t k = 0; k < md.fresh.size(); ++k) {
          const std::uint32_t w = like[k] == kNone ? md.triangles.empty() ? 0 : before.mesh.triangles[md.origin[0]][0] : like[k];
          if (nodes) m.vertex_node.push_back(before.mesh.vertex_node[w]);
          if (strands) m.vertex_strand.push_back(before.mesh.vertex_strand[w]);
          if (normals) m.normals.push_back(before.mesh.normals[w]);
        }
        for (const std::uint32_t f : md.faces) {
          const std::uint32_t u = m.triangles[f][0];
          m.triangles[f] = {u, u, u};
          origin[f] = kNone;
        }
        for (std::size_t k = 0; k < md.triangles.size(); ++k) {
          const auto& t = md.triangles[k];
          push_triangle({vertex(t[0]), vertex(t[1]), vertex(t[2])}, md.origin[k], static_cast<std::uint32_t>(c));
        }
        // Fans: the triangle outside on a split border edge.
        for (const auto& [edge, on] : md.splits) {
          const std::uint32_t a = edge[0], b = edge[1];
          std::uint32_t g = kNone;
          int at = -1;
          for (std::uint32_t i = vc.begin[a]; i < vc.begin[a + 1] && g == kNone; ++i) {
            const std::uint32_t f = vc.corner[i] / 3, k = vc.corner[i] % 3;
            const auto& t = m.triangles[f];
            if (t[(k + 1) % 3] == b || t[(k + 2) % 3] == b) {
              if (std::binary_search(md.faces.begin(), md.faces.end(), f)) continue;
              g = f;
              at = static_cast<int>(k);
            }
          }
          if (g == kNone) continue;  // (cannot happen on a closed mesh)
          const auto t = m.triangles[g];
          // The polygon runs x -> y along the edge, then z.
          std::vector<std::uint32_t> chain;
          std::uint32_t z;
          if (t[(at + 1) % 3] == b) {  // a -> b in this triangle
            chain.push_back(a);
            for (const std::int64_t i : on) chain.push_back(vertex(i));
            chain.push_back(b);
            z = t[(at + 2) % 3];
          } else {  // b -> a
            chain.push_back(b);
            for (auto it = on.rbegin(); it != on.rend(); ++it) chain.push_back(vertex(*it));
            chain.push_back(a);
            z = t[(at + 1) % 3];
          }
          const std::uint32_t from = g;
          fanned[c].push_back(g);
          m.triangles[g] = {z, chain[0], chain[1]};
          if (uvs) {
            m.corner_uvs[g] = uvs_from(before.mesh, from,
                                       {m.positions[z], m.positions[chain[0]], m.positions[chain[1]]});
          }
          owner[g] = static_cast<std::uint32_t>(c) + 1;
          origin[g] = kNone;
          for (std::size_t q = 1; q + 1 < chain.size(); ++q) push_triangle({z, chain[q], chain[q + 1]}, from, static_cast<std::uint32_t>(c));
        }
      }
    };
    // Checks: the surface closed, no pair made, no point left outside; regions failing one go
    // back. After regions went back for pairs or points, only their restored triangles can
    // make new pairs (the others were searched against everything), and only the points near
    // the regions can change sides.
    std::vector<std::uint32_t> near;  // indices into keep_inside
    for (std::size_t p = 0; p < o.keep_inside.size(); ++p) {
      for (std::size_t c = 0; c < made.size(); ++c) {
        const CollarSite& j = all[todo[chosen[c]]];
        if (keep[c] && glm::length(o.keep_inside[p] - j.centre) <= 3 * j.radius) {
          near.push_back(static_cast<std::uint32_t>(p));
          break;
        }
      }
    }
    std::vector<glm::dvec3> near_points;
    for (const std::uint32_t p : near) near_points.push_back(o.keep_inside[p]);
    const std::vector<std::uint8_t> inside_before =
        near_points.empty() ? std::vector<std::uint8_t>{} : inside_closed_mesh(before.mesh, near_points);
    std::optional<std::vector<std::uint32_t>> restored;  // set where only those need a search
    for (int attempt = 0; attempt < 4; ++attempt) {
      const std::vector<std::uint8_t> kept_before = keep;
      apply();
      std::vector<std::uint32_t> changed;
      for (std::uint32_t f = 0; f < owner.size(); ++f) {
        if (owner[f] && r.mesh.triangles[f][0] != r.mesh.triangles[f][1]) changed.push_back(f);
      }
      if (changed.empty()) break;
      // The triangles of the regions that go back this attempt, as restored in the next.
      auto going_back = [&]() {
        std::vector<std::uint32_t> out;
        for (std::size_t c = 0; c < made.size(); ++c) {
          if (!kept_before[c] || keep[c]) continue;
          out.insert(out.end(), made[c].faces.begin(), made[c].faces.end());
          out.insert(out.end(), fanned[c].begin(), fanned[c].end());
        }
        std::sort(out.begin(), out.end());
        out.erase(std::unique(out.begin(), out.end()), out.end());
        return out;
      };
      bool again = false;
      // Closed around every vertex of a changed triangle: each edge leaving it comes back.
      {
        const VertexCorners nc = vertex_corners(r.mesh);
        std::vector<std::uint32_t> around;
        for (const std::uint32_t f : changed) around.insert(around.end(), r.mesh.triangles[f].begin(), r.mesh.triangles[f].end());
        std::sort(around.begin(), around.end());
        around.erase(std::unique(around.begin(), around.end()), around.end());
        for (const std::uint32_t v : around) {
          std::vector<std::uint32_t> out_edges, in_edges;
          for (std::uint32_t i = nc.begin[v]; i < nc.begin[v + 1]; ++i) {
            const auto& t = r.mesh.triangles[nc.corner[i] / 3];
            if (t[0] == t[1]) continue;
            const std::uint32_t k = nc.corner[i] % 3;
            out_edges.push_back(t[(k + 1) % 3]);
            in_edges.push_back(t[(k + 2) % 3]);
          }
          std::sort(out_edges.begin(), out_edges.end());
          std::sort(in_edges.begin(), in_edges.end());
          const bool closed = out_edges == in_edges &&
                              std::adjacent_find(out_edges.begin(), out_edges.end()) == out_edges.end();
          if (closed) continue;
          for (std::uint32_t i = nc.begin[v]; i < nc.begin[v + 1]; ++i) {
            const std::uint32_t f = nc.corner[i] / 3;
            if (owner[f] && keep[owner[f] - 1]) {
              keep[owner[f] - 1] = 0;
              ++st.skipped_shape;
              again = true;
            }
          }
        }
      }
      if (again) {
        restored.reset();  // (this attempt searched no pair: the next searches all)
        continue;
      }
      for (const auto& pr : TriangleIntersections(r.mesh).pairs_touching(restored ? *restored : changed)) {
        for (const std::uint32_t f : pr) {
          if (owner[f] && keep[owner[f] - 1]) {
            keep[owner[f] - 1] = 0;
            ++st.refused_pairs;
            again = true;
          }
        }
      }
      if (!again && !near_points.empty()) {
        const std::vector<std::uint8_t> inside_after = inside_closed_mesh(r.mesh, near_points);
        for (std::size_t q = 0; q < near_points.size(); ++q) {
          if (!inside_before[q] || inside_after[q]) continue;
          // The regions whose ball holds the point (grown by a half), else the nearest one.
          std::size_t nearest = made.size();
          double best = INFINITY;
          bool found = false;
          for (std::size_t c = 0; c < made.size(); ++c) {
            const CollarSite& j = all[todo[chosen[c]]];
            const double d = glm::length(near_points[q] - j.centre);
            if (!keep[c]) continue;
            if (d <= 1.5 * j.radius) {
              keep[c] = 0;
              ++st.refused_inside;
              found = again = true;
            } else if (d < best) {
              best = d;
              nearest = c;
            }
          }
          if (!found && nearest < made.size()) {
            keep[nearest] = 0;
            ++st.refused_inside;
            again = true;
          }
        }
      }
      if (!again) break;
      restored = going_back();
      if (attempt == 3) std::fill(keep.begin(), keep.end(), 0), apply();
    }
    for (std::size_t c = 0; c < made.size(); ++c) st.made += keep[c];
    // Renumber: degenerate triangles dropped; the pairs left follow their triangles.
    const std::vector<std::uint32_t> from = drop_degenerate(r);
    if (pairs && *pairs) {
      std::vector<std::uint32_t> now(nf, kNone);
      for (std::uint32_t g = 0; g < from.size(); ++g) {
        if (origin[from[g]] != kNone) now[origin[from[g]]] = g;
      }
      for (auto& pr : **pairs) {
        pr = {std::min(now[pr[0]], now[pr[1]]), std::max(now[pr[0]], now[pr[1]])};
      }
      std::sort((*pairs)->begin(), (*pairs)->end());
    }
  }
  r.stats.vertices = mesh.vertex_count();
  r.stats.triangles = mesh.triangle_count();
  st.triangles_after = mesh.triangle_count();
  return st;
}

}  // namespace sm
