// The outer surface of a closed mesh whose parts run into each other (see intersections.h):
// CGAL Polygon Mesh Processing's autorefinement, which cuts every pair of intersecting
// triangles along their intersection, with the patches that end up inside another part
// removed (experimental::autorefine_and_remove_self_intersections). Kept in its own
// translation unit: the corefinement headers are the slowest of CGAL's to compile.

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

// Hands a triangle's input index on to the triangles it is cut into.
struct OriginVisitor : PMP::Corefinement::Default_visitor<SurfaceMesh> {
  explicit OriginVisitor(OriginMap map) : origin(map) {}
  void before_subface_creations(Face f_old, SurfaceMesh&) { current = origin[f_old]; }
  void after_subface_created(Face f_new, SurfaceMesh&) { origin[f_new] = current; }
  void after_face_copy(Face f_old, const SurfaceMesh&, Face f_new, SurfaceMesh&) { origin[f_new] = origin[f_old]; }

  OriginMap origin;
  std::uint32_t current = UINT32_MAX;
};

}  // namespace

OuterSurface outer_surface(const Mesh& mesh) {
  OuterSurface out;
  SurfaceMesh sm;
  sm.reserve(mesh.positions.size(), 3 * mesh.triangles.size() / 2, mesh.triangles.size());
  for (const auto& p : mesh.positions) sm.add_vertex(Point(p.x, p.y, p.z));
  auto [origin, created] = sm.add_property_map<Face, std::uint32_t>("f:origin", UINT32_MAX);
  for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    const Face face = sm.add_face(SurfaceMesh::Vertex_index(t[0]), SurfaceMesh::Vertex_index(t[1]),
                                  SurfaceMesh::Vertex_index(t[2]));
    if (face == SurfaceMesh::null_face()) return out;  // not a manifold mesh
    origin[face] = f;
  }
  out.fixed = PMP::experimental::autorefine_and_remove_self_intersections(
      sm, CGAL::parameters::visitor(OriginVisitor(origin)));
  // Input vertices keep their indices (a Surface_mesh only appends; removed ones stay
  // unreferenced), new ones follow.
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
      if (k == 3) return OuterSurface{};  // not a triangle
      t[k++] = static_cast<std::uint32_t>(v.idx());
    }
    if (k != 3 || origin[f] == UINT32_MAX) return OuterSurface{};
    out.triangles.push_back(t);
    out.origin.push_back(origin[f]);
  }
  return out;
}

}  // namespace sm
