// The outer surface of a closed mesh whose parts run into each other (see outer_surface_cgal.h):
// CGAL Polygon Mesh Processing's autorefinement, which cuts every pair of intersecting
// triangles along their intersection, with the patches that end up inside another part
// removed (experimental::autorefine_and_remove_self_intersections), or the patches chosen by
// winding numbers (autorefine alone; outer_surface_by_winding); and the union of two meshes.
// Kept in its own translation unit: the corefinement headers are the slowest of CGAL's to
// compile.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <numeric>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/corefinement.h>
#include <CGAL/Surface_mesh.h>

#include "core/mesh.h"
#include "core/union_find.h"
#include "repair/outer_surface_cgal.h"

namespace sm {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using Face = SurfaceMesh::Face_index;
using OriginMap = SurfaceMesh::Property_map<Face, std::uint32_t>;
namespace PMP = CGAL::Polygon_mesh_processing;

// Hands a triangle's input index on to the triangles it is cut into or copied to (two meshes:
// each has its own map, found by the mesh's address; one mesh: both are the same).
struct OriginVisitor : PMP::Corefinement::Default_visitor<SurfaceMesh> {
  OriginVisitor(const SurfaceMesh* first_mesh, OriginMap first_map, OriginMap second_map)
      : first(first_mesh), first_origin(first_map), second_origin(second_map) {}
  explicit OriginVisitor(OriginMap map) : first(nullptr), first_origin(map), second_origin(map) {}
  OriginMap& of(const SurfaceMesh& tm) { return first == nullptr || &tm == first ? first_origin : second_origin; }
  void before_subface_creations(Face f_old, SurfaceMesh& tm) { current = of(tm)[f_old]; }
  void after_subface_created(Face f_new, SurfaceMesh& tm) { of(tm)[f_new] = current; }
  void after_face_copy(Face f_old, const SurfaceMesh& src, Face f_new, SurfaceMesh& tgt) {
    of(tgt)[f_new] = of(src)[f_old];
  }

  const SurfaceMesh* first;
  OriginMap first_origin, second_origin;
  std::uint32_t current = UINT32_MAX;
};

/// `mesh` as a Surface_mesh (same vertex indices) with each face's index (plus
/// `first_index`) in `origin`; false when it is not a manifold triangle mesh.
bool to_surface_mesh(const Mesh& mesh, SurfaceMesh& sm, OriginMap& origin, std::uint32_t first_index = 0) {
  sm.reserve(mesh.positions.size(), 3 * mesh.triangles.size() / 2, mesh.triangles.size());
  for (const auto& p : mesh.positions) sm.add_vertex(Point(p.x, p.y, p.z));
  origin = sm.add_property_map<Face, std::uint32_t>("f:origin", UINT32_MAX).first;
  for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    const Face face = sm.add_face(SurfaceMesh::Vertex_index(t[0]), SurfaceMesh::Vertex_index(t[1]),
                                  SurfaceMesh::Vertex_index(t[2]));
    if (face == SurfaceMesh::null_face()) return false;
    origin[face] = first_index + f;
  }
  return true;
}

/// The vertex positions of `sm` by index (input vertices keep theirs: a Surface_mesh only
/// appends, and removed ones stay unreferenced) and its faces with their origins; false if a
/// face is not a triangle or has no origin.
bool read_back(const SurfaceMesh& sm, const OriginMap& origin, OuterSurface& out) {
  out.positions.resize(sm.num_vertices(), glm::dvec3(0.0));
  for (const auto v : sm.vertices()) {
    const Point& p = sm.point(v);
    out.positions[v.idx()] = glm::dvec3(p.x(), p.y(), p.z());
  }
  out.triangles.reserve(sm.number_of_faces());
  out.origin.reserve(sm.number_of_faces());
  for (const Face f : sm.faces()) {
    Mesh::Triangle t{};
    std::size_t k = 0;
    for (const auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) {
      if (k == 3) return false;
      t[k++] = static_cast<std::uint32_t>(v.idx());
    }
    if (k != 3 || origin[f] == UINT32_MAX) return false;
    out.triangles.push_back(t);
    out.origin.push_back(origin[f]);
  }
  return true;
}

// outer_surface_by_winding: at most this many patches are classified (a mesh of 110,000
// triangles makes 10 on the samples; more are a tangle, which the choice does not mend).
constexpr std::size_t kMaxPatches = 512;
// A patch's side could not be told: none of its triangles has an area (sides_of_patches).
constexpr int kUnclear = 2;

