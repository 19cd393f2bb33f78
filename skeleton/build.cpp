// Skeleton validation and sanitizing. Real skeletons (QSM, MTG,
// Sapling output; ../shared/skeletons/README.md) need every repair below, so each one is
// counted and reported rather than silently applied.

#include "skeleton/build.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <string>
#include <unordered_map>

#include "core/errors.h"
#include "skeleton/frames.h"
#include "skeleton/separate.h"

namespace sm {
namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
constexpr double kInnerNearForkDegrees = 10.0;  // see merge_inner_branches

std::string fmt(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

/// The n-ary working tree: indices into the raw arrays plus inserted nodes.
struct WorkTree {
  std::vector<dvec3> pos;
  std::vector<double> radius;
  std::vector<std::uint32_t> parent;                 // kNone for the root
  std::vector<std::vector<std::uint32_t>> children;  // in input order
  std::vector<std::int64_t> source;                  // input id or -1
  std::vector<double> base;                          // Skeleton::base_radius (0: the parent's radius)
  std::vector<bool> removed;
  std::uint32_t root = 0;

  std::uint32_t add(dvec3 p, double r, std::uint32_t par, std::int64_t src) {
    pos.push_back(p);
    radius.push_back(r);
    parent.push_back(par);
    children.emplace_back();
    source.push_back(src);
    base.push_back(0.0);
    removed.push_back(false);
    return static_cast<std::uint32_t>(pos.size() - 1);
  }

  /// The node a branch arrives at v from: the nearest ancestor at least v's radius away (the
  /// root if none is; the nodes of an n-ary hub lie a tiny step apart, in no meaningful
  /// direction). kNone for the root.
  [[nodiscard]] std::uint32_t arrival_ancestor(std::uint32_t v) const {
    std::uint32_t a = parent[v];
    while (a != kNone && parent[a] != kNone && glm::length(pos[v] - pos[a]) < radius[v]) a = parent[a];
    return a;
  }

  /// Where node x projects onto the line of the edge from node a to node b: parameter `t`
  /// (0 at a, 1 at b, unclamped), the foot point, the edge's length, the round cone's radius
  /// at t and x's distance from the axis.
  struct Projection {
    double t, length, radius, offset;
    dvec3 foot;
  };
  [[nodiscard]] Projection project(std::uint32_t x, std::uint32_t a, std::uint32_t b) const {
    const dvec3 ab = pos[b] - pos[a];
    const double l2 = glm::dot(ab, ab);
    Projection pr{};
    pr.t = glm::dot(pos[x] - pos[a], ab) / l2;
    pr.length = std::sqrt(l2);
    pr.radius = glm::mix(parent[b] == a && base[b] > 0 ? base[b] : radius[a], radius[b], pr.t);
    pr.foot = pos[a] + pr.t * ab;
    pr.offset = glm::length(pos[x] - pr.foot);
    return pr;
  }

  /// Inserts a node at `p` (radius `r`) on the edge from c's parent to c, in c's child slot.
  std::uint32_t insert_above(std::uint32_t c, dvec3 p, double r) {
    const std::uint32_t par = parent[c];
    const std::uint32_t m = add(p, r, par, -1);
    std::swap(base[m], base[c]);  // the upper part starts at m's radius
    *std::find(children[par].begin(), children[par].end(), c) = m;
    children[m].push_back(c);
    parent[c] = m;
    return m;
  }

  /// Removes node x, its children moving to node m (appended to m's children). Their edges
  /// keep starting at x's radius (or their own base radius) where m is thicker.
  void fold_into(std::uint32_t x, std::uint32_t m) {
    for (const std::uint32_t g : children[x]) {
      children[m].push_back(g);
      parent[g] = m;
      const double start = base[g] > 0 ? base[g] : radius[x];
      base[g] = start < radius[m] ? start : 0.0;
    }
    children[x].clear();
    removed[x] = true;
    auto& siblings = children[parent[x]];
    siblings.erase(std::find(siblings.begin(), siblings.end(), x));
  }

  /// Live nodes in breadth-first order from the root (parents before children).
  [[nodiscard]] std::vector<std::uint32_t> bfs() const {
    std::vector<std::uint32_t> order;
    order.reserve(pos.size());
    order.push_back(root);
    for (std::size_t k = 0; k < order.size(); ++k) {
      for (std::uint32_t c : children[order[k]]) order.push_back(c);
    }
    return order;
  }
};

[[noreturn]] void reject(const std::string& msg) {
  throw InvalidInputError(msg);
}

/// "file: place" for error messages (places in RawSkeleton::where do not repeat the file).
std::string at(const RawSkeleton& raw, std::size_t i) {
  return raw.source.empty() ? raw.place(i) : raw.source + ": " + raw.place(i);
}

/// Validation: everything that makes the input malformed, each with one clear message.
/// Returns the index of the root. Fills `index_of` (id -> index).
std::uint32_t validate(const RawSkeleton& raw, const SkeletonParams& params,
                       std::unordered_map<std::int64_t, std::uint32_t>& index_of) {
  const std::size_t n = raw.size();
  if (raw.parent_id.size() != n || raw.position.size() != n || raw.radius.size() != n) {
    throw InternalError("RawSkeleton arrays have different lengths");
  }
  const std::string file = raw.source.empty() ? std::string("skeleton") : raw.source;
  if (n == 0) reject(file + ": the skeleton has no nodes");
  if (n > params.max_nodes) {
    reject(file + ": the skeleton has " + std::to_string(n) + " nodes, more than the limit of " +
           std::to_string(params.max_nodes) + " (raise it with --max-nodes)");
  }
  index_of.reserve(n * 2);
  std::uint32_t root = kNone;
  for (std::size_t i = 0; i < n; ++i) {
    const std::string where = at(raw, i);
    if (raw.id[i] < 0) reject(where + ": node id " + std::to_string(raw.id[i]) + " is negative; ids must be >= 0");
    if (raw.parent_id[i] < -1) {
      reject(where + ": parent " + std::to_string(raw.parent_id[i]) + " is invalid; use -1 for the root or a node id");
    }
    const dvec3& p = raw.position[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      reject(where + ": position (" + fmt(p.x) + ", " + fmt(p.y) + ", " + fmt(p.z) + ") is not finite");
    }
    if (!std::isfinite(raw.radius[i])) reject(where + ": radius " + fmt(raw.radius[i]) + " is not finite");
    if (raw.radius[i] < 0) reject(where + ": radius " + fmt(raw.radius[i]) + " is negative; radii must be >= 0");
    auto [it, inserted] = index_of.emplace(raw.id[i], static_cast<std::uint32_t>(i));
    if (!inserted) {
      reject(where + ": duplicate node id " + std::to_string(raw.id[i]) + " (also at " + raw.place(it->second) + ")");
    }
    if (raw.parent_id[i] == -1) {
      if (root != kNone) {
        reject(where + ": a second root (parent -1); the skeleton must have exactly one root, the first is at " +
               raw.place(root));
      }
      root = static_cast<std::uint32_t>(i);
    }
  }
  std::vector<std::uint32_t> children(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t pid = raw.parent_id[i];
    if (pid == -1) continue;
    if (pid == raw.id[i]) reject(at(raw, i) + ": node is its own parent (a cycle)");
    const auto parent = index_of.find(pid);
    if (parent == index_of.end()) {
      reject(at(raw, i) + ": parent id " + std::to_string(pid) + " does not exist");
    }
    if (++children[parent->second] > SkeletonLimits::max_children) {
      const std::size_t total = static_cast<std::size_t>(
          std::count(raw.parent_id.begin(), raw.parent_id.end(), raw.id[parent->second]));
      reject(at(raw, parent->second) + ": " + std::to_string(total) + " children; a node may have at most " +
             std::to_string(SkeletonLimits::max_children) +
             " (a hub of that many branches from one point is not meshed well nor in reasonable time; spread "
             "them over nodes along the branch)");
    }
  }
  if (root == kNone) reject(file + ": no root (no node has parent -1); the parent links form a cycle");
  return root;
}

/// Builds children lists and rejects cycles (nodes not reachable from the root).
WorkTree make_tree(const RawSkeleton& raw, std::uint32_t root,
                   const std::unordered_map<std::int64_t, std::uint32_t>& index_of) {
  const std::size_t n = raw.size();
  WorkTree t;
  t.pos = raw.position;
  t.radius = raw.radius;
  t.parent.assign(n, kNone);
  t.children.resize(n);
  t.source = raw.id;
  t.base = raw.base_radius.size() == n ? raw.base_radius : std::vector<double>(n, 0.0);
  t.removed.assign(n, false);
  t.root = root;
  for (std::size_t i = 0; i < n; ++i) {
    if (raw.parent_id[i] == -1) continue;
    const std::uint32_t p = index_of.at(raw.parent_id[i]);
    t.parent[i] = p;
    t.children[p].push_back(static_cast<std::uint32_t>(i));
  }
  const auto order = t.bfs();
  if (order.size() != n) {
    // Every node has one parent and there is one root, so an unreachable node leads, by
    // following parents, into a cycle. Find and name it.
    std::vector<bool> reached(n, false);
    for (auto i : order) reached[i] = true;
    std::uint32_t start = 0;
    while (reached[start]) ++start;
    std::vector<std::uint32_t> seen_at(n, kNone);
    std::vector<std::uint32_t> path;
    std::uint32_t v = start;
    while (seen_at[v] == kNone) {
      seen_at[v] = static_cast<std::uint32_t>(path.size());
      path.push_back(v);
      v = t.parent[v];
    }
    std::string cycle;
    const std::size_t from = seen_at[v];
    for (std::size_t k = from; k < path.size() && k < from + 8; ++k) {
      cycle += std::to_string(raw.id[path[k]]) + " -> ";
    }
    cycle += path.size() - from > 8 ? "..." : std::to_string(raw.id[v]);
    reject(at(raw, v) + ": the parent links form a cycle (ids " + cycle + "); a skeleton must be a tree");
  }
  return t;
}

/// Magnitudes a float32 mesh can resolve (SkeletonLimits in build.h), checked on the radii
/// as the floor will leave them, before any repair.
void check_magnitudes(const RawSkeleton& raw, double floor) {
  const std::size_t n = raw.size();
  dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  std::size_t thinnest = 0, farthest = 0;
  double reach = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const dvec3& p = raw.position[i];
    const double r = std::max(raw.radius[i], floor);
    const double far = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    if (far + r > SkeletonLimits::max_coordinate) {
      reject(at(raw, i) + ": position (" + fmt(p.x) + ", " + fmt(p.y) + ", " + fmt(p.z) + ") with radius " + fmt(r) +
             " reaches beyond " + fmt(SkeletonLimits::max_coordinate) +
             " m from the origin, the limit for coordinates (move the tree near the origin)");
    }
    if (far + r > reach) {
      reach = far + r;
      farthest = i;
    }
    lo = glm::min(lo, p - dvec3(r));
    hi = glm::max(hi, p + dvec3(r));
    if (r < std::max(raw.radius[thinnest], floor)) thinnest = i;
  }
  const double r_min = std::max(raw.radius[thinnest], floor);
  if (reach > SkeletonLimits::max_offset_ratio * r_min) {
    const dvec3& p = raw.position[farthest];
    reject(at(raw, farthest) + ": position (" + fmt(p.x) + ", " + fmt(p.y) + ", " + fmt(p.z) + ") is more than " +
           fmt(SkeletonLimits::max_offset_ratio) + " times the thinnest radius (" + fmt(r_min) + " m at " +
           raw.place(thinnest) + ") from the origin (move the tree near the origin)");
  }
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  if (extent > SkeletonLimits::max_extent_ratio * r_min) {
    reject(at(raw, thinnest) + ": radius " + fmt(r_min) + " m is too thin for a tree " + fmt(extent) +
           " m across: the extent may be at most " + fmt(SkeletonLimits::max_extent_ratio) +
           " times the thinnest radius (raise the radius floor, --radius-floor)");
  }
}

double auto_radius_floor(const WorkTree& t) {
  double max_r = 0, min_pos = std::numeric_limits<double>::infinity();
  for (double r : t.radius) {
    max_r = std::max(max_r, r);
    if (r > 0) min_pos = std::min(min_pos, r);
  }
  if (max_r <= 0) {
    // No radius at all: 1% of the bounding box diagonal, or 1 cm for a single point.
    dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const auto& p : t.pos) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    const double diag = glm::length(hi - lo);
    return diag > 0 ? 0.01 * diag : 0.01;
  }
  return std::max(min_pos, 0.002 * max_r);
}

