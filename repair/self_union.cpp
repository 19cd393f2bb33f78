// Self-union of a closed surface (see self_union.h). Kept in its own translation unit: CGAL's
// corefinement headers are the slowest of the project to compile.

#include "repair/self_union.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <tuple>

// CGAL's assertions stay on here even in release builds: a configuration the refinement cannot
// handle then throws (and the mesh is left as it was) instead of crashing.
#define CGAL_DEBUG 1
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/corefinement.h>
#include <CGAL/Surface_mesh.h>

#include "core/math.h"
#include "core/union_find.h"
#include "meshcheck/intersections.h"
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace sm {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using VertexIndex = SurfaceMesh::Vertex_index;
using FaceIndex = SurfaceMesh::Face_index;
using OriginMap = SurfaceMesh::Property_map<FaceIndex, std::uint32_t>;
namespace PMP = CGAL::Polygon_mesh_processing;
constexpr std::uint32_t kNone = UINT32_MAX;
// Verdicts on a patch or triangle: inside the union (dropped), on its boundary facing out
// (kept) or facing in (a part turned inside out: kept, flipped).
constexpr std::uint8_t kDrop = 0, kKeep = 1, kFlip = 2;

// Hands a triangle's input index on to the triangles it is cut into.
struct OriginVisitor : PMP::Corefinement::Default_visitor<SurfaceMesh> {
  explicit OriginVisitor(OriginMap map) : origin(map) {}
  void before_subface_creations(FaceIndex f_old, SurfaceMesh&) { current = origin[f_old]; }
  void after_subface_created(FaceIndex f_new, SurfaceMesh&) { origin[f_new] = current; }
  OriginMap origin;
  std::uint32_t current = kNone;
};

/// The triangle of `mesh` holding the half-edge a -> b, or kNone.
std::uint32_t triangle_with_edge(const Mesh& mesh, const VertexCorners& vc, std::uint32_t a, std::uint32_t b) {
  for (std::uint32_t k = vc.begin[a]; k < vc.begin[a + 1]; ++k) {
    const std::uint32_t c = vc.corner[k], f = c / 3;
    if (mesh.triangles[f][(c % 3 + 1) % 3] == b) return f;
  }
  return kNone;
}

/// Gives each vertex whose triangles form several fans a copy per fan (appended), drawn a
/// hundredth of the way to the centroid of the fan's other vertices; returns the count split.
/// Triangles at a vertex belong to one fan where they share an edge that no other triangle
/// uses; at an edge of four or more (two solids of the union touching along it), each
/// triangle is paired with its neighbour around the edge across the solid between them, so
/// that the solids come apart. With `grid` > 0 the copies are on that grid, each at least a
/// grid step from v, so the float32 file keeps them apart. `open` receives the triangles with
/// a half-edge a -> b that has no single twin b -> a, or is not unique, after the splits.
std::size_t split_pinches(Mesh& mesh, std::vector<NodeId>* node, std::vector<StrandId>* strand, double grid,
                          std::vector<std::uint32_t>& open) {
  const VertexCorners vc = vertex_corners(mesh);
  std::size_t split = 0;
  const auto nv = static_cast<std::uint32_t>(mesh.positions.size());
  // Most vertices are plain: their triangles form one cycle around them, each neighbour
  // reached by one edge leaving and one arriving. Those are found first, in parallel, and
  // skipped. (A split elsewhere keeps them plain: the two triangles of an edge to a split
  // vertex share that edge, so they go to the same copy.)
  std::vector<std::uint8_t> plain(nv, 0);
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, nv, 1 << 12), [&](const tbb::blocked_range<std::uint32_t>& r) {
    std::vector<std::uint32_t> leaving, arriving;
    for (std::uint32_t v = r.begin(); v != r.end(); ++v) {
      const std::uint32_t b = vc.begin[v], n = vc.begin[v + 1] - b;
      if (n < 2) continue;
      leaving.resize(n);
      arriving.resize(n);
      for (std::uint32_t i = 0; i < n; ++i) {
        const std::uint32_t c = vc.corner[b + i];
        leaving[i] = mesh.triangles[c / 3][(c % 3 + 1) % 3];
        arriving[i] = mesh.triangles[c / 3][(c % 3 + 2) % 3];
      }
      // Walk the cycle: from corner i, the corner arriving from where i leaves to.
      std::uint32_t i = 0, steps = 0;
      bool one_cycle = true;
      do {
        std::uint32_t next = n, count = 0, out_count = 0;
        for (std::uint32_t j = 0; j < n; ++j) {
          if (arriving[j] == leaving[i]) {
            next = j;
            ++count;
          }
          out_count += leaving[j] == leaving[i];
        }
        if (count != 1 || out_count != 1) {
          one_cycle = false;
          break;
        }
        i = next;
        ++steps;
      } while (i != 0 && steps <= n);
      plain[v] = one_cycle && steps == n;
    }
  });
  // The corners at each vertex that is not plain, after the splits: a fan of each copy, or all.
  std::vector<std::vector<std::uint32_t>> corners_at;
  for (std::uint32_t v = 0; v < nv; ++v) {
    if (plain[v]) continue;
    const std::uint32_t b = vc.begin[v], e = vc.begin[v + 1], n = e - b;
    if (n < 2) {
      if (n == 1) corners_at.push_back({vc.corner[b]});
      continue;
    }
    UnionFind fans(n);
    // Corners by the vertex after v (edge v -> x leaving) and before it (edge x -> v arriving).
    auto next_of = [&](std::uint32_t i) { const std::uint32_t c = vc.corner[b + i]; return mesh.triangles[c / 3][(c % 3 + 1) % 3]; };
    auto prev_of = [&](std::uint32_t i) { const std::uint32_t c = vc.corner[b + i]; return mesh.triangles[c / 3][(c % 3 + 2) % 3]; };
    std::map<std::uint32_t, std::pair<std::vector<std::uint32_t>, std::vector<std::uint32_t>>> around;  // x -> (leaving, arriving)
    for (std::uint32_t i = 0; i < n; ++i) {
      around[next_of(i)].first.push_back(i);
      around[prev_of(i)].second.push_back(i);
    }
    for (const auto& [x, sides] : around) {
      const auto& [leaving, arriving] = sides;
      if (leaving.size() == 1 && arriving.size() == 1) {
        fans.unite(leaving[0], arriving[0]);
        continue;
      }
      if (leaving.empty() || arriving.empty()) continue;
      // Around the axis v -> x, a triangle leaving v towards x faces the way the angle grows;
      // one arriving from x faces back. The solid between two neighbours around the axis lies
      // behind both: an arriving triangle and the next one counter-clockwise, a leaving one.
      const glm::dvec3 o = mesh.positions[v], axis = glm::normalize(mesh.positions[x] - o);
      const glm::dvec3 r0 = glm::normalize(glm::cross(axis, std::abs(axis.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0)));
      const glm::dvec3 r1 = glm::cross(axis, r0);
      std::vector<std::tuple<double, int, std::uint32_t>> ring;  // angle, leaving?, corner
      auto third = [&, x = x](std::uint32_t i) {  // (x by copy: clang 14 cannot capture a structured binding)
        const std::uint32_t c = vc.corner[b + i];
        const auto& t = mesh.triangles[c / 3];
        for (const std::uint32_t w : t) {
          if (w != v && w != x) return mesh.positions[w];
        }
        return o;
      };
      for (const std::uint32_t i : leaving) {
        const glm::dvec3 d = third(i) - o;
        ring.emplace_back(std::atan2(glm::dot(d, r1), glm::dot(d, r0)), 1, i);
      }
      for (const std::uint32_t i : arriving) {
        const glm::dvec3 d = third(i) - o;
        ring.emplace_back(std::atan2(glm::dot(d, r1), glm::dot(d, r0)), 0, i);
      }
      std::sort(ring.begin(), ring.end());
      for (std::size_t k = 0; k < ring.size(); ++k) {
        const auto& [a0, leave0, i0] = ring[k];
        const auto& [a1, leave1, i1] = ring[(k + 1) % ring.size()];
        if (!leave0 && leave1) fans.unite(i0, i1);
      }
    }
    std::vector<std::uint32_t> roots;
    for (std::uint32_t i = 0; i < n; ++i) {
      if (fans.find(i) == i) roots.push_back(i);
    }
    if (roots.size() < 2) {
      corners_at.emplace_back(vc.corner.begin() + b, vc.corner.begin() + e);
      continue;
    }
    ++split;
    // Every fan gets its own copy (v itself is left unused).
    for (const std::uint32_t root : roots) {
      glm::dvec3 sum(0.0);
      double count = 0;
      for (std::uint32_t i = 0; i < n; ++i) {
        if (fans.find(i) != root) continue;
        const std::uint32_t c = vc.corner[b + i];
        const auto& t = mesh.triangles[c / 3];
        sum += mesh.positions[t[(c % 3 + 1) % 3]] + mesh.positions[t[(c % 3 + 2) % 3]];
        count += 2;
      }
      corners_at.emplace_back();
      for (std::uint32_t i = 0; i < n; ++i) {
        if (fans.find(i) == root) corners_at.back().push_back(vc.corner[b + i]);
      }
      const auto copy = static_cast<std::uint32_t>(mesh.positions.size());
      mesh.positions.push_back(step_towards(mesh.positions[v], sum / count, grid));
      if (node) node->push_back((*node)[v]);
      if (strand) strand->push_back(StrandId{});
      for (std::uint32_t i = 0; i < n; ++i) {
        const std::uint32_t c = vc.corner[b + i];
        if (fans.find(i) == root) mesh.triangles[c / 3][c % 3] = copy;
      }
    }
  }
  // The open edges after the splits, as open_edge_triangles would find them on the whole
  // mesh: a half-edge a -> b at a vertex without exactly one of it and one twin b -> a. Plain
  // vertices have none.
  open.clear();
  for (const std::vector<std::uint32_t>& at : corners_at) {
    for (const std::uint32_t c : at) {
      const std::uint32_t b = mesh.triangles[c / 3][(c % 3 + 1) % 3];
      int same = 0, twin = 0;
      for (const std::uint32_t cj : at) {
        same += mesh.triangles[cj / 3][(cj % 3 + 1) % 3] == b;
        twin += mesh.triangles[cj / 3][(cj % 3 + 2) % 3] == b;
      }
      if (same != 1 || twin != 1) open.push_back(c / 3);
    }
  }
  std::sort(open.begin(), open.end());
  open.erase(std::unique(open.begin(), open.end()), open.end());
  return split;
}

