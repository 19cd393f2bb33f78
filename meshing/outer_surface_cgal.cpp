// The outer surface of a closed mesh whose parts run into each other (see intersections.h):
// CGAL Polygon Mesh Processing's autorefinement, which cuts every pair of intersecting
// triangles along their intersection, with the patches that end up inside another part
// removed (experimental::autorefine_and_remove_self_intersections). Kept in its own
// translation unit: the corefinement headers are the slowest of CGAL's to compile.

#include <exception>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/corefinement.h>
#include <CGAL/Surface_mesh.h>

#include "meshing/intersections.h"

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