void raise_radii(WorkTree& t, double floor, SkeletonReport& rep, const RawSkeleton& raw) {
  for (std::size_t i = 0; i < t.radius.size(); ++i) {
    if (t.radius[i] < floor) {
      t.radius[i] = floor;
      ++rep.raised_radii;
      rep.warnings.add("raised_radius", "radius below the floor " + fmt(floor) + " m raised to it", raw.place(i));
    }
  }
}

/// Merges zero-length and too-short edges into the parent, top-down.
void merge_short_edges(WorkTree& t, const SkeletonParams& params, SkeletonReport& rep, const RawSkeleton& raw) {
  // "Zero length" is relative to the tree's size (plus a few ulps of the coordinates), not to
  // the distance from the origin: at 1e12 m, real 0.9 m edges were merged as zero-length.
  dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < t.pos.size(); ++i) {
    if (t.removed[i]) continue;
    lo = glm::min(lo, t.pos[i]);
    hi = glm::max(hi, t.pos[i]);
  }
  const double far = std::max({std::abs(lo.x), std::abs(lo.y), std::abs(lo.z), std::abs(hi.x), std::abs(hi.y), std::abs(hi.z)});
  const double zero_tol = 1e-12 * glm::length(hi - lo) + 1e-15 * far;
  std::vector<std::uint32_t> queue{t.root};
  std::vector<std::vector<std::uint32_t>> kept(t.pos.size());
  for (std::size_t k = 0; k < queue.size(); ++k) {
    const std::uint32_t v = queue[k];
    // Children of v, including those inherited from merged children (appended as we go).
    auto& ch = t.children[v];
    for (std::size_t j = 0; j < ch.size(); ++j) {
      const std::uint32_t c = ch[j];
      const double len = glm::length(t.pos[c] - t.pos[v]);
      // A skeleton this stage wrote keeps its short edges: they are the binarized chains' (with
      // the input kept, a chain can be no longer than the distance to its main child).
      const double ratio = raw.sanitized ? 0.0 : params.merge_edge_ratio;
      const double tol = std::max(ratio * std::max(t.radius[c], t.radius[v]), zero_tol);
      if (len <= tol) {
        t.removed[c] = true;
        ++rep.merged_edges;
        rep.warnings.add("merged_edge",
                         len <= zero_tol ? "zero-length edge merged into its parent"
                                              : "edge shorter than merge_edge_ratio x radius merged into its parent",
                         c < raw.size()   ? raw.place(c)
                         : v < raw.size() ? "inserted node merged into " + raw.place(v)
                                          : std::string("inserted node"));
        for (std::uint32_t g : t.children[c]) {
          t.parent[g] = v;
          ch.push_back(g);  // examined later in this same loop against v
        }
        t.children[c].clear();
      } else {
        kept[v].push_back(c);
        queue.push_back(c);
      }
    }
  }
  for (std::size_t v = 0; v < t.children.size(); ++v) {
    if (!t.removed[v]) t.children[v] = std::move(kept[v]);
  }
}