/// The inradius of triangle (a, b, c) (0 where degenerate).
double inradius(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const double perimeter = glm::distance(a, b) + glm::distance(b, c) + glm::distance(c, a);
  return perimeter > 0 ? glm::length(glm::cross(b - a, c - a)) / perimeter : 0.0;
}

/// One attempt at the union of a set of pairs: refine their triangles, judge the patches.
class Attempt {
 public:
  Attempt(const Mesh& mesh, const VertexCorners& vc)
      : mesh_(mesh), vc_(vc), nf_(uint32_t(mesh.triangles.size())), intersections_(mesh) {}

  /// Refines the triangles of `pairs` and judges every patch. False with `problem` set when
  /// CGAL fails; otherwise `bad` lists the cut triangles (mesh indices) whose patches could not
  /// be judged consistently (empty: the union can be assembled).
  bool run(const std::vector<std::array<std::uint32_t, 2>>& pairs);
  /// Per corner k of mesh triangle f, at 3f + k, the triangle across its edge to k + 1 (after run()).
  [[nodiscard]] const std::vector<std::uint32_t>& across() const { return across_; }
  /// The cut triangles (mesh indices) with a piece kept flipped.
  [[nodiscard]] std::vector<std::uint32_t> flipped() const {
    std::vector<std::uint32_t> f;
    for (std::size_t i = 0; i < pieces_.size(); ++i) {
      if (piece_keep_[i] == kFlip) f.push_back(pieces_[i].origin);
    }
    return f;
  }
  /// Only the refinement of run(): whether CGAL can refine the triangles of `pairs`.
  bool refines(const std::vector<std::array<std::uint32_t, 2>>& pairs) {
    choose(pairs);
    return refine();
  }
  /// The mesh with the union in place (after run() left `bad` empty).
  void assemble(Mesh& out, std::vector<std::uint32_t>& origin, double grid, SelfUnionStats& st) const;

  std::string problem;
  std::vector<std::uint32_t> bad;
  std::size_t patches = 0, cut_triangles = 0;

 private:
  struct Piece {
    std::array<std::uint32_t, 3> v;  // refined vertex indices
    std::uint32_t origin, patch;
  };
  // The refinement of one group of cut triangles (refine_group), kept for later attempts.
  struct Refined {
    bool ok = false;
    std::string problem;
    std::vector<std::uint32_t> mesh_vertex;  // per vertex of the group's own: the mesh vertex
    std::vector<glm::dvec3> positions;       // per refined vertex: its own, then the new ones
    std::vector<Piece> pieces;               // in the group's numbering
    std::size_t patches = 0;
    std::vector<std::uint8_t> dangling;  // per patch
  };
  void choose(const std::vector<std::array<std::uint32_t, 2>>& pairs);
  [[nodiscard]] Refined refine_group(const std::vector<std::uint32_t>& group) const;
  bool refine();
  void canonicalize();
  void prepare();
  void judge();
  [[nodiscard]] std::uint32_t mesh_vertex(std::uint32_t r) const { return r < n_sub_ ? mesh_vertex_of_sub_[r] : kNone; }

  const Mesh& mesh_;
  const VertexCorners& vc_;
  std::uint32_t nf_;
  std::vector<std::uint32_t> local_, cut_;  // cut triangles: mesh index <-> local index
  std::vector<std::uint32_t> mesh_vertex_of_sub_;
  std::vector<std::uint32_t> first_cut_of_sub_;  // refine()'s: the first cut triangle at each
  std::uint32_t n_sub_ = 0;
  TriangleIntersections intersections_;
  std::map<std::vector<std::uint32_t>, Refined> cache_;  // by the group's triangles
  std::vector<Piece> pieces_;
  std::vector<glm::dvec3> refined_pos_;
  std::vector<std::uint8_t> dangling_;  // per patch: a cut line ends inside it
  std::vector<std::uint8_t> piece_keep_;  // per piece: kDrop, kKeep or kFlip
  std::vector<std::uint8_t> uncut_;     // per mesh triangle: its verdict where uncut
  std::vector<std::uint32_t> across_;   // prepare()'s: per corner k of f, 3f + k, the triangle across its edge to k + 1
  std::vector<double> inradius_;        // prepare()'s: per mesh triangle
};