/// Per patch of `soup` (`patch[f]` numbers them 0..patches-1): 1 where it bounds the union of
/// the solids (winding number 0 in front of it, so 1 behind: crossing an outward-oriented
/// surface backwards adds one), 0 where it does not (1 or more in front: inside another part;
/// -1 or less: between a pocket turned inside out and the outside). Judged at points a
/// hundredth of the inradius in front of and behind the centroid of the patch's roundest
/// triangle (the largest inradius): far from other sheets, and well inside the triangle. The
/// points are tested all at once by ray crossings (core/mesh.h inside_closed_mesh: the soup is
/// closed as a surface, its cut lines' vertices doubled): kept where the point in front is
/// outside and the one behind inside.
std::vector<int> sides_of_patches(const Mesh& soup, const std::vector<std::uint32_t>& patch, std::size_t patches) {
  const auto& p = soup.positions;
  std::vector<std::pair<double, std::uint32_t>> roundest(patches, {-1.0, 0});
  for (std::uint32_t f = 0; f < soup.triangles.size(); ++f) {
    const auto& t = soup.triangles[f];
    const double area = 0.5 * glm::length(glm::cross(p[t[1]] - p[t[0]], p[t[2]] - p[t[0]]));
    const double perimeter =
        glm::distance(p[t[0]], p[t[1]]) + glm::distance(p[t[1]], p[t[2]]) + glm::distance(p[t[2]], p[t[0]]);
    if (perimeter > 0 && 2 * area / perimeter > roundest[patch[f]].first)
      roundest[patch[f]] = {2 * area / perimeter, f};
  }
  std::vector<glm::dvec3> at(2 * patches, glm::dvec3(0.0));  // in front, behind, per patch
  for (std::size_t k = 0; k < patches; ++k) {
    const auto& [inradius, f] = roundest[k];
    if (!(inradius > 0)) continue;  // no triangle of any area: kUnclear below
    const auto& t = soup.triangles[f];
    const glm::dvec3 n = glm::normalize(glm::cross(p[t[1]] - p[t[0]], p[t[2]] - p[t[0]]));
    const glm::dvec3 c = (p[t[0]] + p[t[1]] + p[t[2]]) / 3.0, d = 0.01 * inradius * n;
    at[2 * k] = c + d;
    at[2 * k + 1] = c - d;
  }
  const std::vector<std::uint8_t> inside = inside_closed_mesh(soup, at);
  std::vector<int> side(patches, kUnclear);
  for (std::size_t k = 0; k < patches; ++k) {
    if (roundest[k].first > 0) side[k] = !inside[2 * k] && inside[2 * k + 1] ? 1 : 0;
  }
  return side;
}

/// Gives each vertex of `soup` whose triangles form several fans (where kept patches meet at
/// a point only: the end of a fold's cut line, which does not separate patches) a copy per
/// fan, moved a hundredth of the way to the centroid of the fan's other vertices: the tips of
/// the cones meeting there draw back into their cones, apart. The copies are appended; the
/// vertex itself is then unused.
void split_pinches(OuterSurface& soup) {
  std::vector<std::vector<std::pair<std::uint32_t, int>>> around(soup.positions.size());
  for (std::uint32_t f = 0; f < soup.triangles.size(); ++f) {
    for (int i = 0; i < 3; ++i) around[soup.triangles[f][i]].emplace_back(f, i);
  }
  for (std::uint32_t v = 0; v < around.size(); ++v) {
    const auto& tris = around[v];
    if (tris.size() < 2) continue;
    // Fans: triangles joined where one's next vertex after v is another's previous one.
    const auto n = static_cast<std::uint32_t>(tris.size());
    UnionFind fans(n);
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::uint32_t next = soup.triangles[tris[i].first][(tris[i].second + 1) % 3];
      for (std::uint32_t j = 0; j < n; ++j) {
        if (soup.triangles[tris[j].first][(tris[j].second + 2) % 3] == next) fans.unite(i, j);
      }
    }
    std::vector<std::uint32_t> roots(n), distinct;
    for (std::uint32_t i = 0; i < n; ++i) {
      roots[i] = fans.find(i);
      if (roots[i] == i) distinct.push_back(i);
    }
    if (distinct.size() < 2) continue;
    // Every fan gets its own copy of v.
    for (const std::uint32_t root : distinct) {
      glm::dvec3 sum(0.0);
      double count = 0;
      for (std::uint32_t i = 0; i < n; ++i) {
        if (roots[i] != root) continue;
        const auto& t = soup.triangles[tris[i].first];
        sum += soup.positions[t[(tris[i].second + 1) % 3]] + soup.positions[t[(tris[i].second + 2) % 3]];
        count += 2;
      }
      const auto copy = static_cast<std::uint32_t>(soup.positions.size());
      const glm::dvec3 p = soup.positions[v];
      soup.positions.push_back(p + 0.01 * (sum / count - p));
      for (std::uint32_t i = 0; i < n; ++i) {
        if (roots[i] == root) soup.triangles[tris[i].first][tris[i].second] = copy;
      }
    }
  }
}

}  // namespace

