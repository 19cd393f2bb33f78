// Caps and junctions of a mesh, from its skeleton (meshcheck/regions.h).

#include "meshcheck/regions.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace sm::detail {

using glm::dvec3;

std::vector<std::uint32_t> cap_ends(const Mesh& mesh, const Skeleton& skel) {
  std::vector<std::uint32_t> end(mesh.positions.size(), 0);
  std::vector<Cone> cones = skeleton_cones(skel);
  if (cones.empty() || skel.size() < 2) return end;
  std::vector<std::uint32_t> children(skel.size(), 0);
  for (std::size_t i = 0; i < skel.size(); ++i) {
    if (skel.parent[i].valid()) ++children[skel.parent[i].idx()];
  }
  const ConeTree tree(std::move(cones));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, end.size(), 4096), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      const dvec3& p = mesh.positions[v];
      const std::uint32_t n = tree.nearest(p).id;
      const NodeId parent = skel.parent[n];
      if (!parent.valid()) continue;
      const dvec3 a = skel.position[parent.idx()], b = skel.position[n];
      const double len = glm::length(b - a);
      if (!(len > 0)) continue;
      const dvec3 d = (b - a) / len;
      if (children[n] == 0 && glm::dot(p - b, d) >= -0.05 * skel.radius[n]) {
        end[v] = n + 1;
      } else if (!skel.parent[parent.idx()].valid() && glm::dot(p - a, d) <= 0.05 * skel.radius[parent.idx()]) {
        end[v] = parent.value + 1;
      }
    }
  });
  return end;
}

std::vector<std::uint8_t> cap_triangles(const Mesh& mesh, const std::vector<std::uint32_t>& cap_end) {
  std::vector<std::uint8_t> cap(mesh.triangles.size(), 0);
  if (cap_end.size() != mesh.positions.size()) return cap;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    cap[f] = cap_end[t[0]] != 0 && cap_end[t[0]] == cap_end[t[1]] && cap_end[t[0]] == cap_end[t[2]];
  }
  return cap;
}

std::unique_ptr<ConeTree> junction_balls(const Skeleton& s, double junction_radii) {
  std::vector<std::uint32_t> children(s.size(), 0);
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.parent[i].valid()) ++children[s.parent[i].idx()];
  }
  std::vector<Cone> spheres;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (children[i] < 2) continue;
    const double r = junction_radii * s.radius[i];
    spheres.push_back({s.position[i], s.position[i], r, r, static_cast<std::uint32_t>(i)});
  }
  if (spheres.empty()) return nullptr;
  return std::make_unique<ConeTree>(std::move(spheres));
}

}  // namespace sm::detail