// The cut triangles: those of the pairs, and where they meet at a vertex in several fans (not
// a manifold there), every triangle at that vertex, until they form one fan at each vertex:
// copies of a vertex would be points where the mesh touches itself, which the refinement
// cannot cut.
void Attempt::choose(const std::vector<std::array<std::uint32_t, 2>>& pairs) {
  std::vector<std::uint8_t> chosen(nf_, 0);
  std::vector<std::uint32_t> check;
  auto pick = [&](std::uint32_t f) {
    if (chosen[f]) return;
    chosen[f] = 1;
    for (const std::uint32_t v : mesh_.triangles[f]) check.push_back(v);
  };
  for (const auto& [a, b] : pairs) {
    pick(a);
    pick(b);
  }
  while (!check.empty()) {
    std::vector<std::uint32_t> vertices;
    vertices.swap(check);
    std::sort(vertices.begin(), vertices.end());
    vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
    for (const std::uint32_t v : vertices) {
      // One fan: at most one chosen triangle whose edge leaving v has no chosen neighbour.
      std::uint32_t open = 0, count = 0;
      for (std::uint32_t k = vc_.begin[v]; k < vc_.begin[v + 1]; ++k) {
        const std::uint32_t c = vc_.corner[k];
        if (!chosen[c / 3]) continue;
        ++count;
        const std::uint32_t next = mesh_.triangles[c / 3][(c % 3 + 1) % 3];
        const std::uint32_t g = triangle_with_edge(mesh_, vc_, next, v);
        if (g == kNone || !chosen[g]) ++open;
      }
      if (open <= 1 || count == vc_.begin[v + 1] - vc_.begin[v]) continue;
      for (std::uint32_t k = vc_.begin[v]; k < vc_.begin[v + 1]; ++k) pick(vc_.corner[k] / 3);
    }
  }
  local_.assign(nf_, kNone);
  cut_.clear();
  for (std::uint32_t f = 0; f < nf_; ++f) {
    if (chosen[f]) {
      local_[f] = static_cast<std::uint32_t>(cut_.size());
      cut_.push_back(f);
    }
  }
  cut_triangles = cut_.size();
}

// CGAL's autorefinement of one group of cut triangles (a surface mesh of their own), with
// the cut lines marked: its pieces (vertices numbered in the group: first its mesh vertices in
// the order the triangles reach them, then the new ones), their patches, and the patches a
// cut line ends in.
Attempt::Refined Attempt::refine_group(const std::vector<std::uint32_t>& group) const {
  Refined out;
  std::map<std::uint32_t, std::uint32_t> sub_of_vertex;
  SurfaceMesh sm;
  std::array<VertexIndex, 3> corner;
  for (const std::uint32_t f : group) {
    for (std::uint32_t k = 0; k < 3; ++k) {
      const auto [it, fresh] = sub_of_vertex.try_emplace(mesh_.triangles[f][k], std::uint32_t(out.mesh_vertex.size()));
      if (fresh) {
        out.mesh_vertex.push_back(mesh_.triangles[f][k]);
        const glm::dvec3& p = mesh_.positions[mesh_.triangles[f][k]];
        sm.add_vertex(Point(p.x, p.y, p.z));
      }
    }
  }
  OriginMap origin = sm.add_property_map<FaceIndex, std::uint32_t>("f:origin", kNone).first;
  for (const std::uint32_t f : group) {
    for (std::uint32_t k = 0; k < 3; ++k) corner[k] = VertexIndex(sub_of_vertex[mesh_.triangles[f][k]]);
    const FaceIndex face = sm.add_face(corner[0], corner[1], corner[2]);
    if (face == SurfaceMesh::null_face()) {
      out.problem = "the cut triangles do not form a manifold";
      return out;
    }
    origin[face] = f;
  }
  auto cut_edge = sm.add_property_map<SurfaceMesh::Edge_index, bool>("e:cut", false).first;
  try {
    PMP::experimental::autorefine(sm,
                                  CGAL::parameters::visitor(OriginVisitor(origin)).edge_is_constrained_map(cut_edge));
  } catch (const std::exception& e) {  // a CGAL precondition or an unexpected configuration
    out.problem = std::string("CGAL's autorefinement failed: ") + e.what();
    return out;
  }
  auto patch_map = sm.add_property_map<FaceIndex, std::size_t>("f:patch", 0).first;
  out.patches = PMP::connected_components(sm, patch_map, CGAL::parameters::edge_is_constrained_map(cut_edge));
  // A cut line that ends inside the surface (a fold at a vertex) leaves the same patch on
  // both sides of it: such a patch has no single winding number in front.
  out.dangling.assign(out.patches, 0);
  for (const auto e : sm.edges()) {
    if (!cut_edge[e]) continue;
    const auto h = sm.halfedge(e);
    const FaceIndex f = sm.face(h), g = sm.face(sm.opposite(h));
    if (f != SurfaceMesh::null_face() && g != SurfaceMesh::null_face() && patch_map[f] == patch_map[g])
      out.dangling[patch_map[f]] = 1;
  }
  out.pieces.reserve(sm.number_of_faces());
  for (const FaceIndex f : sm.faces()) {
    Piece p{};
    std::size_t k = 0;
    for (const VertexIndex v : CGAL::vertices_around_face(sm.halfedge(f), sm)) {
      if (k == 3) break;
      p.v[k++] = static_cast<std::uint32_t>(v.idx());
    }
    if (k != 3 || origin[f] == kNone) {
      out.problem = "the autorefinement made a face that is not a triangle of a known origin";
      return out;
    }
    p.origin = origin[f];
    p.patch = static_cast<std::uint32_t>(patch_map[f]);
    out.pieces.push_back(p);
  }
  out.positions.resize(sm.num_vertices());
  for (const VertexIndex v : sm.vertices()) {
    const Point& q = sm.point(v);
    out.positions[v.idx()] = glm::dvec3(q.x(), q.y(), q.z());
  }
  out.ok = true;
  return out;
}

// The refinement of the cut triangles, put together from that of their groups: triangles
// joined through shared vertices or crossing each other (including crossings no given pair
// holds), which the refinement of all of them at once would cut alike, as nothing joins two
// groups. The mesh does not change between attempts, which mostly leave out a few curves: a
// group met before is taken from the cache. Then the whole is numbered as one refinement
// would be (canonicalize).
bool Attempt::refine() {
  const auto nc = static_cast<std::uint32_t>(cut_.size());
  std::vector<std::uint32_t> sub_of_vertex(mesh_.positions.size(), kNone);
  mesh_vertex_of_sub_.clear();
  UnionFind joined(nc);
  for (std::uint32_t i = 0; i < nc; ++i) {
    for (std::uint32_t k = 0; k < 3; ++k) {
      std::uint32_t& s = sub_of_vertex[mesh_.triangles[cut_[i]][k]];
      if (s == kNone) {
        s = static_cast<std::uint32_t>(mesh_vertex_of_sub_.size());
        mesh_vertex_of_sub_.push_back(mesh_.triangles[cut_[i]][k]);
        first_cut_of_sub_.resize(mesh_vertex_of_sub_.size());
        first_cut_of_sub_[s] = i;
      }
      joined.unite(i, first_cut_of_sub_[s]);
    }
  }
  n_sub_ = static_cast<std::uint32_t>(mesh_vertex_of_sub_.size());
  for (const auto& [f, g] : intersections_.pairs(cut_)) joined.unite(local_[f], local_[g]);
  std::map<std::uint32_t, std::vector<std::uint32_t>> groups;  // by root: mesh triangles, ascending
  for (std::uint32_t i = 0; i < nc; ++i) groups[joined.find(i)].push_back(cut_[i]);
  std::vector<const Refined*> parts;
  for (auto& [root, group] : groups) {
    auto it = cache_.find(group);
    if (it == cache_.end()) {
      Refined r = refine_group(group);
      it = cache_.emplace(std::move(group), std::move(r)).first;
    }
    if (!it->second.ok) {
      problem = it->second.problem;
      return false;
    }
    parts.push_back(&it->second);
  }
  pieces_.clear();
  refined_pos_.assign(n_sub_, glm::dvec3(0.0));
  for (std::uint32_t r = 0; r < n_sub_; ++r) refined_pos_[r] = mesh_.positions[mesh_vertex_of_sub_[r]];
  dangling_.clear();
  patches = 0;
  std::vector<std::uint32_t> renumber;
  for (const Refined* part : parts) {
    const auto nsub = static_cast<std::uint32_t>(part->mesh_vertex.size());
    renumber.assign(part->positions.size(), kNone);
    for (std::uint32_t r = 0; r < part->positions.size(); ++r) {
      if (r < nsub) {
        renumber[r] = sub_of_vertex[part->mesh_vertex[r]];
        refined_pos_[renumber[r]] = part->positions[r];
      } else {
        renumber[r] = static_cast<std::uint32_t>(refined_pos_.size());
        refined_pos_.push_back(part->positions[r]);
      }
    }
    const auto patch0 = static_cast<std::uint32_t>(patches);
    for (Piece p : part->pieces) {
      for (std::uint32_t& v : p.v) v = renumber[v];
      p.patch += patch0;
      pieces_.push_back(p);
    }
    dangling_.insert(dangling_.end(), part->dangling.begin(), part->dangling.end());
    patches += part->patches;
  }
  canonicalize();
  return true;
}