OuterSurface outer_surface(const Mesh& mesh) {
  OuterSurface out;
  SurfaceMesh sm;
  OriginMap origin;
  if (!to_surface_mesh(mesh, sm, origin)) return out;
  try {
    out.fixed = PMP::experimental::autorefine_and_remove_self_intersections(
        sm, CGAL::parameters::visitor(OriginVisitor(origin)));
  } catch (const std::exception&) {  // a CGAL precondition or an unexpected configuration
    return OuterSurface{};
  }
  if (!read_back(sm, origin, out)) return OuterSurface{};
  return out;
}

struct WindingPatches::Data {
  std::string problem;
  std::vector<Mesh::Triangle> input;                              // the mesh's triangles (restored where not applied)
  Mesh soup;                                                      // the refined mesh
  std::vector<std::uint32_t> origin, patch;                       // per refined triangle
  std::vector<int> side;                                          // per patch (sides_of_patches)
  std::vector<std::uint32_t> weld;                                // per refined vertex: the lowest at its position
  std::vector<std::uint32_t> cluster_of_input, cluster_of_patch;  // UINT32_MAX: none
  std::size_t clusters = 0;
};

WindingPatches::~WindingPatches() = default;

WindingPatches::WindingPatches(const Mesh& mesh) : d_(std::make_unique<Data>()) {
  Data& d = *d_;
  d.input = mesh.triangles;
  SurfaceMesh sm;
  OriginMap origin;
  d.problem = "CGAL failed";
  if (!to_surface_mesh(mesh, sm, origin)) return;
  auto cut = sm.add_property_map<SurfaceMesh::Edge_index, bool>("e:cut", false).first;
  try {
    PMP::experimental::autorefine(sm, CGAL::parameters::visitor(OriginVisitor(origin)).edge_is_constrained_map(cut));
  } catch (const std::exception&) {  // a CGAL precondition or an unexpected configuration
    return;
  }
  auto patch_map = sm.add_property_map<Face, std::size_t>("f:patch", 0).first;
  const std::size_t patches = PMP::connected_components(sm, patch_map, CGAL::parameters::edge_is_constrained_map(cut));
  OuterSurface all;
  if (!read_back(sm, origin, all)) return;
  if (patches > kMaxPatches) {
    d.problem = std::to_string(patches) + " patches (more than " + std::to_string(kMaxPatches) + ")";
    return;
  }
  d.origin = std::move(all.origin);
  d.patch.reserve(all.triangles.size());
  for (const Face f : sm.faces()) d.patch.push_back(static_cast<std::uint32_t>(patch_map[f]));
  d.soup.positions = std::move(all.positions);
  d.soup.triangles = std::move(all.triangles);
  d.side = sides_of_patches(d.soup, d.patch, patches);
  if (std::find(d.side.begin(), d.side.end(), kUnclear) != d.side.end()) {
    d.problem = "a patch without area";
    return;
  }
  // The refinement gives each side of a cut line its own copies of the line's vertices: the
  // patches kept are joined there by welding equal positions (to the lowest index).
  const auto nv = static_cast<std::uint32_t>(d.soup.positions.size());
  std::vector<std::uint32_t> order(nv);
  d.weld.resize(nv);
  std::iota(order.begin(), order.end(), 0u);
  auto key = [&](std::uint32_t v) {
    const glm::dvec3& q = d.soup.positions[v];
    return std::tuple(q.x, q.y, q.z, v);
  };
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return key(a) < key(b); });
  for (std::size_t i = 0; i < order.size(); ++i) {
    const bool same = i > 0 && d.soup.positions[order[i]] == d.soup.positions[order[i - 1]];
    d.weld[order[i]] = same ? d.weld[order[i - 1]] : order[i];
  }
  // Clusters: the input triangles the refinement cut (a triangle with a new vertex), joined
  // where they share a vertex (a cut line's, welded, or one of the input's), and where a
  // dropped patch holds parts of several (its fate is theirs).
  const auto ni = static_cast<std::uint32_t>(d.input.size());
  const std::uint32_t nv_in = static_cast<std::uint32_t>(mesh.positions.size());
  std::vector<std::uint8_t> refined(ni, 0);
  for (std::size_t f = 0; f < d.soup.triangles.size(); ++f) {
    for (const std::uint32_t v : d.soup.triangles[f]) {
      if (v >= nv_in) refined[d.origin[f]] = 1;
    }
  }
  UnionFind joined(ni);
  std::vector<std::uint32_t> first_at(nv, UINT32_MAX);  // per welded vertex: a refined input triangle at it
  for (std::size_t f = 0; f < d.soup.triangles.size(); ++f) {
    const std::uint32_t t = d.origin[f];
    if (!refined[t]) continue;
    for (const std::uint32_t v : d.soup.triangles[f]) {
      std::uint32_t& at = first_at[d.weld[v]];
      if (at == UINT32_MAX)
        at = t;
      else
        joined.unite(t, at);
    }
  }
  std::vector<std::uint32_t> patch_input(patches, UINT32_MAX);  // dropped patch: a refined input triangle in it
  for (std::size_t f = 0; f < d.soup.triangles.size(); ++f) {
    const std::uint32_t t = d.origin[f], p = d.patch[f];
    if (!refined[t] || d.side[p] != 0) continue;
    if (patch_input[p] == UINT32_MAX)
      patch_input[p] = t;
    else
      joined.unite(t, patch_input[p]);
  }
  std::vector<std::uint32_t> number(ni, UINT32_MAX);
  d.cluster_of_input.assign(ni, UINT32_MAX);
  for (std::uint32_t t = 0; t < ni; ++t) {
    if (!refined[t]) continue;
    std::uint32_t& n = number[joined.find(t)];
    if (n == UINT32_MAX) n = static_cast<std::uint32_t>(d.clusters++);
    d.cluster_of_input[t] = n;
  }
  d.cluster_of_patch.assign(patches, UINT32_MAX);
  for (std::size_t p = 0; p < patches; ++p) {
    if (d.side[p] != 0) continue;
    // (A dropped patch that no cut line bounds, a part wholly inside another, is a cluster
    // of its own.)
    d.cluster_of_patch[p] =
        patch_input[p] != UINT32_MAX ? d.cluster_of_input[patch_input[p]] : static_cast<std::uint32_t>(d.clusters++);
  }
  d.problem.clear();
}