void fix_thick_children(WorkTree& t, const SkeletonParams& params, SkeletonReport& rep, const RawSkeleton& raw) {
  if (params.thick_child_policy == ThickChildPolicy::keep) return;
  const double ratio = std::max(params.max_child_ratio, 1e-6);
  const auto order = t.bfs();
  auto note = [&](std::uint32_t c) {
    ++rep.clamped_children;
    rep.warnings.add("thick_child",
                     params.thick_child_policy == ThickChildPolicy::clamp_child
                         ? "child thicker than max_child_ratio x its parent clamped down"
                         : "parent thinner than its child raised",
                     c < raw.size() ? raw.place(c) : std::string("inserted node"));
  };
  if (params.thick_child_policy == ThickChildPolicy::clamp_child) {
    for (std::uint32_t c : order) {
      if (t.parent[c] == kNone) continue;
      // (Never below the radius floor, raised to before: a small max_child_ratio compounds
      // down the tree, 0.1 gave twigs of 1e-17 m, and zero-length collar edges.)
      const double limit = std::max(ratio * t.radius[t.parent[c]], rep.radius_floor);
      if (t.radius[c] > limit * (1 + 1e-12)) {
        t.radius[c] = limit;
        note(c);
      }
    }
  } else {
    for (auto it = order.rbegin(); it != order.rend(); ++it) {
      const std::uint32_t c = *it;
      if (t.parent[c] == kNone) continue;
      double& rp = t.radius[t.parent[c]];
      if (t.radius[c] > ratio * rp * (1 + 1e-12)) {
        rp = t.radius[c] / ratio;
        note(c);
      }
    }
  }
}

void resample_long_edges(WorkTree& t, const SkeletonParams& params, SkeletonReport& rep) {
  if (params.max_edge_ratio <= 0) return;
  const auto order = t.bfs();
  for (std::uint32_t c : order) {
    const std::uint32_t p = t.parent[c];
    if (p == kNone) continue;
    const double len = glm::length(t.pos[c] - t.pos[p]);
    const double r0 = t.base[c] > 0 ? t.base[c] : t.radius[p];  // the edge's radius at p
    const double max_len = params.max_edge_ratio * 0.5 * (t.radius[c] + r0);
    if (len <= max_len) continue;
    const auto pieces = static_cast<std::size_t>(std::min(std::ceil(len / max_len), 1e4));
    ++rep.resampled_edges;
    rep.warnings.add("resampled_edge", "edge longer than max_edge_ratio x radius split into equal parts");
    std::uint32_t prev = p;
    auto& pc = t.children[p];
    const auto slot = std::find(pc.begin(), pc.end(), c) - pc.begin();
    for (std::size_t k = 1; k < pieces; ++k) {
      const double a = double(k) / double(pieces);
      const std::uint32_t m = t.add(glm::mix(t.pos[p], t.pos[c], a), glm::mix(r0, t.radius[c], a), prev, -1);
      if (prev == p) {
        t.children[p][static_cast<std::size_t>(slot)] = m;
        std::swap(t.base[m], t.base[c]);  // the first piece starts where the edge did
      } else {
        t.children[prev].push_back(m);
      }
      prev = m;
      ++rep.inserted_nodes;
    }
    t.children[prev].push_back(c);
    t.parent[c] = prev;
  }
}

/// What each node's branch carries, for choosing the main child at a fork: the larger of the
/// sum of its tips' radius² (the pipe model's share of the strands, which start at the tips)
/// and its own radius² (bottom-up over a BFS order). The tips alone misjudge a pruned stub:
/// sapling_small_pine's input node 491, a bare stub of r 17 mm, outweighed its sibling 41
/// (r 22 mm, the branch's continuation, whose 24 nodes end in twigs), so the binarized whorl
/// chain ran along the stub and the continuation left it as a lateral, folding the crotch
/// (8 pairs at each particle seed). The own radius alone misjudges a QSM's thick short
/// lateral (rtwig's node 711, r 28 mm, over the 17 mm continuation 510 carrying twice its
/// tips: 4 and 2 pairs at seeds 1 and 2). With the larger of the two, the samples x particle
/// seeds 1-3 went from 24 pairs to 0.
std::vector<double> branch_loads(const WorkTree& t, const std::vector<std::uint32_t>& order) {
  std::vector<double> tips(t.pos.size(), 0.0), load(t.pos.size(), 0.0);
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    const std::uint32_t v = *it;
    const double own = t.radius[v] * t.radius[v];
    if (t.children[v].empty()) {
      tips[v] = own;
    } else {
      for (auto c : t.children[v]) tips[v] += tips[c];
    }
    load[v] = std::max(tips[v], own);
  }
  return load;
}