// CGAL hands back its new vertices and faces in an order that depends on heap addresses (which
// differ from run to run when other threads allocate): new vertices are put in the order of
// their positions, pieces in the order of their origins and corners, patches in the order of
// their first piece, so that what follows depends on the geometry only.
void Attempt::canonicalize() {
  const auto nv = static_cast<std::uint32_t>(refined_pos_.size());
  std::vector<std::array<std::uint32_t, 2>> touching(nv, {kNone, 0});  // (least, greatest) origin
  for (const Piece& p : pieces_) {
    for (const std::uint32_t v : p.v) {
      touching[v][0] = std::min(touching[v][0], p.origin);
      touching[v][1] = std::max(touching[v][1], p.origin);
    }
  }
  std::vector<std::uint32_t> added(nv - n_sub_);
  std::iota(added.begin(), added.end(), n_sub_);
  const auto key = [&](std::uint32_t v) {
    const glm::dvec3& p = refined_pos_[v];
    return std::tuple(p.x, p.y, p.z, touching[v][0], touching[v][1]);
  };
  std::sort(added.begin(), added.end(), [&](std::uint32_t a, std::uint32_t b) { return key(a) < key(b); });
  std::vector<std::uint32_t> renumber(nv);
  std::iota(renumber.begin(), renumber.begin() + n_sub_, 0u);
  std::vector<glm::dvec3> pos(refined_pos_.begin(), refined_pos_.begin() + n_sub_);
  for (const std::uint32_t v : added) {
    renumber[v] = static_cast<std::uint32_t>(pos.size());
    pos.push_back(refined_pos_[v]);
  }
  refined_pos_ = std::move(pos);
  for (Piece& p : pieces_) {
    for (std::uint32_t& v : p.v) v = renumber[v];
    std::rotate(p.v.begin(), std::min_element(p.v.begin(), p.v.end()), p.v.end());  // keeps the orientation
  }
  std::sort(pieces_.begin(), pieces_.end(),
            [](const Piece& a, const Piece& b) { return std::tie(a.origin, a.v) < std::tie(b.origin, b.v); });
  std::vector<std::uint32_t> patch(patches, kNone);
  std::vector<std::uint8_t> dangling(patches, 0);
  std::uint32_t next = 0;
  for (Piece& p : pieces_) {
    if (patch[p.patch] == kNone) {
      dangling[next] = dangling_[p.patch];
      patch[p.patch] = next++;
    }
    p.patch = patch[p.patch];
  }
  dangling_ = std::move(dangling);
}

// Winding numbers: a point just in front of and one just behind the roundest piece of every
// patch, and of the roundest triangle of every region of uncut triangles next to a cut one
// (joined through uncut edges: no surface crosses it, so one verdict holds for all of it),
// tested all at once by ray crossings against the whole surface. A patch that a cut line ends
// in (where the surface folds through itself at a vertex) has no single verdict: each of its
// pieces is judged on its own. A cut line along an uncut triangle's side (the refinement split
// an edge the mesh shares with a triangle it did not cut) makes the patches there `bad`.
// The tables of the mesh judge() reads on every attempt, made on the first (the mesh does
// not change between attempts): the triangle across each edge, and each triangle's inradius.
void Attempt::prepare() {
  if (across_.size() == 3 * std::size_t{nf_}) return;
  across_.resize(3 * std::size_t{nf_});
  inradius_.resize(nf_);
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, nf_, 1 << 12), [&](const tbb::blocked_range<std::uint32_t>& r) {
    for (std::uint32_t f = r.begin(); f != r.end(); ++f) {
      const auto& t = mesh_.triangles[f];
      for (int k = 0; k < 3; ++k) across_[3 * f + k] = triangle_with_edge(mesh_, vc_, t[(k + 1) % 3], t[k]);
      inradius_[f] = inradius(mesh_.positions[t[0]], mesh_.positions[t[1]], mesh_.positions[t[2]]);
    }
  });
}

void Attempt::judge() {
  const auto np = static_cast<std::uint32_t>(patches);
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> patch_on_edge;  // directed mesh edge
  for (const Piece& p : pieces_) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = mesh_vertex(p.v[k]), b = mesh_vertex(p.v[(k + 1) % 3]);
      if (a != kNone && b != kNone) patch_on_edge[{a, b}] = p.patch;
    }
  }
  prepare();
  std::vector<std::uint8_t> bad_patch(np, 0), touches(nf_, 0);
  UnionFind region(nf_);
  for (std::uint32_t f = 0; f < nf_; ++f) {
    if (local_[f] != kNone) continue;
    const auto& t = mesh_.triangles[f];
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t[k], b = t[(k + 1) % 3];
      const std::uint32_t g = across_[3 * f + k];
      if (g == kNone) continue;
      if (local_[g] == kNone) {
        region.unite(f, g);
      } else if (patch_on_edge.contains({b, a})) {
        touches[f] = 1;
      } else {  // the edge was cut: a cut line along an uncut triangle's side
        for (const Piece& p : pieces_) {
          if (p.origin == g) bad_patch[p.patch] = 1;
        }
      }
    }
  }
  std::vector<double> piece_r(pieces_.size());
  std::vector<std::pair<double, std::uint32_t>> best_piece(np, {-1.0, 0});
  for (std::uint32_t i = 0; i < pieces_.size(); ++i) {
    const auto& v = pieces_[i].v;
    piece_r[i] = inradius(refined_pos_[v[0]], refined_pos_[v[1]], refined_pos_[v[2]]);
    if (piece_r[i] > best_piece[pieces_[i].patch].first) best_piece[pieces_[i].patch] = {piece_r[i], i};
  }
  // Regions next to a cut triangle, by root: their roundest triangle.
  std::vector<std::uint8_t> region_touches(nf_, 0);
  for (std::uint32_t f = 0; f < nf_; ++f) {
    if (touches[f]) region_touches[region.find(f)] = 1;
  }
  std::vector<std::uint32_t> best_uncut(nf_, kNone);  // by root (in increasing order: deterministic)
  for (std::uint32_t f = 0; f < nf_; ++f) {
    if (local_[f] != kNone) continue;
    const std::uint32_t root = region.find(f);
    if (!region_touches[root]) continue;
    std::uint32_t& best = best_uncut[root];
    if (best == kNone || inradius_[f] > inradius_[best]) best = f;
  }
  std::vector<glm::dvec3> probe;
  auto add_probe = [&](const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, double r) {
    const glm::dvec3 n = glm::normalize(glm::cross(b - a, c - a));
    const glm::dvec3 centre = (a + b + c) / 3.0, d = 0.01 * r * n;
    probe.push_back(centre + d);
    probe.push_back(centre - d);
  };
  auto piece_probe = [&](std::uint32_t i) {
    const auto& v = pieces_[i].v;
    if (piece_r[i] > 0) {
      add_probe(refined_pos_[v[0]], refined_pos_[v[1]], refined_pos_[v[2]], piece_r[i]);
    } else {
      probe.insert(probe.end(), 2, glm::dvec3(0.0));
    }
  };
  for (std::uint32_t k = 0; k < np; ++k) piece_probe(best_piece[k].second);
  std::vector<std::uint32_t> own_probe(pieces_.size(), kNone);  // pieces of dangling patches
  for (std::uint32_t i = 0; i < pieces_.size(); ++i) {
    if (!dangling_[pieces_[i].patch] || !(piece_r[i] > 0)) continue;
    own_probe[i] = static_cast<std::uint32_t>(probe.size());
    piece_probe(i);
  }
  std::vector<std::size_t> region_probe(nf_, SIZE_MAX);  // by root
  for (std::uint32_t root = 0; root < nf_; ++root) {
    const std::uint32_t best = best_uncut[root];
    if (best == kNone) continue;
    const auto& t = mesh_.triangles[best];
    region_probe[root] = probe.size();
    add_probe(mesh_.positions[t[0]], mesh_.positions[t[1]], mesh_.positions[t[2]], inradius_[best]);
  }
  const std::vector<int> winding = winding_numbers(mesh_, probe);
  // Kept where exactly one side is outside (winding number 0), facing it: a side turned
  // inside out (-1 in front, 0 behind) is flipped rather than dropped, which would cut the
  // branch it belongs to off the tree.
  auto judge_sides = [&](std::size_t i) -> std::uint8_t {
    const int front = winding[i], back = winding[i + 1];
    if (front == 0 && back != 0) return kKeep;
    if (front != 0 && back == 0) return kFlip;
    return kDrop;
  };
  piece_keep_.resize(pieces_.size());
  for (std::uint32_t i = 0; i < pieces_.size(); ++i) {
    piece_keep_[i] = judge_sides(own_probe[i] != kNone ? own_probe[i] : 2 * std::size_t{pieces_[i].patch});
  }
  bad.clear();
  for (const Piece& p : pieces_) {
    if (bad_patch[p.patch]) bad.push_back(p.origin);
  }
  std::sort(bad.begin(), bad.end());
  bad.erase(std::unique(bad.begin(), bad.end()), bad.end());
  uncut_.assign(nf_, kKeep);
  for (std::uint32_t f = 0; f < nf_; ++f) {
    if (local_[f] != kNone) continue;
    if (const std::size_t at = region_probe[region.find(f)]; at != SIZE_MAX) uncut_[f] = judge_sides(at);
  }
}