std::size_t WindingPatches::clusters() const {
  return d_->clusters;
}

const std::string& WindingPatches::problem() const {
  return d_->problem;
}

OuterSurface WindingPatches::surface(const std::vector<std::uint8_t>& apply) const {
  const Data& d = *d_;
  OuterSurface out;
  if (!d.problem.empty()) {
    out.problem = d.problem;
    return out;
  }
  auto applied = [&](std::uint32_t c) { return c == UINT32_MAX || (c < apply.size() && apply[c]); };
  out.positions = d.soup.positions;
  for (std::size_t f = 0; f < d.soup.triangles.size(); ++f) {
    const std::uint32_t t = d.origin[f], p = d.patch[f];
    if (!applied(d.cluster_of_input[t])) continue;  // its input triangle, below
    if (d.side[p] == 0 && applied(d.cluster_of_patch[p])) continue;
    const auto& tri = d.soup.triangles[f];
    out.triangles.push_back({d.weld[tri[0]], d.weld[tri[1]], d.weld[tri[2]]});
    out.origin.push_back(t);
  }
  for (std::uint32_t t = 0; t < d.input.size(); ++t) {
    if (applied(d.cluster_of_input[t])) continue;
    out.triangles.push_back(d.input[t]);
    out.origin.push_back(t);
  }
  split_pinches(out);
  out.fixed = true;
  return out;
}

OuterSurface outer_surface_by_winding(const Mesh& mesh) {
  const WindingPatches patches(mesh);
  return patches.surface(std::vector<std::uint8_t>(patches.clusters(), 1));
}

OuterSurface union_of(const Mesh& a, const Mesh& b) {
  OuterSurface out;
  SurfaceMesh sa, sb;
  OriginMap oa, ob;
  if (!to_surface_mesh(a, sa, oa) || !to_surface_mesh(b, sb, ob, static_cast<std::uint32_t>(a.triangles.size())))
    return out;
  try {
    out.fixed = PMP::corefine_and_compute_union(sa, sb, sa, CGAL::parameters::visitor(OriginVisitor(&sa, oa, ob)));
  } catch (const std::exception&) {  // a CGAL precondition or an unexpected configuration
    return OuterSurface{};
  }
  if (!read_back(sa, oa, out)) return OuterSurface{};
  return out;
}

}  // namespace sm