/// Hubs with more than max_chain_forks children (see SkeletonParams::max_chain_forks): the
/// laterals (every child but the heaviest) are sorted by azimuth around the hub's main
/// direction and cut into at most max_chain_forks runs of equal size; each run of more than
/// one lateral hangs from a new cluster node a short step from the hub towards the run's mean
/// direction, its radius that of one branch carrying the run (sqrt of the sum of r^2, at most
/// the hub's). A cluster with too many laterals is clustered again in turn. Returns, per node
/// of the tree before clustering, 1 for the hubs it clustered.
std::vector<std::uint8_t> cluster_fan_outs(WorkTree& t, const SkeletonParams& params, SkeletonReport& rep,
                                           const RawSkeleton& raw) {
  std::vector<std::uint8_t> hub(t.pos.size(), 0);
  const std::size_t limit = params.max_chain_forks;
  if (limit < 2) return hub;
  std::vector<std::uint32_t> queue = t.bfs();
  const std::vector<double> w = branch_loads(t, queue);
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const std::uint32_t v = queue[q];
    if (t.children[v].size() <= limit + 1) continue;
    const std::vector<std::uint32_t> ch = t.children[v];  // copy: t.add() below may reallocate
    if (v < hub.size()) hub[v] = 1;
    ++rep.clustered_nodes;
    rep.warnings.add("clustered_children",
                     "node with more than " + std::to_string(limit + 1) +
                         " children: its laterals are grouped by direction under cluster nodes",
                     v < raw.size() ? raw.place(v) : std::string("inserted node"));
    // The main child stays; cluster nodes (added below, never in w) count as their runs.
    auto weight = [&](std::uint32_t c) { return c < w.size() ? w[c] : 0.0; };
    const auto main_it = std::min_element(ch.begin(), ch.end(), [&](std::uint32_t a, std::uint32_t b) {
      return weight(a) != weight(b) ? weight(a) > weight(b) : a < b;
    });
    const std::uint32_t main = *main_it;
    std::vector<std::uint32_t> laterals;
    for (const std::uint32_t c : ch)
      if (c != main) laterals.push_back(c);
    const dvec3 origin = t.pos[v];
    const dvec3 axis = normalize_or(t.pos[main] - origin, dvec3(0, 0, 1));
    const dvec3 e1 = any_perpendicular(axis), e2 = glm::cross(axis, e1);
    std::vector<std::pair<double, std::uint32_t>> by_angle;
    by_angle.reserve(laterals.size());
    for (const std::uint32_t c : laterals) {
      const dvec3 d = t.pos[c] - origin;
      by_angle.emplace_back(std::atan2(glm::dot(d, e2), glm::dot(d, e1)), c);
    }
    std::sort(by_angle.begin(), by_angle.end());
    const std::size_t n = by_angle.size(), groups = limit;
    std::vector<std::uint32_t> kept{main};
    for (std::size_t g = 0; g < groups; ++g) {
      const std::size_t b = g * n / groups, e = (g + 1) * n / groups;
      if (e - b == 1) kept.push_back(by_angle[b].second);
      if (e - b <= 1) continue;
      dvec3 dir(0);
      double r2 = 0, shortest = std::numeric_limits<double>::infinity();
      for (std::size_t k = b; k < e; ++k) {
        const std::uint32_t c = by_angle[k].second;
        const dvec3 d = t.pos[c] - origin;
        const double l = glm::length(d);
        if (l > 0) dir += d / l;
        shortest = std::min(shortest, l);
        r2 += t.radius[c] * t.radius[c];
      }
      dir = normalize_or(dir, axis);
      // On the hub's surface or halfway to the nearest lateral node, whichever is nearer, but
      // beyond the merge tolerance.
      const double step =
          std::max(std::min(t.radius[v], 0.5 * shortest), 2.0 * params.merge_edge_ratio * t.radius[v]);
      const std::uint32_t cl = t.add(origin + dir * step, std::min(t.radius[v], std::sqrt(r2)), v, -1);
      ++rep.inserted_nodes;
      for (std::size_t k = b; k < e; ++k) {
        const std::uint32_t c = by_angle[k].second;
        t.parent[c] = cl;
        t.children[cl].push_back(c);
      }
      kept.push_back(cl);
      queue.push_back(cl);  // clustered again if it has too many laterals
    }
    t.children[v] = std::move(kept);
  }
  return hub;
}

/// Orders every node's children main first (largest branch_loads, ties by lower index; kept as
/// they are in a skeleton this stage wrote) and replaces nodes with more than two children by
/// chains of extra nodes. `hub` marks the nodes cluster_fan_outs clustered (per node before
/// clustering).
void binarize(WorkTree& t, const SkeletonParams& params, SkeletonReport& rep, const RawSkeleton& raw,
              const std::vector<std::uint8_t>& hub) {
  auto order = t.bfs();
  const std::vector<double> w = branch_loads(t, order);
  auto heavier = [&](std::uint32_t a, std::uint32_t b) { return w[a] != w[b] ? w[a] > w[b] : a < b; };
  for (std::uint32_t v : order) {
    auto& ch = t.children[v];
    // A skeleton this stage wrote has its forks in order already (main child first), and its
    // collars (wider than the laterals they start) would change the loads.
    if (!raw.sanitized) std::sort(ch.begin(), ch.end(), heavier);
    if (ch.size() <= 2) continue;
    ++rep.binarized_nodes;
    rep.warnings.add("binarized", "node with more than two children replaced by a chain of binary forks",
                     v < raw.size() ? raw.place(v) : std::string("inserted node"));
    const std::vector<std::uint32_t> sorted = ch;  // [main, lateral1 (thickest), lateral2, ...]
    const std::uint32_t main = sorted[0];
    const std::size_t k = sorted.size();
    const dvec3 origin = t.pos[v];
    const double dist = glm::length(t.pos[main] - origin);
    const dvec3 dir = (t.pos[main] - origin) / dist;  // dist > 0 after merging
    // k - 2 extra nodes, each at least one merge tolerance apart so re-importing the
    // sanitized skeleton does not merge them again.
    const double min_step = 2.0 * params.merge_edge_ratio * t.radius[v];
    // Whorls (input nodes not clustered) get room for their laterals to part; hubs and the
    // cluster nodes grouping their children (added by the clustering, so not input nodes)
    // stay compact, their forks a merge tolerance apart. (`hub` covers every input node: the
    // tree only grows.)
    const bool whorl = v < raw.size() && !hub[v];
    // Without `separate` the chain stays short of the main child, which is not moved: where it
    // is near, the forks crowd closer than the merge tolerance.
    double step = std::max({whorl ? params.binarize_step_ratio * t.radius[v] : 0.0, min_step, 1e-9});
    if (!params.separate) step = std::min(step, dist / double(k - 1));
    ch = {sorted[1]};
    std::uint32_t prev = v;
    for (std::size_t j = 1; j + 1 < k; ++j) {
      const std::uint32_t e = t.add(origin + dir * (step * double(j)), t.radius[v], prev, -1);
      t.children[prev].insert(t.children[prev].begin(), e);  // chain node is the main child
      if (j + 1 < k - 1) t.children[e].push_back(sorted[j + 1]);
      t.parent[sorted[j + 1]] = e;
      prev = e;
      ++rep.inserted_nodes;
    }
    // The last chain node carries the main child and the last lateral.
    t.children[prev] = {main, sorted[k - 1]};
    t.parent[main] = prev;
    t.parent[sorted[k - 1]] = prev;
    if (params.separate && dist <= step * double(k - 2) + min_step) {
      // The main child sits inside the chain: move it just beyond the last chain node.
      const dvec3 delta = origin + dir * (step * double(k - 2) + 1.5 * std::max(min_step, step)) - t.pos[main];
      t.pos[main] += delta;
      rep.warnings.add("binarize_moved_child", "main child moved slightly outward to make room for binarized forks",
                       main < raw.size() ? raw.place(main) : std::string("inserted node"));
    }
  }
}

