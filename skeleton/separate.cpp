// Branch collision repair: see separate.h.

#include "skeleton/separate.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "core/errors.h"

namespace sm {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
/// Edge pairs closer than their radii, per edge, beyond which a skeleton is a dense hub (see
/// Separator::run). The samples have at most 2.6 (agraf), a grown 33,000-node tree 0.3; stars
/// of 300 and 1,000 twigs (clustered) 70 and 140.
constexpr std::size_t kDensePairsPerEdge = 16;

class Separator {
 public:
  Separator(Skeleton& s, const SeparateParams& p) : s_(s), p_(p) {
    const std::size_t n = s.size();
    depth_ = s.depths();
    size_.assign(n, 1);
    for (std::size_t i = n; i-- > 1;) size_[s.parent[i].idx()] += size_[i];
    // Subtrees must be contiguous index ranges (depth-first numbering, as build_skeleton makes).
    for (std::size_t i = 1; i < n; ++i) {
      const std::size_t par = s.parent[i].idx();
      SM_CHECK(i > par && i < par + size_[par], "separate_branches needs depth-first node numbering");
    }
  }

  /// Colliding pairs that are real collisions (not the overlap of two bundles leaving a fork).
  /// With `dense`, stops early and sets it when the edge pairs closer than their radii
  /// (collisions or fork overlaps) exceed kDensePairsPerEdge per edge.
  std::vector<Collision> collisions(double clearance, bool* dense = nullptr) const;
  SeparateReport run();

 private:
  struct PathPoint {
    dvec3 pos;
    double radius;
  };
  [[nodiscard]] bool in_subtree(std::size_t v, std::size_t root) const { return v >= root && v < root + size_[root]; }
  [[nodiscard]] std::size_t lca(std::size_t a, std::size_t b) const {
    while (depth_[a] > depth_[b]) a = s_.parent[a].idx();
    while (depth_[b] > depth_[a]) b = s_.parent[b].idx();
    while (a != b) {
      a = s_.parent[a].idx();
      b = s_.parent[b].idx();
    }
    return a;
  }
  /// Polyline from node c to the point at parameter t on edge k (k in c's subtree, or k == c
  /// for the edge below c), with radii.
  std::vector<PathPoint> path(std::size_t c, std::size_t k, double t) const {
    std::vector<PathPoint> pts;
    const std::size_t pk = s_.parent[k].idx();
    const PathPoint end{glm::mix(s_.position[pk], s_.position[k], t), glm::mix(s_.radius[pk], s_.radius[k], t)};
    if (k == c) {
      pts.push_back({s_.position[c], s_.radius[c]});
      pts.push_back(end);
      return pts;
    }
    for (std::size_t v = pk;; v = s_.parent[v].idx()) {
      pts.push_back({s_.position[v], s_.radius[v]});
      if (v == c) break;
    }
    std::reverse(pts.begin(), pts.end());
    pts.push_back(end);
    return pts;
  }
  static double length(const std::vector<PathPoint>& p) {
    double l = 0;
    for (std::size_t k = 1; k < p.size(); ++k) l += glm::length(p[k].pos - p[k - 1].pos);
    return l;
  }
  static PathPoint at(const std::vector<PathPoint>& p, double d) {
    for (std::size_t k = 1; k < p.size(); ++k) {
      const double l = glm::length(p[k].pos - p[k - 1].pos);
      if (d <= l || k + 1 == p.size()) {
        const double f = l > 0 ? std::clamp(d / l, 0.0, 1.0) : 1.0;
        return {glm::mix(p[k - 1].pos, p[k].pos, f), glm::mix(p[k - 1].radius, p[k].radius, f)};
      }
      d -= l;
    }
    return p.back();
  }
  /// True when the two edges overlap only because they leave their common ancestor together:
  /// walking both paths from the ancestor at equal distances, the cones never come apart
  /// before the collision.
  bool fork_overlap(std::size_t c, std::size_t i, double si, std::size_t j, double tj) const {
    const auto a = path(c, i, si), b = path(c, j, tj);
    const double la = length(a), lb = length(b), l = std::min(la, lb);
    const int samples = 24;
    for (int k = 1; k < samples; ++k) {
      const double d = l * k / samples;
      const PathPoint pa = at(a, d), pb = at(b, d);
      if (glm::length(pa.pos - pb.pos) > pa.radius + pb.radius) return false;
    }
    return true;
  }
  void rotate_subtree(std::size_t root, const dvec3& pivot, const dvec3& axis, double angle) {
    const double c = std::cos(angle), sn = std::sin(angle);
    for (std::size_t v = root; v < root + size_[root]; ++v) {
      const dvec3 x = s_.position[v] - pivot;
      s_.position[v] = pivot + x * c + glm::cross(axis, x) * sn + axis * glm::dot(axis, x) * (1 - c);
    }
  }

