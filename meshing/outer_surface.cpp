// Outer surface: the last resort for the self-intersections left (see outer_surface.h).

#include "meshing/outer_surface.h"

#include <algorithm>
#include <array>
#include <limits>
#include <utility>

#include <glm/glm.hpp>

#include "core/report.h"
#include "meshing/checks.h"
#include "meshing/intersections.h"

namespace sm {

namespace {

/// Barycentric coordinates of p projected onto the plane of (a, b, c), clamped to the
/// triangle (p lies on it up to rounding: it was cut from it).
glm::dvec3 barycentric(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& p) {
  const glm::dvec3 e0 = b - a, e1 = c - a, d = p - a;
  const double d00 = glm::dot(e0, e0), d01 = glm::dot(e0, e1), d11 = glm::dot(e1, e1);
  const double d20 = glm::dot(d, e0), d21 = glm::dot(d, e1);
  const double den = d00 * d11 - d01 * d01;
  if (!(den > 0)) return {1.0, 0.0, 0.0};
  const double v = (d11 * d20 - d01 * d21) / den, w = (d00 * d21 - d01 * d20) / den;
  glm::dvec3 l = glm::max(glm::dvec3(1.0 - v - w, v, w), glm::dvec3(0.0));
  const double s = l.x + l.y + l.z;
  return s > 0 ? l / s : glm::dvec3(1.0, 0.0, 0.0);
}

/// Why `after` does worse than `before` in some respect the checks measure (empty if it
/// does not): the outer surface may only make the mesh better.
std::string worse(const MeshCheckReport& before, const MeshCheckReport& after) {
  if (after.nonfinite_vertices > 0) return "non-finite vertices";
  if (!after.closed || !after.edge_manifold || !after.vertex_manifold || !after.oriented)
    return "not a closed, oriented 2-manifold";
  if (after.components > before.components) return std::to_string(after.components) + " components";
  if (after.genus != before.genus) return "genus " + (after.genus ? std::to_string(*after.genus) : std::string("?"));
  if (after.degenerate_triangles > before.degenerate_triangles)
    return std::to_string(after.degenerate_triangles) + " degenerate triangles";
  if (!(after.signed_volume > 0)) return "negative volume";
  if (after.thick_nodes_inside < before.thick_nodes_inside)
    return std::to_string(before.thick_nodes_inside - after.thick_nodes_inside) + " more thick nodes outside";
  if (after.fidelity_p95 > std::max(before.fidelity_p95, before.fidelity_tolerance))
    return "fidelity p95 " + std::to_string(after.fidelity_p95);
  if (after.self_intersecting_pairs >= before.self_intersecting_pairs)
    return std::to_string(after.self_intersecting_pairs) + " self-intersecting pairs";
  return {};
}

}  // namespace

OuterSurfaceStats keep_outer_surface(MeshResult& result, const Skeleton& skeleton, const MeshParams& params) {
  OuterSurfaceStats stats;
  if (!params.outer_surface || !result.crossings_counted || result.crossings.empty()) return stats;
  Stopwatch clock;
  stats.tried = true;
  const Mesh& mesh = result.mesh;
  MeshCheckParams check;
  check.skeleton = &skeleton;
  check.max_examples = std::numeric_limits<std::size_t>::max();  // every pair, for `crossings`
  const MeshCheckReport before = check_mesh(mesh, check);
  stats.pairs_before = stats.pairs_after = before.self_intersecting_pairs;

  auto done = [&](std::string why) {
    stats.refused = std::move(why);
    stats.seconds = clock.lap();
    return stats;
  };
  const OuterSurface outer = outer_surface(mesh);
  if (outer.triangles.empty()) return done("CGAL gave no surface");
  if (!outer.fixed) return done("CGAL could not remove every self-intersection");

  // The outer surface as a mesh with the attributes of the triangles it was cut from.
  const std::size_t nv_old = mesh.positions.size();
  std::vector<std::uint32_t> remap(outer.positions.size(), UINT32_MAX);
  for (const auto& t : outer.triangles) {
    for (const std::uint32_t v : t) remap[v] = 0;
  }
  Mesh out;
  const bool strands = !mesh.vertex_strand.empty(), nodes = !mesh.vertex_node.empty();
  // The corner of the origin triangle nearest to each new vertex (first use).
  std::vector<std::uint32_t> nearest_corner(outer.positions.size(), UINT32_MAX);
  for (std::size_t f = 0; f < outer.triangles.size(); ++f) {
    const auto& o = mesh.triangles[outer.origin[f]];
    for (const std::uint32_t v : outer.triangles[f]) {
      if (v < nv_old || nearest_corner[v] != UINT32_MAX) continue;
      std::uint32_t best = o[0];
      for (const std::uint32_t c : o) {
        if (glm::distance(mesh.positions[c], outer.positions[v]) < glm::distance(mesh.positions[best], outer.positions[v]))
          best = c;
      }
      nearest_corner[v] = best;
    }
  }
  for (std::size_t v = 0; v < outer.positions.size(); ++v) {
    if (remap[v] == UINT32_MAX) continue;
    remap[v] = static_cast<std::uint32_t>(out.positions.size());
    // New vertices go on the float grid too (MeshResult::grid): the result is checked as exported.
    const bool snap = v >= nv_old && result.grid > 0;
    out.positions.push_back(snap ? snap_to_grid(outer.positions[v], result.grid) : outer.positions[v]);
    const std::uint32_t from = v < nv_old ? static_cast<std::uint32_t>(v) : nearest_corner[v];
    if (strands) out.vertex_strand.push_back(v < nv_old ? mesh.vertex_strand[v] : StrandId{});
    if (nodes) out.vertex_node.push_back(mesh.vertex_node[from]);
  }
  std::vector<TriangleKind> kinds;
  std::size_t unchanged = 0;
  for (std::size_t f = 0; f < outer.triangles.size(); ++f) {
    const std::uint32_t g = outer.origin[f];
    const Mesh::Triangle& t = outer.triangles[f];
    const Mesh::Triangle& o = mesh.triangles[g];
    out.triangles.push_back({remap[t[0]], remap[t[1]], remap[t[2]]});
    if (!mesh.triangle_branch.empty()) out.triangle_branch.push_back(mesh.triangle_branch[g]);
    if (!result.triangle_kind.empty()) kinds.push_back(result.triangle_kind[g]);
    // Unchanged when it is the origin triangle, corners in the same cyclic order.
    for (int k = 0; k < 3; ++k) {
      if (t[0] == o[std::size_t(k)] && t[1] == o[std::size_t((k + 1) % 3)] && t[2] == o[std::size_t((k + 2) % 3)])
        ++unchanged;
    }
    if (!mesh.corner_uvs.empty()) {
      std::array<glm::vec2, 3> uv{};
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t v = t[std::size_t(k)];
        const auto corner = std::find(o.begin(), o.end(), v);
        if (corner != o.end()) {
          uv[std::size_t(k)] = mesh.corner_uvs[g][std::size_t(corner - o.begin())];
        } else {
          const glm::dvec3 l = barycentric(mesh.positions[o[0]], mesh.positions[o[1]], mesh.positions[o[2]],
                                           outer.positions[v]);
          const auto& ouv = mesh.corner_uvs[g];
          uv[std::size_t(k)] = glm::vec2(l.x * glm::dvec2(ouv[0]) + l.y * glm::dvec2(ouv[1]) + l.z * glm::dvec2(ouv[2]));
        }
      }
      out.corner_uvs.push_back(uv);
    }
  }
  if (!mesh.normals.empty()) out.normals = angle_weighted_normals(out);
  stats.triangles_removed = mesh.triangles.size() - unchanged;
  stats.triangles_added = out.triangles.size() - unchanged;

  const MeshCheckReport after = check_mesh(out, check);
  if (std::string why = worse(before, after); !why.empty()) return done("the outer surface has " + why);

  result.mesh = std::move(out);
  result.triangle_kind = std::move(kinds);
  result.stats.vertices = result.mesh.positions.size();
  result.stats.triangles = result.mesh.triangles.size();
  result.crossings.clear();
  for (const auto& [a, b] : after.self_intersection_examples) {
    Crossing c;
    std::size_t k = 0;
    for (const std::uint32_t f : {a, b}) {
      for (const std::uint32_t v : result.mesh.triangles[f]) {
        c.at += result.mesh.positions[v] / 6.0;
        if (nodes) c.nodes[k] = result.mesh.vertex_node[v];
        ++k;
      }
    }
    result.crossings.push_back(c);
  }
  stats.applied = true;
  stats.pairs_after = after.self_intersecting_pairs;
  stats.seconds = clock.lap();
  return stats;
}

}  // namespace sm