/// Branches running inside a sibling: some skeletons (Sapling output among them) start a
/// branch on the parent's axis and run it up inside the parent's next long edge for several
/// nodes before it turns away; its sub-branches then leave from inside the parent. Such a
/// node X (a child of v lying inside the round cone of v's edge to its sibling Y, with Y's edge
/// the longer) is merged into that edge: a node M is inserted on v->Y at X's projection, and
/// X's children move to M. Repeated from M, so whole inner chains fold into the parent.
/// Within the fork's own sphere (1.5 r(v) from v) children overlap anyway and the contour stage
/// separates them; there only a child running along Y (within kInnerNearForkDegrees) or lying a
/// hair from v (under half its own radius: a whorl hub whose laterals leave from a chain of
/// nodes millimetres apart on the axis) is folded. (sapling_small_pine, particle seeds 1/2/3:
/// self-intersecting pairs 900/798/694 -> 214/174/205; the other samples within their noise.)
bool merge_inner_branches(WorkTree& t, double max_move, SkeletonReport& rep, const RawSkeleton& raw) {
  const std::size_t before = rep.merged_inner;
  const double cos_along = std::cos(kInnerNearForkDegrees * std::numbers::pi / 180.0);
  std::vector<std::uint32_t> queue = t.bfs();
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const std::uint32_t v = queue[q];
    bool changed = true;
    while (changed) {
      changed = false;
      // Copy: t.add() below may reallocate t.children.
      const std::vector<std::uint32_t> ch = t.children[v];
      for (std::size_t xi = 0; !changed && xi < ch.size(); ++xi) {
        for (std::size_t yi = 0; !changed && yi < ch.size(); ++yi) {
          if (xi == yi) continue;
          const std::uint32_t x = ch[xi], y = ch[yi];
          const dvec3 ay = t.pos[y] - t.pos[v], ax = t.pos[x] - t.pos[v];
          if (glm::dot(ay, ay) <= glm::dot(ax, ax)) continue;  // y's edge must be the longer
          const auto e = t.project(x, v, y);
          if (e.t >= 0.98 || e.t <= 0.0) continue;
          if (e.offset >= max_move * e.radius) continue;
          if (t.radius[x] > e.radius) continue;  // thicker than the edge it would run inside
          if (e.t * e.length <= 1.5 * t.radius[v]) {
            // Within the fork's sphere: only a hub along y or a hair from v (see above).
            const bool along = glm::dot(normalize_or(ax, dvec3(0)), normalize_or(ay, dvec3(0))) > cos_along;
            if (!along && !(glm::length(ax) < 0.5 * t.radius[x])) continue;
          }
          const std::uint32_t m = t.insert_above(y, e.foot, e.radius);
          t.fold_into(x, m);
          ++rep.merged_inner;
          rep.warnings.add("inner_branch", "branch running inside its sibling's edge merged into it",
                           x < raw.size() ? raw.place(x) : std::string("inserted node"));
          queue.push_back(m);
          changed = true;
        }
      }
    }
  }
  return rep.merged_inner > before;
}

/// The same for a branch that runs back down inside its parent's own edge (Sapling starts
/// whorl hubs that way: a child of v lying inside the round cone of parent(v) -> v, well
/// below v): a node M is inserted on that edge at the child's projection and takes the
/// child's children. Repeated until nothing changes.
bool fold_backward_branches(WorkTree& t, double max_move, SkeletonReport& rep, const RawSkeleton& raw) {
  const std::size_t before = rep.merged_inner;
  std::vector<std::uint32_t> queue = t.bfs();
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const std::uint32_t v = queue[q];
    if (t.removed[v] || t.parent[v] == kNone) continue;
    bool changed = true;
    while (changed) {
      changed = false;
      const std::uint32_t p = t.parent[v];
      if (!(glm::length(t.pos[v] - t.pos[p]) > 0)) break;
      const std::vector<std::uint32_t> ch = t.children[v];  // copy: t.add() may reallocate
      for (const std::uint32_t x : ch) {
        const auto e = t.project(x, p, v);
        if (e.t <= 0.02 || e.t >= 0.98 || (1.0 - e.t) * e.length <= 1.5 * t.radius[v]) continue;
        if (e.offset >= max_move * e.radius) continue;
        if (t.radius[x] > e.radius) continue;  // thicker than the edge it would run inside
        const std::uint32_t m = t.insert_above(v, e.foot, e.radius);
        t.fold_into(x, m);
        ++rep.merged_inner;
        rep.warnings.add("inner_branch_back", "branch running back inside its parent's edge merged into it",
                         x < raw.size() ? raw.place(x) : std::string("inserted node"));
        queue.push_back(m);
        changed = true;
        break;
      }
    }
  }
  return rep.merged_inner > before;
}