bool Attempt::run(const std::vector<std::array<std::uint32_t, 2>>& pairs) {
  choose(pairs);
  if (!refine()) return false;
  judge();
  return true;
}

void Attempt::assemble(Mesh& out, std::vector<std::uint32_t>& origin_of, double grid, SelfUnionStats& st) const {
  const Mesh& mesh = mesh_;
  const std::uint32_t nf = nf_;
  // The new vertices: refined vertices that are not mesh vertices, welded by position (the
  // refinement makes one per side of a cut line).
  std::vector<std::uint32_t> out_vertex(refined_pos_.size(), kNone);
  std::map<std::tuple<double, double, double>, std::uint32_t> at;
  const auto nv = static_cast<std::uint32_t>(mesh.positions.size());
  std::vector<glm::dvec3> new_pos;
  std::vector<std::uint32_t> new_origin;  // a cut triangle the new vertex lies on
  for (std::size_t i = 0; i < pieces_.size(); ++i) {
    const Piece& p = pieces_[i];
    if (piece_keep_[i] == kDrop) continue;
    for (const std::uint32_t r : p.v) {
      if (out_vertex[r] != kNone) continue;
      if (r < n_sub_) {
        out_vertex[r] = mesh_vertex_of_sub_[r];
        continue;
      }
      glm::dvec3 q = refined_pos_[r];
      if (grid > 0) q = snap_to_grid(q, grid);
      const auto [it, fresh] = at.try_emplace({q.x, q.y, q.z}, nv + static_cast<std::uint32_t>(new_pos.size()));
      if (fresh) {
        new_pos.push_back(q);
        new_origin.push_back(p.origin);
      }
      out_vertex[r] = it->second;
    }
  }
  st.new_vertices = new_pos.size();
  for (std::uint32_t f = 0; f < nf; ++f) {
    st.dropped_triangles += uncut_[f] == kDrop;
    st.flipped_triangles += uncut_[f] == kFlip;
  }

  // Uncut triangles not dropped, in order, then the kept pieces.
  out.positions = mesh.positions;
  out.positions.insert(out.positions.end(), new_pos.begin(), new_pos.end());
  const bool uvs = mesh.corner_uvs.size() == nf, branches = mesh.triangle_branch.size() == nf;
  origin_of.clear();
  out.triangles.reserve(nf + pieces_.size());
  origin_of.reserve(nf + pieces_.size());
  if (uvs) out.corner_uvs.reserve(nf + pieces_.size());
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (local_[f] != kNone || uncut_[f] == kDrop) continue;
    const auto& t = mesh.triangles[f];
    const bool flip = uncut_[f] == kFlip;
    out.triangles.push_back(flip ? Mesh::Triangle{t[0], t[2], t[1]} : t);
    origin_of.push_back(f);
    if (uvs) {
      const auto& uv = mesh.corner_uvs[f];
      out.corner_uvs.push_back(flip ? std::array<glm::vec2, 3>{uv[0], uv[2], uv[1]} : uv);
    }
  }
  for (std::size_t i = 0; i < pieces_.size(); ++i) {
    if (piece_keep_[i] == kDrop) continue;
    Piece p = pieces_[i];
    if (piece_keep_[i] == kFlip) std::swap(p.v[1], p.v[2]);
    const Mesh::Triangle t{out_vertex[p.v[0]], out_vertex[p.v[1]], out_vertex[p.v[2]]};
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) continue;  // welded or snapped flat
    out.triangles.push_back(t);
    origin_of.push_back(p.origin);
    if (uvs) {
      const auto& o = mesh.triangles[p.origin];
      const auto& ouv = mesh.corner_uvs[p.origin];
      std::array<glm::vec2, 3> uv{};
      for (int k = 0; k < 3; ++k) {
        const glm::dvec3 w = barycentric(mesh.positions[o[0]], mesh.positions[o[1]], mesh.positions[o[2]],
                                         refined_pos_[p.v[k]]);
        uv[k] = glm::vec2(w.x * glm::dvec2(ouv[0]) + w.y * glm::dvec2(ouv[1]) + w.z * glm::dvec2(ouv[2]));
      }
      out.corner_uvs.push_back(uv);
    }
  }
  if (branches) {
    out.triangle_branch.reserve(origin_of.size());
    for (const std::uint32_t o : origin_of) out.triangle_branch.push_back(mesh.triangle_branch[o]);
  }
  if (mesh.vertex_node.size() == nv) {
    out.vertex_node = mesh.vertex_node;
    for (std::size_t k = 0; k < new_pos.size(); ++k) {
      const auto& o = mesh.triangles[new_origin[k]];
      int best = 0;
      for (int c = 1; c < 3; ++c) {
        if (glm::distance(mesh.positions[o[c]], new_pos[k]) < glm::distance(mesh.positions[o[best]], new_pos[k]))
          best = c;
      }
      out.vertex_node.push_back(mesh.vertex_node[o[best]]);
    }
  }
  if (mesh.vertex_strand.size() == nv) {
    out.vertex_strand = mesh.vertex_strand;
    out.vertex_strand.resize(nv + new_pos.size(), StrandId{});
  }
}

}  // namespace

