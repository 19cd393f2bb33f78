// Tree attributes for wind and shading (see tree_attributes.h).

#include "meshio/tree_attributes.h"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/errors.h"
#include "core/rng.h"

namespace sm {

namespace {

// The nearest point to p on segment [a, b]: its parameter in [0, 1] and squared distance.
std::pair<double, double> nearest_on_segment(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b) {
  const glm::dvec3 d = b - a;
  const double l2 = glm::dot(d, d);
  const double t = l2 > 0 ? std::clamp(glm::dot(p - a, d) / l2, 0.0, 1.0) : 0.0;
  const glm::dvec3 q = a + t * d;
  return {t, glm::dot(p - q, p - q)};
}

}  // namespace

TreeAttributes compute_tree_attributes(const Mesh& mesh, const Skeleton& s) {
  const std::size_t nv = mesh.positions.size(), nn = s.size();
  if (mesh.vertex_node.size() != nv) {
    throw InvalidInputError("tree attributes need the skeleton node of every vertex, which only a mesh made by the "
                            "pipeline has (not one read from a file)");
  }
  TreeAttributes a;
  // Per node: distance from the root along the tree.
  std::vector<double> dist(nn, 0.0);
  for (std::size_t i = 1; i < nn; ++i) dist[i] = dist[s.parent[i].idx()] + s.edge_length(NodeId(i));
  const std::vector<std::uint32_t> branch = s.branch_ids();
  a.level.assign(nn, 0);
  a.pivot.assign(nn, glm::dvec3(0));
  a.direction.assign(nn, glm::dvec3(0, 0, 1));
  a.phase.assign(nn, 0.0f);
  for (std::size_t i = 0; i < nn; ++i) {
    if (branch[i] != i) continue;  // not a branch start
    const NodeId p = s.parent[i];
    a.level[i] = p.valid() ? a.level[branch[p.idx()]] + 1 : 0;  // parents come first
    a.max_level = std::max(a.max_level, a.level[i]);
    a.pivot[i] = p.valid() ? s.position[p.idx()] : s.position[i];
    glm::dvec3 d(0, 0, 1);
    if (p.valid()) {
      d = s.position[i] - s.position[p.idx()];
    } else if (s.children[i][0].valid()) {
      d = s.position[s.children[i][0].idx()] - s.position[i];
    }
    const double l = glm::length(d);
    a.direction[i] = l > 0 ? d / l : glm::dvec3(0, 0, 1);
    // 24 random bits of a hash of the branch id: exact in a float, in [0, 1).
    a.phase[i] = static_cast<float>(derive_seed(0x7769'6e64, i) >> 40) / 16777216.0f;
  }
  a.root_distance.resize(nv);
  a.thickness.resize(nv);
  a.vertex_branch.resize(nv);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      const NodeId n = mesh.vertex_node[v];
      if (!n.valid() || n.idx() >= nn) {
        throw InvalidInputError("tree attributes: vertex " + std::to_string(v) + " has no skeleton node");
      }
      const glm::dvec3& p = mesh.positions[v];
      // The edges at n: to its parent and to each child; keep the nearest.
      double best = std::numeric_limits<double>::infinity(), d = dist[n.idx()], r_at = s.radius[n.idx()];
      auto consider = [&](std::size_t lo, std::size_t hi) {  // edge from node lo to its child hi
        const auto [t, d2] = nearest_on_segment(p, s.position[lo], s.position[hi]);
        if (d2 < best) {
          best = d2;
          d = dist[lo] + t * (dist[hi] - dist[lo]);
          r_at = s.radius[lo] + t * (s.radius[hi] - s.radius[lo]);
        }
      };
      if (s.parent[n.idx()].valid()) consider(s.parent[n.idx()].idx(), n.idx());
      for (const NodeId c : s.children[n.idx()]) {
        if (c.valid()) consider(n.idx(), c.idx());
      }
      a.root_distance[v] = static_cast<float>(d);
      a.thickness[v] = static_cast<float>(r_at);
      a.vertex_branch[v] = branch[n.idx()];
    }
  });
  for (std::size_t v = 0; v < nv; ++v) {
    a.max_root_distance = std::max(a.max_root_distance, a.root_distance[v]);
    a.max_thickness = std::max(a.max_thickness, a.thickness[v]);
  }
  return a;
}

}  // namespace sm