/// Hairpins: a child that leaves its node turned back by more than max_turn_back (120
/// degrees) from the branch arriving there (digitised regrowth below a pruned top, branches
/// doubling back). No tube of the branch's radius turns like that, and the strands sweep it
/// into a fold. The child is re-attached where it comes back to on the node's incoming edge
/// (a new node there), or to the node's parent when it reaches back past it, so it leaves
/// sideways and the node above becomes a stub. (Walking further down the branch was tried:
/// it crowds the child into forks below and folds them; boutdenoylum2 593 -> 1191 pairs.)
bool reattach_hairpins(WorkTree& t, const SkeletonParams& params, SkeletonReport& rep, const RawSkeleton& raw) {
  const double max_angle = params.max_turn_back * std::numbers::pi / 180.0;
  if (!(max_angle > 0) || max_angle >= std::numbers::pi) return false;
  const double cos_max = std::cos(max_angle);
  const std::size_t before = rep.hairpins;
  std::vector<std::uint32_t> queue = t.bfs();
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const std::uint32_t v = queue[q];
    if (t.removed[v] || t.parent[v] == kNone) continue;
    // One child at a time: a re-attachment splits v's incoming edge.
    for (bool changed = true; changed;) {
      changed = false;
      dvec3 u = t.pos[v] - t.pos[t.arrival_ancestor(v)];  // the branch's direction arriving at v
      const double ul = glm::length(u);
      if (!(ul > 0)) break;
      u /= ul;
      const std::uint32_t p = t.parent[v];
      const double el = glm::length(t.pos[v] - t.pos[p]);
      const double tol = 2.0 * params.merge_edge_ratio * t.radius[v];  // no edge merge_short_edges would undo
      const std::vector<std::uint32_t> ch = t.children[v];             // copy: t.add() may reallocate
      for (const std::uint32_t x : ch) {
        const dvec3 w = t.pos[x] - t.pos[v];
        const double wl = glm::length(w);
        if (!(wl > 0) || glm::dot(w, u) >= cos_max * wl) continue;  // turns by less than max_turn_back
        const double back = -glm::dot(w, u);                        // how far x reaches back along the branch
        if (back <= tol) continue;                                  // too little to move
        std::uint32_t target = p;
        if (back < el - tol) {
          const double f = back / el;
          target = t.insert_above(v, glm::mix(t.pos[v], t.pos[p], f), glm::mix(t.radius[v], t.radius[p], f));
        }
        auto& kids = t.children[v];
        kids.erase(std::find(kids.begin(), kids.end(), x));
        t.children[target].push_back(x);
        t.parent[x] = target;
        ++rep.hairpins;
        rep.warnings.add("hairpin", "branch turning back by more than max_turn_back re-attached where it comes back to",
                         x < raw.size() ? raw.place(x) : std::string("inserted node"));
        queue.push_back(target);  // x may still turn back from there
        changed = true;
        break;
      }
    }
  }
  return rep.hairpins > before;
}

/// Hidden tips: a tip whose whole sphere lies inside one of its parent's other round cones
/// (the parent's incoming edge or the edge to a sibling) adds nothing to the surface, but its
/// particles must still leave the parent sideways within a fraction of a radius, which folds
/// the surface around it (a pruned stump digitised as a short knob inside the trunk). Such a
/// tip is removed (warning "hidden_tip"). Only tips beside a sibling: the end of a branch stays,
/// however short.
bool drop_hidden_tips(WorkTree& t, SkeletonReport& rep, const RawSkeleton& raw) {
  const std::size_t before = rep.hidden_tips;
  std::vector<std::uint32_t> queue = t.bfs();
  for (std::size_t q = queue.size(); q-- > 0;) {  // leaves first
    const std::uint32_t x = queue[q];
    if (t.removed[x] || !t.children[x].empty() || t.parent[x] == kNone) continue;
    const std::uint32_t v = t.parent[x];
    if (t.children[v].size() < 2) continue;  // the end of a branch, not a knob beside it
    auto inside = [&](std::uint32_t a, std::uint32_t b) {
      if (!(glm::length(t.pos[b] - t.pos[a]) > 0)) return false;
      const auto e = t.project(x, a, b);
      return e.t >= 0.0 && e.t <= 1.0 && e.offset + t.radius[x] <= e.radius;
    };
    bool hidden = t.parent[v] != kNone && inside(t.parent[v], v);
    for (const std::uint32_t y : t.children[v]) {
      if (!hidden && y != x) hidden = inside(v, y);
    }
    if (!hidden) continue;
    auto& siblings = t.children[v];
    siblings.erase(std::find(siblings.begin(), siblings.end(), x));
    t.removed[x] = true;
    ++rep.hidden_tips;
    rep.warnings.add("hidden_tip", "tip lying wholly inside its parent's branch removed",
                     x < raw.size() ? raw.place(x) : std::string("inserted node"));
  }
  return rep.hidden_tips > before;
}

/// Tight bends (SkeletonParams::tight_bend_ratio): a node with one child where the branch turns
/// so sharply, for its radius, that the slices of its two edges would cross on the inner side
/// is removed, its child taking its place. Repeated until no node qualifies: a removal changes
/// the turns at the neighbours. Without `merge_follows` (after binarize, where merging would
/// undo the binary forks), a node whose child comes back to within merge_edge_ratio x radius of
/// the parent stays: its removal would leave an edge of (near) zero length.
bool smooth_tight_bends(WorkTree& t, const SkeletonParams& params, SkeletonReport& rep, const RawSkeleton& raw,
                        bool merge_follows) {
  if (!(params.tight_bend_ratio > 0)) return false;
  const std::size_t before = rep.tight_bends;
  for (bool changed = true; changed;) {
    changed = false;
    for (const std::uint32_t v : t.bfs()) {
      if (t.removed[v] || t.parent[v] == kNone || t.children[v].size() != 1) continue;
      const std::uint32_t p = t.parent[v], c = t.children[v][0];
      const dvec3 a = t.pos[v] - t.pos[p], b = t.pos[c] - t.pos[v];
      const double la = glm::length(a), lb = glm::length(b);
      if (!(la > 0 && lb > 0)) continue;
      const double cos_turn = std::clamp(glm::dot(a, b) / (la * lb), -1.0, 1.0);
      // r tan(turn / 2) > ratio x shorter edge, with tan(turn / 2) = sqrt((1 - cos) / (1 + cos)).
      const double limit = params.tight_bend_ratio * std::min(la, lb);
      if (t.radius[v] * t.radius[v] * (1 - cos_turn) <= limit * limit * (1 + cos_turn)) continue;
      // Input as given (not `separate`): only where the straightened branch passes within
      // max_node_move x radius of the node, a move the user cannot see.
      if (!params.separate) {
        const double u = segment_param(t.pos[v], t.pos[p], t.pos[c]);
        if (glm::length(t.pos[p] + u * (t.pos[c] - t.pos[p]) - t.pos[v]) > params.max_node_move * t.radius[v]) continue;
      }
      if (!merge_follows &&
          !(glm::length(t.pos[c] - t.pos[p]) > params.merge_edge_ratio * std::max(t.radius[c], t.radius[p]))) {
        continue;
      }
      *std::find(t.children[p].begin(), t.children[p].end(), v) = c;
      t.parent[c] = p;
      t.children[v].clear();
      t.removed[v] = true;
      ++rep.tight_bends;
      rep.warnings.add("tight_bend",
                       "node where the branch turns too sharply for its radius removed (tight_bend_ratio)",
                       v < raw.size() ? raw.place(v) : std::string("inserted node"));
      changed = true;
    }
  }
  return rep.tight_bends > before;
}