namespace {

/// Where drop_loose_parts found a part holding a node cut loose (`in_severed`, per triangle of
/// `out`), the crossings that cut it off: in the mesh before the union, the cut triangles of the
/// wholly dropped regions (joined across edges) that touch both the loose part and the rest,
/// the loose part's cut triangles next to such a region, and cut triangles with pieces on both
/// sides. Leaving out only these keeps the crossings elsewhere in the loose part (on a large
/// tree, thousands of them). Empty where no such region is found.
std::vector<std::uint32_t> severing_cuts(const Mesh& mesh, const std::vector<std::uint32_t>& across, const Mesh& out,
                                         const std::vector<std::uint32_t>& origin_of,
                                         const std::vector<std::uint8_t>& in_severed,
                                         const std::vector<std::uint8_t>& was_cut) {
  const auto nf = static_cast<std::uint32_t>(mesh.triangles.size());
  std::vector<std::uint8_t> side(nf, 0);  // bit 1: a piece in the loose part, bit 2: one elsewhere
  for (std::uint32_t f = 0; f < out.triangles.size(); ++f) side[origin_of[f]] |= in_severed[f] ? 1 : 2;
  UnionFind dropped(nf);
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (side[f] != 0) continue;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t g = across[3 * f + k];
      if (g != kNone && side[g] == 0) dropped.unite(f, g);
    }
  }
  std::vector<std::uint8_t> touches(nf, 0);  // by root of a dropped region: the sides it meets
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (side[f] != 0) continue;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t g = across[3 * f + k];
      if (g != kNone) touches[dropped.find(f)] |= side[g];
    }
  }
  auto between = [&](std::uint32_t f) { return side[f] == 0 && touches[dropped.find(f)] == 3; };
  std::vector<std::uint32_t> cuts;
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (!was_cut[f]) continue;
    bool take = between(f) || side[f] == 3;
    for (int k = 0; k < 3 && !take && side[f] == 1; ++k) {
      const std::uint32_t g = across[3 * f + k];
      take = g != kNone && between(g);
    }
    if (take) cuts.push_back(f);
  }
  return cuts;
}

/// Components (through shared vertices) of `out` other than the largest: inner shells (a void
/// enclosed by crossing branches: negative volume) and lumps (a pocket turned inside out, come
/// apart from the tube it folded) go. A part that holds an anchor, of either volume, is a branch
/// the union cut off the tree (its tube turned inside out over a whole section): the input
/// triangles it was cut from are returned, `in_severed` marks its triangles, and the mesh is not
/// to be used.
std::vector<std::uint32_t> drop_loose_parts(Mesh& out, std::vector<std::uint32_t>& origin_of,
                                            std::span<const glm::dvec3> anchors,
                                            const std::vector<std::uint8_t>& was_cut, SelfUnionStats& st,
                                            std::vector<std::uint8_t>& in_severed) {
  std::vector<std::uint32_t> severed;
  in_severed.assign(out.triangles.size(), 0);
  if (out.triangles.empty()) return severed;
  const bool uvs = !out.corner_uvs.empty(), branches = !out.triangle_branch.empty();
  UnionFind comp(out.positions.size());
  for (const auto& t : out.triangles) {
    comp.unite(t[0], t[1]);
    comp.unite(t[1], t[2]);
  }
  // Signed volumes about one common origin (any origin gives a closed component's volume),
  // by root; the components in increasing order of their roots.
  const auto nf = static_cast<std::uint32_t>(out.triangles.size());
  std::vector<double> volume_of(out.positions.size(), 0.0);
  std::vector<std::uint8_t> is_root(out.positions.size(), 0);
  std::vector<std::uint32_t> root_of(nf);
  const glm::dvec3 o = out.positions[out.triangles.front()[0]];
  for (std::uint32_t f = 0; f < nf; ++f) {
    const auto& t = out.triangles[f];
    const std::uint32_t c = root_of[f] = comp.find(t[0]);
    volume_of[c] += glm::dot(out.positions[t[0]] - o, glm::cross(out.positions[t[1]] - o, out.positions[t[2]] - o));
    is_root[c] = 1;
  }
  std::vector<std::pair<std::uint32_t, double>> volume;
  for (std::uint32_t c = 0; c < is_root.size(); ++c) {
    if (is_root[c]) volume.emplace_back(c, volume_of[c]);
  }
  std::uint32_t largest = volume.front().first;
  for (const auto& [c, v] : volume) {
    if (v > volume_of[largest]) largest = c;
  }
  std::map<std::uint32_t, std::vector<std::uint32_t>> members;  // of the other components
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (root_of[f] != largest) members[root_of[f]].push_back(f);
  }
  std::vector<std::uint8_t> keep_comp(out.positions.size(), 0);
  for (const auto& [c, v] : volume) {
    if (c == largest) {
      keep_comp[c] = 1;
      continue;
    }
    bool holds = false;  // a void's shell holds no node; one that does is a branch turned over
    {
      Mesh part;  // (its own vertices only)
      std::map<std::uint32_t, std::uint32_t> vertex;
      glm::dvec3 lo(HUGE_VAL), hi(-HUGE_VAL);
      for (const std::uint32_t f : members[c]) {
        Mesh::Triangle t = out.triangles[f];
        for (std::uint32_t& x : t) {
          lo = glm::min(lo, out.positions[x]);
          hi = glm::max(hi, out.positions[x]);
          const auto [it, fresh] = vertex.try_emplace(x, std::uint32_t(part.positions.size()));
          if (fresh) part.positions.push_back(out.positions[x]);
          x = it->second;
        }
        part.triangles.push_back(t);
      }
      std::vector<glm::dvec3> near;
      for (const glm::dvec3& a : anchors) {
        if (glm::all(glm::greaterThanEqual(a, lo)) && glm::all(glm::lessThanEqual(a, hi))) near.push_back(a);
      }
      for (const int w : winding_numbers(part, near)) holds = holds || w != 0;
    }
    if (holds) {
      for (const std::uint32_t f : members[c]) {
        in_severed[f] = 1;
        if (was_cut[origin_of[f]]) severed.push_back(origin_of[f]);
      }
      continue;
    }
    keep_comp[c] = 0;
    st.inner_shells += v < 0 ? 1 : 0;
    st.lumps += v > 0 ? 1 : 0;
  }
  if (!severed.empty()) return severed;
  std::size_t w = 0;
  for (std::size_t f = 0; f < out.triangles.size(); ++f) {
    if (!keep_comp[root_of[f]]) continue;
    out.triangles[w] = out.triangles[f];
    origin_of[w] = origin_of[f];
    if (uvs) out.corner_uvs[w] = out.corner_uvs[f];
    if (branches) out.triangle_branch[w] = out.triangle_branch[f];
    ++w;
  }
  out.triangles.resize(w);
  origin_of.resize(w);
  if (uvs) out.corner_uvs.resize(w);
  if (branches) out.triangle_branch.resize(w);
  return severed;
}

/// Where CGAL cannot refine a set of pairs, the crossings it fails on: the pairs are split into
/// clusters (joined through shared vertices), the clusters into at most 64 batches refined one
/// by one, and the clusters of a failing batch one by one. Returns the triangles of the failing
/// clusters (empty when every batch refines after all). The cost is about twice the refinement
/// of the whole set, plus a pass over the mesh per call.
std::vector<std::uint32_t> failing_clusters(Attempt& attempt, const Mesh& mesh,
                                            const std::vector<std::array<std::uint32_t, 2>>& pairs) {
  UnionFind joined(mesh.positions.size());
  for (const auto& pr : pairs) {
    for (const std::uint32_t f : pr) {
      joined.unite(mesh.triangles[f][0], mesh.triangles[f][1]);
      joined.unite(mesh.triangles[f][0], mesh.triangles[f][2]);
    }
    joined.unite(mesh.triangles[pr[0]][0], mesh.triangles[pr[1]][0]);
  }
  std::map<std::uint32_t, std::vector<std::array<std::uint32_t, 2>>> by_root;  // ordered: deterministic
  for (const auto& pr : pairs) by_root[joined.find(mesh.triangles[pr[0]][0])].push_back(pr);
  std::vector<const std::vector<std::array<std::uint32_t, 2>>*> clusters;
  for (const auto& [root, members] : by_root) clusters.push_back(&members);

  constexpr std::size_t kBatches = 64;
  const std::size_t per_batch = (clusters.size() + kBatches - 1) / kBatches;
  std::vector<std::uint32_t> failing;
  std::vector<std::array<std::uint32_t, 2>> batch;
  for (std::size_t b = 0; b < clusters.size(); b += per_batch) {
    const std::size_t e = std::min(clusters.size(), b + per_batch);
    batch.clear();
    for (std::size_t c = b; c < e; ++c) batch.insert(batch.end(), clusters[c]->begin(), clusters[c]->end());
    if (attempt.refines(batch)) continue;
    for (std::size_t c = b; c < e; ++c) {
      if (e - b > 1 && attempt.refines(*clusters[c])) continue;
      for (const auto& pr : *clusters[c]) failing.insert(failing.end(), {pr[0], pr[1]});
    }
  }
  return failing;
}

