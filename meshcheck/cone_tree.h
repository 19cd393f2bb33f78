#pragma once
/// Internal to meshcheck: round cones (the convex hull of two spheres, one per skeleton edge)
/// and a bounding-volume hierarchy that finds the nearest one to a point exactly.
///
/// The index is a small BVH over the cones rather than a point kd-tree (nanoflann): the
/// distance to a cone depends on its radii, and a box per cone gives exact lower bounds for
/// branch-and-bound, so the nearest cone is found exactly in O(log N) on typical trees.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#include <glm/glm.hpp>

#include "skeleton/skeleton.h"

namespace sm::detail {

using glm::dvec3;


struct Cone {
  dvec3 a, b;     // end sphere centres (b == a for a lone node)
  double ra, rb;  // end sphere radii (> 0)
  std::uint32_t id = 0;  // the caller's number for it (checks: the skeleton node at b)
};

struct ConeDistance {
  double distance;  // signed: negative inside
  double radius;    // cone radius at the closest point
  std::uint32_t id = 0;  // Cone::id of the nearest cone
  double t = 0;          // where along the cone the closest point lies: 0 at sphere a, 1 at sphere b
};

// Signed distance from p to the convex hull of the spheres (a, ra) and (b, rb). In the half
// plane through the axis, the hull's outline is two circles joined by their common tangent;
// the point's coordinate along that tangent decides whether sphere a, sphere b or the
// tangent (the conical side) is closest.
inline ConeDistance cone_distance(const Cone& c, const dvec3& p) {
  const dvec3 axis = c.b - c.a;
  const double len = glm::length(axis);
  if (len <= std::abs(c.ra - c.rb)) {  // one sphere contains the other (or a single node)
    const bool a_big = c.ra >= c.rb;
    const dvec3& centre = a_big ? c.a : c.b;
    const double r = a_big ? c.ra : c.rb;
    return {glm::length(p - centre) - r, r, c.id, a_big ? 0.0 : 1.0};
  }
  const dvec3 e = axis / len;
  const dvec3 w = p - c.a;
  const double y = glm::dot(w, e);          // along the axis
  const double x = glm::length(w - y * e);  // away from the axis
  const double s = (c.ra - c.rb) / len;     // sine of the cone's half angle
  const double co = std::sqrt(std::max(0.0, 1.0 - s * s));
  const double u = y * co - x * s;  // along the tangent, 0 at a's tangent point
  if (u <= 0) return {glm::length(w) - c.ra, c.ra, c.id, 0.0};
  if (u >= len * co) return {glm::length(p - c.b) - c.rb, c.rb, c.id, 1.0};
  const double d = y * s + x * co - c.ra;                    // distance to the tangent line
  const double t = std::clamp((y - d * s) / len, 0.0, 1.0);  // axial position of the closest point
  return {d, c.ra + t * (c.rb - c.ra), c.id, t};
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


/// The round cone of every edge of `skel` (id: the node at its upper end; its radii
/// Skeleton::start_radius and the node's), or for a lone node its sphere.
inline std::vector<Cone> skeleton_cones(const Skeleton& skel) {
  std::vector<Cone> cones;
  for (std::size_t i = 0; i < skel.size(); ++i) {
    const auto id = static_cast<std::uint32_t>(i);
    const NodeId parent = skel.parent[i];
    if (parent.valid()) {
      cones.push_back({skel.position[parent.idx()], skel.position[i], skel.start_radius(NodeId(id)), skel.radius[i], id});
    } else if (skel.size() == 1) {
      cones.push_back({skel.position[i], skel.position[i], skel.radius[i], skel.radius[i], id});
    }
  }
  return cones;
}

}  // namespace sm::detail