  Skeleton& s_;
  const SeparateParams& p_;
  std::vector<std::uint32_t> depth_;
  std::vector<std::size_t> size_;
};

std::vector<Collision> Separator::collisions(double clearance, bool* dense) const {
  const std::size_t n = s_.size();
  const std::size_t max_near = dense ? kDensePairsPerEdge * n : std::numeric_limits<std::size_t>::max();
  std::size_t near = 0;
  // Sweep and prune along the skeleton's longest extent: along x, a tall trunk whose edges all
  // share one x range made the sweep quadratic (a 60,000-node zigzag chain took 26 s).
  dvec3 lo_all(std::numeric_limits<double>::infinity()), hi_all(-std::numeric_limits<double>::infinity());
  for (const dvec3& p : s_.position) {
    lo_all = glm::min(lo_all, p);
    hi_all = glm::max(hi_all, p);
  }
  const dvec3 extent = hi_all - lo_all;
  const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  struct Box {
    dvec3 lo, hi;
    std::size_t e;
  };
  std::vector<Box> boxes;
  boxes.reserve(n);
  for (std::size_t i = 1; i < n; ++i) {
    const dvec3& a = s_.position[s_.parent[i].idx()];
    const dvec3& b = s_.position[i];
    const double r = std::max(s_.radius[i], s_.radius[s_.parent[i].idx()]) * (1 + clearance);
    boxes.push_back({glm::min(a, b) - dvec3(r), glm::max(a, b) + dvec3(r), i});
  }
  std::sort(boxes.begin(), boxes.end(), [axis](const Box& x, const Box& y) {
    return x.lo[axis] != y.lo[axis] ? x.lo[axis] < y.lo[axis] : x.e < y.e;
  });
  std::vector<Collision> out;
  for (std::size_t u = 0; u < boxes.size(); ++u) {
    for (std::size_t v = u + 1; v < boxes.size() && boxes[v].lo[axis] <= boxes[u].hi[axis]; ++v) {
      const Box& A = boxes[u];
      const Box& B = boxes[v];
      if (A.lo.x > B.hi.x || B.lo.x > A.hi.x || A.lo.y > B.hi.y || B.lo.y > A.hi.y || A.lo.z > B.hi.z ||
          B.lo.z > A.hi.z)
        continue;
      std::size_t i = std::min(A.e, B.e), j = std::max(A.e, B.e);
      const std::size_t pi = s_.parent[i].idx(), pj = s_.parent[j].idx();
      if (pi == pj || pj == i || pi == j) continue;  // edges sharing a node
      double si = 0, tj = 0;
      closest_segment_params(s_.position[pi], s_.position[i], s_.position[pj], s_.position[j], si, tj);
      const dvec3 x = glm::mix(s_.position[pi], s_.position[i], si);
      const dvec3 y = glm::mix(s_.position[pj], s_.position[j], tj);
      const double need =
          (glm::mix(s_.radius[pi], s_.radius[i], si) + glm::mix(s_.radius[pj], s_.radius[j], tj)) * (1 + clearance);
      const double dist = glm::length(x - y);
      if (dist >= need) continue;
      if (++near > max_near) {
        *dense = true;
        return {};
      }
      const std::size_t c = lca(i, j);
      if (fork_overlap(c, i, si, j, tj)) continue;
      out.push_back({NodeId(i), NodeId(j), need - dist});
    }
  }
  std::sort(out.begin(), out.end(), [](const Collision& a, const Collision& b) {
    return a.penetration != b.penetration ? a.penetration > b.penetration : std::pair(a.a, a.b) < std::pair(b.a, b.b);
  });
  return out;
}

SeparateReport Separator::run() {
  SeparateReport rep;
  const std::vector<dvec3> original = s_.position;
  const double detect = 0.5 * p_.clearance;  // detect below half the target gap: the result is stable
  // Rounds that stop lowering the collision count (dense hubs: hundreds of twigs from one
  // node, where every swing makes new collisions) end the separation, and the state with the
  // fewest collisions is kept: a star of 1,000 twigs took 13 s and moved twigs 12 m.
  constexpr std::size_t kPatience = 10;
  std::size_t best = std::numeric_limits<std::size_t>::max(), stale = 0;
  std::vector<dvec3> best_position;
  for (std::size_t round = 0; round < p_.max_rounds; ++round) {
    bool dense = false;
    const auto found = collisions(detect, &dense);
    if (dense) {
      // Edges crowding each other by the hundred (a hub of thousands of twigs): examining
      // the pairs alone is quadratic, and no swinging clears them. Left as it was, reported.
      rep.dense = true;
      s_.position = original;
      rep.unresolved = rep.collisions;  // 0 if found in the first round (not counted)
      return rep;
    }
    if (round == 0) rep.collisions = found.size();
    if (found.empty()) break;
    if (round == 0 && found.size() > s_.size()) {
      // More colliding pairs than edges: a dense hub no swinging can clear (a star of 5,000
      // twigs had 132,252 pairs, and each round took 12 s). Left as it is, reported.
      rep.unresolved = found.size();
      return rep;
    }
    if (found.size() < best) {
      best = found.size();
      best_position = s_.position;
      stale = 0;
    } else if (++stale >= kPatience) {
      break;
    }
    std::vector<std::pair<std::size_t, std::size_t>> moved;  // subtree ranges rotated this round
    for (const Collision& col : found) {
      const std::size_t i = col.a.idx(), j = col.b.idx();
      const std::size_t c = lca(i, j);
      // The subtree to swing: below c on one side, preferably the smaller one; j == c means
      // edge j lies below the ancestor, so only i's side can move.
      auto child_towards = [&](std::size_t k) {
        std::size_t v = k;
        while (s_.parent[v].idx() != c) v = s_.parent[v].idx();
        return v;
      };
      const std::size_t ci = i == c ? SIZE_MAX : child_towards(i);
      const std::size_t cj = j == c ? SIZE_MAX : child_towards(j);
      bool move_i = cj == SIZE_MAX || (ci != SIZE_MAX && size_[ci] <= size_[cj]);
      const std::size_t mover = move_i ? i : j, other = move_i ? j : i;
      std::size_t root = move_i ? ci : cj;
      if (root == SIZE_MAX) continue;
      // Prefer the nearest branch start (a child of a fork) on the way, if it gives a lever
      // long enough for a modest rotation.
      double s_m = 0, t_o = 0;
      const std::size_t pm = s_.parent[mover].idx(), po = s_.parent[other].idx();
      closest_segment_params(s_.position[pm], s_.position[mover], s_.position[po], s_.position[other], s_m, t_o);
      const dvec3 x = glm::mix(s_.position[pm], s_.position[mover], s_m);
      const dvec3 y = glm::mix(s_.position[po], s_.position[other], t_o);
      const double gap_need =
          glm::mix(s_.radius[pm], s_.radius[mover], s_m) + glm::mix(s_.radius[po], s_.radius[other], t_o);
      for (std::size_t v = mover; v != root; v = s_.parent[v].idx()) {
        const std::size_t pv = s_.parent[v].idx();
        if (s_.is_fork(NodeId(pv)) && glm::length(x - s_.position[pv]) > 3 * gap_need && !in_subtree(other, v)) {
          root = v;
          break;
        }
      }
      const std::size_t lo = root, hi = root + size_[root];
      bool overlaps = false;
      for (const auto& [a, b] : moved) overlaps |= lo < b && a < hi;
      if (overlaps) continue;
      const dvec3 pivot = s_.position[s_.parent[root].idx()];
      dvec3 sep = x - y;
      if (glm::length(sep) < 1e-12 * (1 + glm::length(x)))
        sep = any_perpendicular(normalize_or(x - pivot, dvec3(0, 0, 1)));
      sep = glm::normalize(sep);
      const dvec3 lever = x - pivot;
      dvec3 axis = glm::cross(lever, sep);
      if (glm::length(axis) < 1e-12 * (1 + glm::length(lever))) continue;
      axis = glm::normalize(axis);
      const dvec3 motion = glm::cross(axis, lever);  // displacement of x per radian
      const double gain = glm::dot(motion, sep);
      if (gain <= 1e-12) continue;
      const double want = gap_need * (1 + p_.clearance) - glm::length(x - y);
      const double angle = std::min(want / gain, p_.max_step_degrees * kDeg);
      rotate_subtree(root, pivot, axis, angle);
      moved.emplace_back(lo, hi);
      ++rep.rotations;
    }
  }
  rep.unresolved = collisions(detect).size();
  if (rep.unresolved > best) {
    s_.position = best_position;
    rep.unresolved = best;
  }
  for (std::size_t v = 0; v < s_.size(); ++v) {
    rep.max_displacement = std::max(rep.max_displacement, glm::length(s_.position[v] - original[v]));
  }
  return rep;
}

}  // namespace

SeparateReport separate_branches(Skeleton& skeleton, const SeparateParams& params) {
  if (skeleton.size() < 3) return {};
  Separator sep(skeleton, params);
  return sep.run();
}

std::vector<Collision> find_collisions(const Skeleton& skeleton, double clearance) {
  if (skeleton.size() < 3) return {};
  Skeleton copy = skeleton;  // Separator keeps a mutable reference
  SeparateParams p;
  Separator sep(copy, p);
  return sep.collisions(clearance);
}

}  // namespace sm