/// Lateral collars: a lateral edge from a fork of radius r to a much thinner child is, as a
/// round cone, a wide funnel flaring from the fork (whorls of such funnels become umbrellas).
/// A node inserted about where the lateral leaves the parent's surface (at collar_ratio x r
/// from the fork, a little inside) with about the child's radius (a quarter of the way to the fork's) keeps the
/// flare inside the parent and the lateral thin. Short stubs get one too, as long as they
/// reach collar_min_stub of their own radii beyond it.
void add_collars(WorkTree& t, const SkeletonParams& params, SkeletonReport& rep) {
  if (params.collar_ratio <= 0) return;
  const auto order = t.bfs();
  for (std::uint32_t v : order) {
    if (t.children[v].size() != 2) continue;
    const std::uint32_t c = t.children[v][1];  // children are sorted main first by binarize()
    const double rv = t.radius[v], rc = t.radius[c];
    const double len = glm::length(t.pos[c] - t.pos[v]);
    const double at = params.collar_ratio * rv;
    // (A collar at the child itself would leave a zero-length edge: collar_min_stub 0.)
    if (rc >= params.collar_max_child_ratio * rv || len < at + params.collar_min_stub * rc || len - at <= 1e-6 * len)
      continue;
    const dvec3 dir = (t.pos[c] - t.pos[v]) / len;
    t.insert_above(c, t.pos[v] + dir * at, rc + 0.25 * (rv - rc));
    ++rep.collars;  // a refinement, not a repair: counted, not warned about
  }
}

/// Steep laterals: a lateral leaving its fork at more than max_lateral_angle from the parent's
/// direction gets a base node where it has cleared the parent (its first stretch, rotated
/// towards the parent's direction in the plane of the two, leaves at max_lateral_angle); from
/// there the branch bends to its own direction, like the upturned base of a real branch.
void raise_steep_laterals(WorkTree& t, const SkeletonParams& params, SkeletonReport& rep) {
  const double max_angle = params.max_lateral_angle * std::numbers::pi / 180.0;
  if (!(max_angle > 0) || max_angle >= std::numbers::pi) return;
  const auto order = t.bfs();
  for (std::uint32_t v : order) {
    if (t.children[v].size() != 2) continue;
    const std::uint32_t main = t.children[v][0], c = t.children[v][1];  // main first (binarize)
    // The parent's direction: from the nearest ancestor at least a radius away (the extra
    // nodes of a binarized node lie a tiny step apart, in no meaningful direction); at the
    // root, towards the main child.
    const std::uint32_t a = t.arrival_ancestor(v);
    const dvec3 from = a != kNone ? t.pos[v] - t.pos[a] : t.pos[main] - t.pos[v];
    const dvec3 up = normalize_or(from, dvec3(0));
    const dvec3 edge = t.pos[c] - t.pos[v];
    const double len = glm::length(edge);
    if (up == dvec3(0) || !(len > 0)) continue;
    const dvec3 dir = edge / len;
    const double cos_angle = std::clamp(glm::dot(dir, up), -1.0, 1.0);
    if (cos_angle >= std::cos(max_angle + 1e-3)) continue;  // (1e-3 rad: laterals at the limit stay)
    // The side the lateral leaves towards (perpendicular to up); straight back down: any
    // side, taken from the main child's offset or a fixed axis so it is deterministic.
    dvec3 side = dir - up * cos_angle;
    if (glm::length(side) < 1e-6) side = t.pos[main] - t.pos[v] - up * glm::dot(t.pos[main] - t.pos[v], up);
    if (glm::length(side) < 1e-6)
      side = std::abs(up.x) < 0.9 ? glm::cross(up, dvec3(1, 0, 0)) : glm::cross(up, dvec3(0, 1, 0));
    side = glm::normalize(side);
    const dvec3 base_dir = up * std::cos(max_angle) + side * std::sin(max_angle);
    // Far enough along base_dir to clear the parent (radius rv) with the lateral's own radius.
    const double rv = t.radius[v], rc = t.radius[c];
    // (At most 70% of the way along a short edge, even if the base node then lies somewhat
    // inside the parent. Left as they are: an edge too short to reach half that far, and a
    // short stub ending in a tip, which bent would be all bend.)
    const double clear = 1.25 * (rv + rc) / std::sin(max_angle);
    const double reach = std::min(clear, 0.7 * len);
    if (reach < 0.5 * clear || (t.children[c].empty() && len < 1.5 * clear)) continue;
    // With the lateral's own radius: a thicker base would add strands there (and thin the
    // particles of the whole tree when the root's strand count is capped).
    const std::uint32_t m = t.insert_above(c, t.pos[v] + base_dir * reach, rc);
    // The bend, halved by a second node where there is room: one stretch along the mean of
    // the base direction and the way on to c.
    const dvec3 rest = t.pos[c] - t.pos[m];
    const double rest_len = glm::length(rest);
    const double step = std::max(reach, 2.0 * rc);
    if (rest_len > 2.0 * step) {
      const dvec3 mid_dir = normalize_or(base_dir + rest / rest_len, rest / rest_len);
      t.insert_above(c, t.pos[m] + mid_dir * step, rc);
    }
    ++rep.raised_laterals;  // a refinement, not a repair: counted, not warned about
  }
}

}  // namespace

namespace {

/// How far sanitizing moved the input's nodes (those kept, by source id) and how many it
/// dropped; warns of any move beyond max_node_move (made by the opt-in `separate`).
void measure_moves(const RawSkeleton& raw, const std::unordered_map<std::int64_t, std::uint32_t>& index_of,
                   const Skeleton& s, SkeletonReport& rep) {
  std::vector<std::uint8_t> kept(raw.size(), 0);
  std::vector<double> radii;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.source_id[i] < 0) continue;
    const auto it = index_of.find(s.source_id[i]);
    if (it == index_of.end() || kept[it->second]) continue;
    kept[it->second] = 1;
    const double d = glm::length(s.position[i] - raw.position[it->second]);
    const double r = std::max(raw.radius[it->second], rep.radius_floor);
    rep.max_move = std::max(rep.max_move, d);
    radii.push_back(d / r);
  }
  std::sort(radii.begin(), radii.end());
  if (!radii.empty()) {
    rep.max_move_radii = radii.back();
    rep.p95_move_radii = radii[std::min(radii.size() - 1, static_cast<std::size_t>(0.95 * double(radii.size())))];
  }
  rep.dropped_nodes = raw.size() - static_cast<std::size_t>(std::count(kept.begin(), kept.end(), 1));
}

}  // namespace

Skeleton input_skeleton(const RawSkeleton& raw, const SkeletonParams& params) {
  std::unordered_map<std::int64_t, std::uint32_t> index_of;
  const std::uint32_t root = validate(raw, params, index_of);
  const WorkTree t = make_tree(raw, root, index_of);
  const double floor = params.radius_floor > 0 ? params.radius_floor : auto_radius_floor(t);
  check_magnitudes(raw, floor);  // `check --skeleton` measures against it: the same limits as meshing
  Skeleton s;
  s.up_axis = raw.up_axis;
  const std::size_t n = raw.size();
  s.position = raw.position;
  s.radius.resize(n);
  s.parent.resize(n);
  s.children.resize(n);
  s.frame.resize(n);
  s.source_id = raw.id;
  if (raw.base_radius.size() == n) s.base_radius = raw.base_radius;  // (a sanitized export's)
  for (std::size_t i = 0; i < n; ++i) {
    s.radius[i] = std::max(raw.radius[i], floor);
    if (t.parent[i] != kNone) s.parent[i] = NodeId(t.parent[i]);
  }
  return s;
}

