// Outer surface: the last resort for the self-intersections and thick nodes outside left (see
// outer_surface.h).

#include "repair/outer_surface.h"
#include "repair/verdict.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "core/math.h"
#include "core/report.h"
#include "meshcheck/checks.h"
#include "repair/outer_surface_cgal.h"

namespace sm {

namespace {

/// Barycentric coordinates of p projected onto the plane of (a, b, c), clamped to the
/// triangle (p lies on it up to rounding: it was cut from it).
glm::dvec3 clamped_barycentric(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& p) {
  const glm::dvec3 l = glm::max(barycentric(a, b, c, p), glm::dvec3(0.0));
  const double s = l.x + l.y + l.z;
  return s > 0 ? l / s : glm::dvec3(1.0, 0.0, 0.0);
}

/// `outer` (cut from `base`'s mesh) as a mesh with the attributes of the triangles it was cut from.
struct Candidate {
  Mesh mesh;
  std::vector<TriangleKind> kinds;
};
/// Vertices below `nv_old` keep their index (and attributes); the others are new. No normals
/// (made for the surface kept only).
Candidate candidate_mesh(const MeshResult& base, const OuterSurface& outer, std::size_t nv_old) {
  const Mesh& mesh = base.mesh;
  std::vector<std::uint32_t> remap(outer.positions.size(), UINT32_MAX);
  for (const auto& t : outer.triangles) {
    for (const std::uint32_t v : t) remap[v] = 0;
  }
  Candidate cand;
  Mesh& out = cand.mesh;
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
    const bool snap = v >= nv_old && base.grid > 0;
    out.positions.push_back(snap ? snap_to_grid(outer.positions[v], base.grid) : outer.positions[v]);
    const std::uint32_t from = v < nv_old ? static_cast<std::uint32_t>(v) : nearest_corner[v];
    if (strands) out.vertex_strand.push_back(v < nv_old ? mesh.vertex_strand[v] : StrandId{});
    if (nodes) out.vertex_node.push_back(mesh.vertex_node[from]);
  }
  for (std::size_t f = 0; f < outer.triangles.size(); ++f) {
    const std::uint32_t g = outer.origin[f];
    const Mesh::Triangle& t = outer.triangles[f];
    const Mesh::Triangle& o = mesh.triangles[g];
    out.triangles.push_back({remap[t[0]], remap[t[1]], remap[t[2]]});
    if (!mesh.triangle_branch.empty()) out.triangle_branch.push_back(mesh.triangle_branch[g]);
    if (!base.triangle_kind.empty()) cand.kinds.push_back(base.triangle_kind[g]);
    if (!mesh.corner_uvs.empty()) {
      std::array<glm::vec2, 3> uv{};
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t v = t[std::size_t(k)];
        const auto corner = std::find(o.begin(), o.end(), v);
        if (corner != o.end()) {
          uv[std::size_t(k)] = mesh.corner_uvs[g][std::size_t(corner - o.begin())];
        } else {
          const glm::dvec3 l = clamped_barycentric(mesh.positions[o[0]], mesh.positions[o[1]], mesh.positions[o[2]],
                                           outer.positions[v]);
          const auto& ouv = mesh.corner_uvs[g];
          uv[std::size_t(k)] = glm::vec2(l.x * glm::dvec2(ouv[0]) + l.y * glm::dvec2(ouv[1]) + l.z * glm::dvec2(ouv[2]));
        }
      }
      out.corner_uvs.push_back(uv);
    }
  }
  return cand;
}