/// For each anchor `held` before the union but outside `out` (at most 64 of them), the
/// triangle of the active pairs nearest to it (by its corners and centroid): the crossing whose
/// union lost it. Empty when no anchor was lost.
std::vector<std::uint32_t> nearest_cut_to_lost(const Mesh& mesh, const std::vector<std::array<std::uint32_t, 2>>& active,
                                               std::span<const glm::dvec3> anchors, const std::vector<std::uint8_t>& held,
                                               const Mesh& out) {
  std::vector<glm::dvec3> probe;
  for (std::size_t k = 0; k < anchors.size(); ++k) {
    if (held[k]) probe.push_back(anchors[k]);
  }
  std::vector<std::uint32_t> near;
  if (probe.empty() || active.empty()) return near;
  const std::vector<int> w = winding_numbers(out, probe);
  std::vector<std::uint32_t> cut;
  for (const auto& pr : active) cut.insert(cut.end(), {pr[0], pr[1]});
  std::sort(cut.begin(), cut.end());
  cut.erase(std::unique(cut.begin(), cut.end()), cut.end());
  constexpr std::size_t kMaxLost = 64;
  for (std::size_t k = 0; k < probe.size() && near.size() < kMaxLost; ++k) {
    if (w[k] != 0) continue;
    double best = HUGE_VAL;
    std::uint32_t at = cut.front();
    for (const std::uint32_t f : cut) {
      const auto& t = mesh.triangles[f];
      const glm::dvec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
      const double d = std::min({glm::distance(a, probe[k]), glm::distance(b, probe[k]), glm::distance(c, probe[k]),
                                 glm::distance((a + b + c) / 3.0, probe[k])});
      if (d < best) {
        best = d;
        at = f;
      }
    }
    near.push_back(at);
  }
  return near;
}

/// Per pair, the crossing curve it lies on (an index into `pairs`, the curve's first pair):
/// pairs (f, g) and (f', g) are on one curve where f and f' share an edge, and likewise on g's side.
std::vector<std::uint32_t> crossing_curves(const Mesh& mesh, const VertexCorners& vc,
                                           const std::vector<std::array<std::uint32_t, 2>>& pairs) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> index;  // (f, g) both ways
  for (std::uint32_t k = 0; k < pairs.size(); ++k) {
    index.try_emplace({pairs[k][0], pairs[k][1]}, k);
    index.try_emplace({pairs[k][1], pairs[k][0]}, k);
  }
  UnionFind joined(pairs.size());
  for (std::uint32_t k = 0; k < pairs.size(); ++k) {
    for (int side = 0; side < 2; ++side) {
      const std::uint32_t f = pairs[k][side], g = pairs[k][1 - side];
      const auto& t = mesh.triangles[f];
      for (int e = 0; e < 3; ++e) {
        const std::uint32_t n = triangle_with_edge(mesh, vc, t[(e + 1) % 3], t[e]);
        if (n == kNone) continue;
        const auto it = index.find({n, g});
        if (it != index.end()) joined.unite(k, it->second);
      }
    }
  }
  std::vector<std::uint32_t> curve(pairs.size());
  for (std::uint32_t k = 0; k < pairs.size(); ++k) curve[k] = joined.find(k);
  return curve;
}

}  // namespace

glm::dvec3 step_towards(const glm::dvec3& p, const glm::dvec3& target, double grid) {
  const glm::dvec3 towards = target - p;
  const double length = glm::length(towards);
  if (!(length > 0)) return grid > 0 ? snap_to_grid(p, grid) : p;
  const glm::dvec3 q = p + towards * std::min(1.0, std::max(0.01, grid > 0 ? 2 * grid / length : 0.0));
  return grid > 0 ? snap_to_grid(q, grid) : q;
}

double signed_volume(const Mesh& m) {
  if (m.triangles.empty()) return 0;
  const glm::dvec3 o = m.positions[m.triangles.front()[0]];
  double v = 0;
  for (const auto& t : m.triangles) {
    v += glm::dot(m.positions[t[0]] - o, glm::cross(m.positions[t[1]] - o, m.positions[t[2]] - o));
  }
  return v / 6;
}