void validate_params(const SkeletonParams& p) { check_params(p); }

SkeletonResult build_skeleton(const RawSkeleton& raw, const SkeletonParams& params) {
  validate_params(params);
  Stopwatch clock;
  SkeletonResult result;
  SkeletonReport& rep = result.report;
  rep.input_nodes = raw.size();

  std::unordered_map<std::int64_t, std::uint32_t> index_of;
  const std::uint32_t root = validate(raw, params, index_of);
  WorkTree t = make_tree(raw, root, index_of);
  rep.timings.add("validate", clock.lap());

  rep.radius_floor = params.radius_floor > 0 ? params.radius_floor : auto_radius_floor(t);
  check_magnitudes(raw, rep.radius_floor);
  raise_radii(t, rep.radius_floor, rep, raw);
  merge_short_edges(t, params, rep, raw);
  fix_thick_children(t, params, rep, raw);
  // A skeleton this stage wrote already has its geometric refinements (RawSkeleton::sanitized).
  const bool refine = !raw.sanitized;
  if (refine) {
    // Edits that keep every input node within max_node_move of its place, then the shape edits
    // that are opt-in (SkeletonParams::separate).
    bool folded = false;
    if (params.merge_inner_branches) {
      // (With `separate`, nodes up to half the edge's radius off its axis fold in, as before.)
      const double max_offset = params.separate ? 0.5 : params.max_node_move;
      folded = fold_backward_branches(t, max_offset, rep, raw);
      folded = merge_inner_branches(t, max_offset, rep, raw) || folded;
    }
    if (params.separate) folded = reattach_hairpins(t, params, rep, raw) || folded;
    folded = drop_hidden_tips(t, rep, raw) || folded;
    folded = smooth_tight_bends(t, params, rep, raw, /*merge_follows=*/true) || folded;
    if (folded) merge_short_edges(t, params, rep, raw);  // folded nodes can land next to existing ones
  }
  resample_long_edges(t, params, rep);
  const std::vector<std::uint8_t> hubs = cluster_fan_outs(t, params, rep, raw);
  binarize(t, params, rep, raw, hubs);
  if (refine) {
    raise_steep_laterals(t, params, rep);
    // Again once the upturned lateral bases are in: on a short twig one can itself be a tight
    // bend. Before the collars, which go on the final edges (so sanitizing the result again
    // adds none).
    smooth_tight_bends(t, params, rep, raw, /*merge_follows=*/false);
  }
  add_collars(t, params, rep);
  rep.timings.add("repair", clock.lap());

  // Renumber depth-first from the root, main child first, so main chains are contiguous and
  // parent[i] < i. Explicit stack: no recursion over depth.
  Skeleton& s = result.skeleton;
  s.up_axis = raw.up_axis;
  std::vector<std::pair<std::uint32_t, NodeId>> stack{{t.root, NodeId{}}};
  while (!stack.empty()) {
    auto [v, par] = stack.back();
    stack.pop_back();
    const NodeId id = s.add_node(par, t.pos[v], t.radius[v], t.source[v]);
    if (par.valid()) s.base_radius[id.idx()] = t.base[v];
    const auto& ch = t.children[v];
    for (auto it = ch.rbegin(); it != ch.rend(); ++it) stack.emplace_back(*it, id);
  }
  // add_node fills child slots in visiting order, which is main first (pushed last above).
  if (refine && params.separate) {
    SeparateParams sp;
    sp.clearance = params.branch_clearance;
    const SeparateReport sep = separate_branches(s, sp);
    rep.branch_collisions = sep.collisions;
    rep.unresolved_collisions = sep.unresolved;
    rep.max_separation = sep.max_displacement;
    if (sep.collisions > 0 && sep.rotations > 0) {
      rep.warnings.add_count("separated_branches",
                             "branches intersecting away from their common fork swung apart (largest move " +
                                 fmt(sep.max_displacement) + " m)",
                             sep.collisions);
    }
    if (sep.dense) {
      rep.warnings.add("dense_branches",
                       "edges crowding each other by the hundred (a hub of very many children): branch separation "
                       "skipped; the mesh will self-intersect there");
    }
    if (sep.unresolved > 0) {
      rep.warnings.add_count("unresolved_collisions",
                             "branch pairs still intersecting after separation; the mesh will self-intersect there",
                             sep.unresolved);
    }
  }
  measure_moves(raw, index_of, s, rep);
  compute_frames(s);
  rep.output_nodes = s.size();
  validate_binary_skeleton(s);
  rep.timings.add("frames", clock.lap());
  return result;
}

void validate_binary_skeleton(const Skeleton& s) {
  const std::size_t n = s.size();
  SM_CHECK(s.radius.size() == n && s.parent.size() == n && s.children.size() == n && s.frame.size() == n &&
               s.source_id.size() == n,
           "skeleton arrays have different lengths");
  SM_CHECK(s.base_radius.empty() || s.base_radius.size() == n, "skeleton base radii must be none or one per node");
  for (const double b : s.base_radius) SM_CHECK(std::isfinite(b) && b >= 0, "base radius must be finite and >= 0");
  if (n == 0) return;
  SM_CHECK(!s.parent[0].valid(), "node 0 must be the root");
  for (std::size_t i = 0; i < n; ++i) {
    const NodeId id(i);
    SM_CHECK(std::isfinite(s.radius[i]) && s.radius[i] > 0, "radius must be finite and > 0");
    const dvec3& p = s.position[i];
    SM_CHECK(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z), "position must be finite");
    if (i > 0) {
      SM_CHECK(s.parent[i].valid() && s.parent[i].idx() < i, "parent must precede its child");
      const auto& pc = s.children[s.parent[i].idx()];
      SM_CHECK(pc[0] == id || pc[1] == id, "parent must list the node as a child");
      SM_CHECK(s.edge_length(id) > 0, "edges must have positive length");
    }
    const auto& c = s.children[i];
    SM_CHECK(c[0].valid() || !c[1].valid(), "a lateral child requires a main child");
    for (const NodeId k : c) {
      if (k.valid()) SM_CHECK(k.idx() < n && s.parent[k.idx()] == id, "child must point back to its parent");
    }
    const Frame& f = s.frame[i];
    SM_CHECK(std::abs(glm::length(f.tangent) - 1) < 1e-9 && std::abs(glm::length(f.normal) - 1) < 1e-9 &&
                 std::abs(glm::dot(f.tangent, f.normal)) < 1e-9 && std::abs(glm::dot(f.tangent, f.binormal)) < 1e-9,
             "frames must be orthonormal");
  }
}

}  // namespace sm