/// A unit sphere: the octahedron subdivided twice (128 triangles, outward), turned by
/// `turn` radians about a fixed oblique axis (another turn moves its vertices off whatever
/// they met in the mesh).
Mesh unit_sphere(double turn) {
  Mesh m;
  m.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int s = 0; s < 2; ++s) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const auto [it, fresh] = mid.try_emplace(std::minmax(a, b), static_cast<std::uint32_t>(m.positions.size()));
      if (fresh) m.positions.push_back(glm::normalize(m.positions[a] + m.positions[b]));
      return it->second;
    };
    std::vector<Mesh::Triangle> next;
    for (const auto& t : m.triangles) {
      const std::uint32_t ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
      next.push_back({t[0], ab, ca});
      next.push_back({t[1], bc, ab});
      next.push_back({t[2], ca, bc});
      next.push_back({ab, bc, ca});
    }
    m.triangles = std::move(next);
  }
  const glm::dvec3 axis = glm::normalize(glm::dvec3(1, 2, 3));
  for (auto& q : m.positions) {  // Rodrigues' rotation
    q = q * std::cos(turn) + glm::cross(axis, q) * std::sin(turn) + axis * glm::dot(axis, q) * (1 - std::cos(turn));
  }
  return m;
}

/// The outer surface by winding numbers is tried cluster by cluster at up to this many clusters
/// (each a check of the whole mesh).
constexpr std::size_t kMaxClusters = 16;

/// Thick nodes outside get a sphere only when at most this far from the mesh, relative to their
/// radius, and at most kMaxSpheres of them.
constexpr double kMaxMiss = 0.5;
constexpr std::size_t kMaxSpheres = 16;

/// A thick node outside the mesh: how far, and the mesh triangle nearest to it.
struct Miss {
  std::uint32_t node = 0;
  double distance = 0;
  std::uint32_t nearest = 0;
};
Miss miss_of(const Mesh& mesh, const Skeleton& skeleton, std::uint32_t node) {
  Miss m{node, std::numeric_limits<double>::infinity(), 0};
  const glm::dvec3 c = skeleton.position[node];
  for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    const double d =
        glm::distance(c, closest_on_triangle(c, mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]));
    if (d < m.distance) {
      m.distance = d;
      m.nearest = f;
    }
  }
  return m;
}

/// A small sphere around each node of `misses` (separate parts, to be joined to the mesh by a
/// union): centred on the node, reaching `reach` of its radius beyond its distance to the
/// mesh. Sphere triangles take the branch, kind and UVs of `result`'s triangle nearest the
/// node (one UV for the whole sphere), sphere vertices that node and no strand.
MeshResult spheres_around(const MeshResult& result, const Skeleton& skeleton, const std::vector<Miss>& misses,
                          double reach, double turn) {
  MeshResult out;
  Mesh& m = out.mesh;
  const Mesh sphere = unit_sphere(turn);
  for (const auto& [n, distance, nearest] : misses) {
    const glm::dvec3 c = skeleton.position[n];
    const double radius = distance + reach * skeleton.radius[n];
    const auto first = static_cast<std::uint32_t>(m.positions.size());
    for (const auto& q : sphere.positions) {
      const glm::dvec3 p = c + radius * q;
      m.positions.push_back(result.grid > 0 ? snap_to_grid(p, result.grid) : p);
      if (!result.mesh.vertex_strand.empty()) m.vertex_strand.push_back(StrandId{});
      if (!result.mesh.vertex_node.empty()) m.vertex_node.push_back(NodeId(n));
    }
    for (const auto& t : sphere.triangles) {
      m.triangles.push_back({first + t[0], first + t[1], first + t[2]});
      if (!result.mesh.triangle_branch.empty()) m.triangle_branch.push_back(result.mesh.triangle_branch[nearest]);
      if (!result.triangle_kind.empty()) out.triangle_kind.push_back(result.triangle_kind[nearest]);
      if (!result.mesh.corner_uvs.empty()) {
        const glm::vec2 uv = result.mesh.corner_uvs[nearest][0];
        m.corner_uvs.push_back({uv, uv, uv});
      }
    }
  }
  return out;
}