SelfUnionStats self_union(Mesh& mesh, const std::vector<std::array<std::uint32_t, 2>>& pairs, double grid,
                          std::span<const glm::dvec3> anchors, std::vector<std::uint32_t>& origin_out) {
  SelfUnionStats st;
  st.pairs = pairs.size();
  const auto nf = static_cast<std::uint32_t>(mesh.triangles.size());
  origin_out.resize(nf);
  std::iota(origin_out.begin(), origin_out.end(), 0u);
  if (pairs.empty()) return st;
  const VertexCorners vc = vertex_corners(mesh);

  // Attempts: where CGAL cannot refine a cluster of crossings, patches cannot be judged, or
  // the union cuts a branch off the tree, the crossing curves through those triangles are left
  // out whole (a curve cut only in part would leave a cut line ending inside a patch), and the
  // rest is tried again. A curve is the pairs joined where it passes from a triangle to its
  // neighbour across their common edge while staying on the same other triangle.
  const std::vector<std::uint32_t> curve = crossing_curves(mesh, vc, pairs);
  std::vector<std::array<std::uint32_t, 2>> active = pairs;
  std::vector<std::uint32_t> active_curve = curve;
  // Attempts leaving out single curves; clusters after. Leaving out part of a cluster can end
  // another curve's cut line inside a patch, a new failure next to the old one: on a tree with
  // thousands of crossings (the maple) single curves kept the attempts from converging, while
  // on small trees they keep more of the union (messy seed 107 needs four).
  constexpr int kCurveAttempts = 4;
  int attempts_made = 0;
  auto leave_out = [&](const std::vector<std::uint32_t>& bad) {
    std::vector<std::uint8_t> bad_triangle(nf, 0);
    for (const std::uint32_t f : bad) bad_triangle[f] = 1;
    std::vector<std::uint8_t> drop_curve(pairs.size(), 0);
    bool any = false;
    for (std::size_t k = 0; k < active.size(); ++k) {
      if (!bad_triangle[active[k][0]] && !bad_triangle[active[k][1]]) continue;
      drop_curve[active_curve[k]] = 1;
      any = true;
    }
    if (!any) {  // bad triangles no pair holds (open edges next to a cut): the pairs around them
      std::vector<std::uint8_t> bad_vertex(mesh.positions.size(), 0);
      for (const std::uint32_t f : bad) {
        for (const std::uint32_t v : mesh.triangles[f]) bad_vertex[v] = 1;
      }
      for (std::size_t k = 0; k < active.size(); ++k) {
        for (const std::uint32_t f : active[k]) {
          for (const std::uint32_t v : mesh.triangles[f]) {
            if (!bad_vertex[v]) continue;
            drop_curve[active_curve[k]] = 1;
            any = true;
          }
        }
      }
    }
    if (!any) {  // nor near them by a vertex: the curve of the nearest active triangle to each
      for (std::size_t b = 0; b < bad.size() && b < 64; ++b) {
        const auto& t = mesh.triangles[bad[b]];
        const glm::dvec3 c = (mesh.positions[t[0]] + mesh.positions[t[1]] + mesh.positions[t[2]]) / 3.0;
        double best = HUGE_VAL;
        std::size_t at = 0;
        for (std::size_t k = 0; k < active.size(); ++k) {
          for (const std::uint32_t f : active[k]) {
            const auto& u = mesh.triangles[f];
            const double d =
                glm::distance(c, (mesh.positions[u[0]] + mesh.positions[u[1]] + mesh.positions[u[2]]) / 3.0);
            if (d < best) {
              best = d;
              at = k;
            }
          }
        }
        if (!active.empty()) drop_curve[active_curve[at]] = 1;
      }
    }
    // In the later attempts, the whole cluster (joined through shared vertices) of a curve
    // left out goes with it, so the attempts converge where failures keep turning up next to
    // the crossings left out before.
    if (attempts_made >= kCurveAttempts) {
      // A flood over the pairs: a curve left out marks the vertices of its pairs, and a pair
      // touching a marked vertex takes its whole curve with it.
      std::map<std::uint32_t, std::vector<std::uint32_t>> of_curve;  // curve -> active pairs
      std::map<std::uint32_t, std::vector<std::uint32_t>> at_vertex;  // vertex -> active pairs
      for (std::uint32_t k = 0; k < active.size(); ++k) {
        of_curve[active_curve[k]].push_back(k);
        for (const std::uint32_t f : active[k]) {
          for (const std::uint32_t v : mesh.triangles[f]) at_vertex[v].push_back(k);
        }
      }
      std::vector<std::uint32_t> queue;
      for (std::uint32_t k = 0; k < active.size(); ++k) {
        if (drop_curve[active_curve[k]]) queue.push_back(k);
      }
      std::vector<std::uint8_t> marked(mesh.positions.size(), 0);
      while (!queue.empty()) {
        const std::uint32_t k = queue.back();
        queue.pop_back();
        for (const std::uint32_t f : active[k]) {
          for (const std::uint32_t v : mesh.triangles[f]) {
            if (marked[v]) continue;
            marked[v] = 1;
            for (const std::uint32_t j : at_vertex[v]) {
              if (drop_curve[active_curve[j]]) continue;
              drop_curve[active_curve[j]] = 1;
              for (const std::uint32_t m : of_curve[active_curve[j]]) queue.push_back(m);
            }
          }
        }
      }
    }
    std::size_t w = 0;
    for (std::size_t k = 0; k < active.size(); ++k) {
      if (drop_curve[active_curve[k]]) continue;
      active[w] = active[k];
      active_curve[w] = active_curve[k];
      ++w;
    }
    if (w == active.size()) w = 0;  // (no bad triangles given: nothing to leave out but all)
    active.resize(w);
    active_curve.resize(w);
  };
  // The skeleton nodes the surface holds before the union (winding number not 0).
  std::vector<std::uint8_t> held(anchors.size(), 0);
  {
    const std::vector<int> w = winding_numbers(mesh, anchors);
    for (std::size_t k = 0; k < w.size(); ++k) held[k] = w[k] != 0;
  }
  Attempt attempt(mesh, vc);
  // (Each attempt finds one kind of failure; trees with thousands of crossings, the fir, need
  // 28 before the union is kept.)
  constexpr int kAttempts = 40;
  Mesh out;
  std::vector<std::uint32_t> origin_of;
  bool ready = false;
  for (int k = 0; k < kAttempts && !active.empty(); ++k, ++attempts_made) {
    if (!attempt.run(active)) {
      const std::vector<std::uint32_t> failing = failing_clusters(attempt, mesh, active);
      if (failing.empty()) {
        st.problem = attempt.problem;
        return st;
      }
      ++st.unrefined_clusters;
      leave_out(failing);
      continue;
    }
    if (!attempt.bad.empty()) {
      leave_out(attempt.bad);
      continue;
    }
    SelfUnionStats trial;
    out = Mesh{};
    attempt.assemble(out, origin_of, grid, trial);
    std::vector<NodeId>* node = out.vertex_node.size() == out.positions.size() ? &out.vertex_node : nullptr;
    std::vector<StrandId>* strand = out.vertex_strand.size() == out.positions.size() ? &out.vertex_strand : nullptr;
    std::vector<std::uint32_t> open_at;
    trial.split_vertices = split_pinches(out, node, strand, grid, open_at);
    std::vector<std::uint8_t> was_cut(nf, 0);
    for (const auto& pr : active) was_cut[pr[0]] = was_cut[pr[1]] = 1;
    // Where the kept patches do not close up (a cut line ending where the surface folds), those
    // crossings are left out too.
    std::vector<std::uint32_t> open;
    for (const std::uint32_t f : open_at) open.push_back(origin_of[f]);
    if (!open.empty()) {
      leave_out(open);
      continue;
    }
    std::vector<std::uint8_t> in_severed;
    const std::vector<std::uint32_t> severed = drop_loose_parts(out, origin_of, anchors, was_cut, trial, in_severed);
    if (!severed.empty()) {
      const std::vector<std::uint32_t> cuts = severing_cuts(mesh, attempt.across(), out, origin_of, in_severed, was_cut);
      leave_out(cuts.empty() ? severed : cuts);
      continue;
    }
    // A large part judged turned inside out and flipped turns the whole surface over: those
    // crossings are left out too.
    if (!(signed_volume(out) > 0)) {
      const std::vector<std::uint32_t> flipped = attempt.flipped();
      if (flipped.empty()) break;
      leave_out(flipped);
      continue;
    }
    // A union that leaves outside a skeleton node the surface held (a part dropped as lying
    // inside another while it was the tree's own) is not the union of the tree's solids: the
    // crossing nearest each such node is left out.
    if (const std::vector<std::uint32_t> near = nearest_cut_to_lost(mesh, active, anchors, held, out); !near.empty()) {
      leave_out(near);
      continue;
    }
    st.new_vertices = trial.new_vertices;
    st.dropped_triangles = trial.dropped_triangles;
    st.flipped_triangles = trial.flipped_triangles;
    st.split_vertices = trial.split_vertices;
    st.inner_shells = trial.inner_shells;
    st.lumps = trial.lumps;
    ready = true;
    break;
  }
  st.patches = attempt.patches;
  st.cut_triangles = attempt.cut_triangles;
  st.left_out = pairs.size() - active.size();
  {
    std::set<std::array<std::uint32_t, 2>> kept(active.begin(), active.end());
    for (const auto& pr : pairs) {
      if (!kept.contains(pr)) st.left_out_pairs.push_back(pr);
    }
  }
  if (!ready) {
    st.problem = active.empty() ? "no crossing could be judged"
                                : "crossings still misjudged after " + std::to_string(kAttempts) + " attempts";
    return st;
  }

  // Unused vertices go (those of dropped triangles and split pinches), the order kept.
  std::vector<std::uint32_t> renumber(out.positions.size(), kNone);
  for (const auto& t : out.triangles) {
    for (const std::uint32_t v : t) renumber[v] = 0;
  }
  std::uint32_t used = 0;
  const bool nodes = out.vertex_node.size() == renumber.size(), strands = out.vertex_strand.size() == renumber.size();
  for (std::size_t v = 0; v < renumber.size(); ++v) {
    if (renumber[v] == kNone) continue;
    renumber[v] = used;
    out.positions[used] = out.positions[v];
    if (nodes) out.vertex_node[used] = out.vertex_node[v];
    if (strands) out.vertex_strand[used] = out.vertex_strand[v];
    ++used;
  }
  out.positions.resize(used);
  if (nodes) out.vertex_node.resize(used);
  if (strands) out.vertex_strand.resize(used);
  for (auto& t : out.triangles) {
    for (auto& v : t) v = renumber[v];
  }
  if (!mesh.normals.empty()) out.normals = angle_weighted_normals(out);
  mesh = std::move(out);
  origin_out = std::move(origin_of);
  return st;
}

}  // namespace sm