/// `a` followed by `b` (b's indices shifted; the attributes both carry; no normals): the
/// triangles a union of the two is cut from, in union_of's order.
MeshResult joined(const MeshResult& a, const MeshResult& b) {
  MeshResult out;
  out.grid = a.grid;
  Mesh& m = out.mesh;
  m = a.mesh;
  m.normals.clear();
  const auto shift = static_cast<std::uint32_t>(m.positions.size());
  auto append = [](auto& to, const auto& from) { to.insert(to.end(), from.begin(), from.end()); };
  append(m.positions, b.mesh.positions);
  append(m.vertex_strand, b.mesh.vertex_strand);
  append(m.vertex_node, b.mesh.vertex_node);
  for (const auto& t : b.mesh.triangles) m.triangles.push_back({t[0] + shift, t[1] + shift, t[2] + shift});
  append(m.triangle_branch, b.mesh.triangle_branch);
  append(m.corner_uvs, b.mesh.corner_uvs);
  out.triangle_kind = a.triangle_kind;
  append(out.triangle_kind, b.triangle_kind);
  return out;
}

}  // namespace

OuterSurfaceStats keep_outer_surface(MeshResult& result, Crossings& crossings, const Skeleton& skeleton,
                                     bool thick_nodes_outside) {
  OuterSurfaceStats stats;
  if (!crossings.counted || (crossings.pairs.empty() && !thick_nodes_outside)) return stats;
  Stopwatch clock;
  stats.tried = true;
  MeshCheckParams check;
  check.skeleton = &skeleton;
  check.max_examples = std::numeric_limits<std::size_t>::max();  // every pair and node
  MeshCheckReport now = check_mesh(result.mesh, check);
  stats.pairs_before = stats.pairs_after = now.self_intersecting_pairs;
  stats.nodes_inside_before = stats.nodes_inside_after = now.thick_nodes_inside;
  stats.triangles_before = stats.triangles_after = result.mesh.triangles.size();

  // The outer surface of `base` replaces the mesh by the repair's rule (verdict.h), the genus
  // kept: a handle is the self-union's to make.
  std::vector<std::string> refused;
  auto attempt = [&](const MeshResult& base, const OuterSurface& outer, std::size_t kept, const std::string& what) {
    if (outer.triangles.empty() || !outer.fixed) {
      refused.push_back(what + ": " + (outer.problem.empty() ? "CGAL failed" : outer.problem));
      return false;
    }
    Candidate cand = candidate_mesh(base, outer, kept);
    const MeshCheckReport after = check_mesh(cand.mesh, check);
    const std::string why = refuse(figures_of(now), figures_of(after));
    if (!why.empty()) {
      if (!what.empty()) refused.push_back(what + ": " + why);
      return false;
    }
    if (!result.mesh.normals.empty()) cand.mesh.normals = angle_weighted_normals(cand.mesh);
    result.mesh = std::move(cand.mesh);
    result.triangle_kind = std::move(cand.kinds);
    result.stats.vertices = result.mesh.positions.size();
    result.stats.triangles = result.mesh.triangles.size();
    crossings.pairs.clear();
    for (const auto& [a, b] : after.self_intersection_examples) crossings.pairs.push_back(crossing_of(result.mesh, a, b));
    now = after;
    stats.applied = true;
    return true;
  };
  // Parts inside parts.
  if (now.self_intersecting_pairs > 0) {
    // CGAL's choice of patches first; where that is refused (it goes wrong at folds), the
    // patches chosen by winding numbers; where that is refused too, the same cluster by
    // cluster (a crossing where two parts make a handle, or cut off a branch, is left as it
    // is; the others are mended), each kept if it does better.
    if (!attempt(result, outer_surface(result.mesh), result.mesh.positions.size(), "outer surface")) {
      const std::size_t kept = result.mesh.positions.size();
      const WindingPatches patches(result.mesh);
      const std::size_t n = patches.clusters();
      std::vector<std::uint8_t> apply(n, 1);
      if (!attempt(result, patches.surface(apply), kept, "outer surface by winding") && n > 1 &&
          patches.problem().empty()) {
        // (A refused attempt leaves the mesh as it was; the clusters kept replace it, so each
        // later candidate is cut from a copy of the mesh the patches were made from.)
        const MeshResult base = result;
        apply.assign(n, 0);
        stats.clusters = std::min(n, kMaxClusters);
        for (std::size_t k = 0; k < stats.clusters; ++k) {
          apply[k] = 1;
          if (attempt(base, patches.surface(apply), kept, ""))
            ++stats.clusters_kept;
          else
            apply[k] = 0;
        }
        if (stats.clusters_kept < n)
          refused.push_back("outer surface by winding at " + std::to_string(n - stats.clusters_kept) + " of " +
                            std::to_string(n) + " clusters of crossings: no better");
      }
    }
  }
  // Thick nodes outside: all at once, then one by one; the spheres reaching a quarter of the
  // node's radius beyond the mesh, else a tenth (a larger one may bridge a crotch: genus 1),
  // each turned once more if the first does not do (a sliver where its vertices meet the
  // mesh's).
  // Only near misses get one (within kMaxMiss of their radius of the mesh; 0.03-0.3 on the
  // samples), and only where there are few: many nodes outside are a tangle of branches
  // through each other (a hub of hundreds of twigs), which spheres do not mend.
  std::vector<Miss> near;
  for (const std::uint32_t n : now.outside_node_examples) {
    if (near.size() > kMaxSpheres) break;  // (each distance is a pass over the mesh)
    const Miss m = miss_of(result.mesh, skeleton, n);
    if (m.distance <= kMaxMiss * skeleton.radius[n]) near.push_back(m);
  }
  if (near.size() > kMaxSpheres) {
    refused.push_back("more than " + std::to_string(kMaxSpheres) + " thick nodes just outside: none gets a sphere");
    near.clear();
  }
  auto blobs = [&](const std::vector<Miss>& nodes) {
    std::string what = nodes.size() > 1 ? "spheres around nodes" : "sphere around node";
    for (std::size_t i = 0; i < nodes.size(); ++i) what += (i ? ", " : " ") + std::to_string(nodes[i].node);
    for (const auto& [reach, turn] : {std::pair{0.25, 0.0}, {0.25, 0.5}, {0.1, 0.0}, {0.1, 0.5}}) {
      // The spheres joined by a union with the mesh alone (CGAL's corefinement), which leaves
      // the mesh's own folds elsewhere as they are.
      const MeshResult spheres = spheres_around(result, skeleton, nodes, reach, turn);
      if (attempt(joined(result, spheres), union_of(result.mesh, spheres.mesh), result.mesh.positions.size(), what)) {
        stats.blobs += nodes.size();
        return true;
      }
    }
    return false;
  };
  if (!near.empty() && !blobs(near) && near.size() > 1) {
    for (const Miss& m : near) blobs({m});
  }
  stats.pairs_after = now.self_intersecting_pairs;
  stats.nodes_inside_after = now.thick_nodes_inside;
  stats.triangles_after = result.mesh.triangles.size();
  for (const auto& r : refused) stats.refused += (stats.refused.empty() ? "" : "; ") + r;
  stats.seconds = clock.lap();
  return stats;
}

std::string to_text(const OuterSurfaceStats& os) {
  char line[256];
  std::snprintf(line, sizeof line,
                "%zu -> %zu self-intersecting pairs, %zu -> %zu thick nodes inside (%zu with a sphere), %zu -> %zu "
                "triangles, in %.3f s",
                os.pairs_before, os.pairs_after, os.nodes_inside_before, os.nodes_inside_after, os.blobs,
                os.triangles_before, os.triangles_after, os.seconds);
  std::string text = line;
  if (os.clusters > 0)
    text += "; by winding numbers at " + std::to_string(os.clusters_kept) + " of " + std::to_string(os.clusters) +
            " clusters of crossings";
  return text;
}

}  // namespace sm
