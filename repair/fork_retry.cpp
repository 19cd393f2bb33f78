// Step 2 of the repair stage: the fork retry (see fork_retry.h).

#include "repair/fork_retry.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdio>
#include <limits>
#include <mutex>
#include <numeric>
#include <optional>
#include <vector>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "core/mesh.h"
#include "meshcheck/checks.h"
#include "repair/repair.h"

namespace sm {
namespace {

// A fork on the tree path between the nodes of a crossing's triangles takes part in it when
// the crossing lies within this many of its radii (a crotch's pairs lie on the surface, about
// a radius from the fork's node; a whorl's forks are a tiny step apart and all take part).
// 6 rather than 4: the same 44 pairs over the samples x particle seeds 1-3, thick nodes inside
// 7,509 -> 7,511 (a stub tip of boutdenoylum2 at seeds 1 and 3).
constexpr double kReach = 6.0;

// A variant may not lengthen the longest triangle edge near a group's forks (in units of the
// nearest fork's radius, webs()) by more than this factor. A slicing that untangles a crotch
// can do it by spanning it with a web of large flat triangles, which no check counts
// (fidelity is measured at vertices): agraf's sanitized fork 395 at particle seeds 2, 3 and 4,
// 3.8 -> 6.1-6.4 radii (a web the size of the crotch, plain in the viewer), and forks 399 /
// 931 at seed 6, 2.3 -> 5.4 and 3.1-3.3 -> 6.9-8.0. With this guard those crotches keep
// their shape; samples x particle seeds 1-3 still have no pairs (agraf seeds 2 and 3 found
// other variants), seeds 4-6 6 -> 14 pairs (agraf seed 6, whose pairs the webs had hidden).
// 1.25 also refused what small_pine seed 3 needed (0 -> 4 pairs).
constexpr double kWebGrowth = 1.5;

// The variants tried, as factors on the configured values, written as the values they give
// at the defaults (split gap 1.5, fork transition 1.5, slice step 0.4): split gaps 1.0-4.5,
// transitions 0.5-3.0, slice steps 0.3 and 0.35, in the order tried. (Each of the
// first five applied to the whole tree, samples x particle seeds 1-3: 133 / 174 / 145 / 153 /
// 142 pairs against the defaults' 135. Retried with these five, 82 pairs left; with these
// eleven, 44, and thick nodes inside 7,501 -> 7,509 of 7,524: the far ones matter, split gap
// 3.0 and 4.5 and transition 0.5 made 11 of the 43 improvements. Split gap 6.0, transitions 0.25
// and 4.5 and slice steps 0.25 and 0.5 won none.) Since the main child is chosen by load and
// webs are refused, split gaps 1.0 and 3.0 won no group over the samples x particle seeds 1-6
// (24 meshes; the other nine won 2-15 groups each), so they are no longer tried: the same 24
// meshes byte for byte, the retry two runs shorter (those samples 5-25 % faster in all).
constexpr std::array<LocalContourScale, 9> kVariants{{
    {.split_gap = 1.25 / 1.5},
    {.split_gap = 2.0 / 1.5},
    {.fork_transition = 1.0 / 1.5},
    {.fork_transition = 2.0 / 1.5},
    {.slice_step = 0.35 / 0.4},
    {.fork_transition = 3.0 / 1.5},
    {.slice_step = 0.3 / 0.4},
    {.fork_transition = 0.5 / 1.5},
    {.split_gap = 4.5 / 1.5},
}};

struct Run {
  std::vector<LocalContourScale> scale;  // per group: the factors its forks were sliced with
  ForkRetryState state;
  std::vector<std::size_t> outside;  // per group: watched nodes outside the mesh
  std::vector<double> web;           // per group: longest edge near its forks (webs())
};

// The forks a crossing depends on: where the edges of its triangles' corners start (the fork
// below each), and the forks on the tree paths between those edges that lie within kReach
// radii of it. Ascending.
std::vector<NodeId> forks_of(const Skeleton& s, const Crossing& c) {
  std::vector<NodeId> nodes;
  for (const NodeId n : c.nodes) {
    if (n.valid() && n.idx() < s.size()) nodes.push_back(n);
  }
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  std::vector<NodeId> out;
  if (nodes.empty()) return out;
  // The lowest common ancestor: the first of nodes[0]'s ancestors (itself included) that
  // every other node has among its ancestors.
  auto ancestors = [&](NodeId n) {
    std::vector<NodeId> up;
    for (; n.valid(); n = s.parent[n.idx()]) up.push_back(n);
    std::sort(up.begin(), up.end());
    return up;
  };
  std::vector<std::vector<NodeId>> up;
  for (const NodeId n : nodes) up.push_back(ancestors(n));
  NodeId lca;
  for (NodeId n = nodes[0]; n.valid() && !lca.valid(); n = s.parent[n.idx()]) {
    if (std::all_of(up.begin(), up.end(), [&](const auto& u) { return std::binary_search(u.begin(), u.end(), n); }))
      lca = n;
  }
  auto near = [&](NodeId f) { return glm::length(c.at - s.position[f.idx()]) <= kReach * s.radius[f.idx()]; };
  for (const NodeId n : nodes) {
    const NodeId p = s.parent[n.idx()];
    if (p.valid() && s.is_fork(p)) out.push_back(p);
    for (NodeId x = n; x.valid(); x = s.parent[x.idx()]) {
      if (s.is_fork(x) && near(x)) out.push_back(x);
      if (x == lca) break;
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

// The forks a thick node outside the mesh depends on: the forks among the node and its
// ancestors (up to kAncestors edges down) that lie within kReach of their radii of it. A
// stub's tip swallowed by a crotch, a node left outside by a fused section.
std::vector<NodeId> forks_of(const Skeleton& s, NodeId n) {
  constexpr int kAncestors = 32;
  std::vector<NodeId> out;
  int steps = 0;
  for (NodeId x = n; x.valid() && steps < kAncestors; x = s.parent[x.idx()], ++steps) {
    if (s.is_fork(x) && glm::length(s.position[n.idx()] - s.position[x.idx()]) <= kReach * s.radius[x.idx()])
      out.push_back(x);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The groups of forks around the crossings and the thick nodes outside: the forks of one
// crossing or node share a group (union-find), numbered in order of their first fork.
struct Groups {
  std::vector<NodeId> forks;          // ascending
  std::vector<std::uint32_t> group;   // per fork
  std::size_t count = 0;

  Groups(const Skeleton& s, const std::vector<Crossing>& crossings, const std::vector<NodeId>& outside) {
    std::vector<std::vector<NodeId>> of;
    for (const Crossing& c : crossings) of.push_back(forks_of(s, c));
    for (const NodeId n : outside) of.push_back(forks_of(s, n));
    for (const auto& list : of) forks.insert(forks.end(), list.begin(), list.end());
    std::sort(forks.begin(), forks.end());
    forks.erase(std::unique(forks.begin(), forks.end()), forks.end());
    std::vector<std::uint32_t> up(forks.size());
    std::iota(up.begin(), up.end(), 0u);
    auto find = [&](std::uint32_t x) {
      while (up[x] != x) x = up[x] = up[up[x]];
      return x;
    };
    for (const auto& list : of) {
      for (std::size_t k = 1; k < list.size(); ++k) {
        const std::uint32_t a = find(index(list[0])), b = find(index(list[k]));
        up[std::max(a, b)] = std::min(a, b);
      }
    }
    group.assign(forks.size(), 0);
    std::vector<std::uint32_t> id(forks.size(), UINT32_MAX);
    for (std::size_t f = 0; f < forks.size(); ++f) {
      const std::uint32_t r = find(static_cast<std::uint32_t>(f));
      if (id[r] == UINT32_MAX) id[r] = static_cast<std::uint32_t>(count++);
      group[f] = id[r];
    }
  }

  [[nodiscard]] std::uint32_t index(NodeId n) const {
    return static_cast<std::uint32_t>(std::lower_bound(forks.begin(), forks.end(), n) - forks.begin());
  }
  [[nodiscard]] bool has(NodeId n) const { return std::binary_search(forks.begin(), forks.end(), n); }

  // The fork (index into `forks`) nearest to p in units of each fork's radius, within kReach of
  // it (the last of equally near ones); UINT32_MAX if none is.
  [[nodiscard]] std::uint32_t nearest_within_reach(const Skeleton& s, const glm::dvec3& p) const {
    double best = kReach;
    std::uint32_t at = UINT32_MAX;
    for (std::size_t f = 0; f < forks.size(); ++f) {
      const std::size_t k = forks[f].idx();
      const double d = glm::length(p - s.position[k]) / s.radius[k];
      if (d <= best) {
        best = d;
        at = static_cast<std::uint32_t>(f);
      }
    }
    return at;
  }

  // Pairs per group: a crossing goes to the group of its first fork that has one, else to
  // the group of the fork nearest to it in units of the fork's radius (so every crossing
  // counts somewhere, and one a variant did not touch counts the same for all variants).
  [[nodiscard]] std::vector<std::size_t> tally(const Skeleton& s, const std::vector<Crossing>& crossings) const {
    std::vector<std::size_t> out(count, 0);
    if (forks.empty()) return out;
    for (const Crossing& c : crossings) {
      std::uint32_t at = UINT32_MAX;
      for (const NodeId f : forks_of(s, c)) {
        if (has(f)) {
          at = index(f);
          break;
        }
      }
      if (at == UINT32_MAX) {
        double best = std::numeric_limits<double>::infinity();
        for (std::size_t f = 0; f < forks.size(); ++f) {
          const double d = glm::length(c.at - s.position[forks[f].idx()]) / s.radius[forks[f].idx()];
          if (d < best) {
            best = d;
            at = static_cast<std::uint32_t>(f);
          }
        }
      }
      ++out[group[at]];
    }
    return out;
  }
};

// The thick nodes near the groups (radius at least the median, the nodes `strandmesh check`
// asks to be inside), each with the group of the fork nearest to it within kReach of that
// fork's radius: another slicing of a crotch must not leave one of them outside.
struct Watched {
  std::vector<NodeId> node;
  std::vector<std::uint32_t> group;

  Watched(const Skeleton& s, const Groups& groups) {
    if (groups.forks.empty()) return;
    for (const std::uint32_t i : thick_node_ids(s)) {
      const std::uint32_t f = groups.nearest_within_reach(s, s.position[i]);
      if (f == UINT32_MAX) continue;
      node.push_back(NodeId(i));
      group.push_back(groups.group[f]);
    }
  }

  // Per group: the watched nodes outside the closed mesh (winding number below 1/2: counted
  // ray crossings, the same for any thread count).
  [[nodiscard]] std::vector<std::size_t> outside(const Skeleton& s, const Mesh& mesh, std::size_t groups) const {
    if (node.empty()) return std::vector<std::size_t>(groups, 0);
    std::vector<glm::dvec3> at;
    at.reserve(node.size());
    for (const NodeId n : node) at.push_back(s.position[n.idx()]);
    const std::vector<std::uint8_t> inside = inside_closed_mesh(mesh, at);
    std::vector<std::size_t> count(groups, 0);
    for (std::size_t k = 0; k < node.size(); ++k) count[group[k]] += inside[k] ? 0 : 1;
    return count;
  }
};

// Per group: the longest triangle edge near its forks, in units of the nearest fork's radius
// (the triangles whose centroid lies within kReach radii of a group fork, each with the fork
// nearest in radii).
std::vector<double> webs(const Skeleton& s, const Mesh& mesh, const Groups& groups) {
  std::vector<double> out(groups.count, 0.0);
  // Triangles outside every fork's reach are skipped before the search over the forks.
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const NodeId f : groups.forks) {
    lo = glm::min(lo, s.position[f.idx()] - glm::dvec3(kReach * s.radius[f.idx()]));
    hi = glm::max(hi, s.position[f.idx()] + glm::dvec3(kReach * s.radius[f.idx()]));
  }
  for (const auto& t : mesh.triangles) {
    const glm::dvec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    const glm::dvec3 m = (a + b + c) / 3.0;
    if (glm::any(glm::lessThan(m, lo)) || glm::any(glm::greaterThan(m, hi))) continue;
    const std::uint32_t at = groups.nearest_within_reach(s, m);
    if (at == UINT32_MAX) continue;
    const double e = std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)});
    double& w = out[groups.group[at]];
    w = std::max(w, e / s.radius[groups.forks[at].idx()]);
  }
  return out;
}

}  // namespace

ForkRetryStats retry_forks(ForkRetryState& first, const RepairInputs& in, const RepairParams& params,
                           const ProgressFn& progress) {
  ForkRetryStats stats;
  MeshResult& mesh = first.mesh;
  Crossings& crossings = first.crossings;
  stats.counted = crossings.counted;
  stats.counted_everywhere = crossings.counted && crossings.everywhere;
  stats.pairs_before = stats.pairs_after = crossings.pairs.size();
  // (A mesh with edges not shared by two triangles is a bug, reported as one; the retry
  // counts nodes inside by ray crossings, which needs a closed mesh.)
  if (!params.fork_retry || !crossings.counted || mesh.stats.bad_edges > 0) return stats;
  if (!crossings.everywhere && crossings.pairs.empty()) return stats;  // (see the header)
  const Skeleton& s = in.skeleton;
  // The thick nodes outside the first mesh (as `strandmesh check` finds them: winding number
  // below 1/2; counted by ray crossings in one pass over the triangles, 1-4 ms on the samples
  // where the check took 24-190 ms, with the same nodes).
  std::vector<NodeId> outside_nodes;
  {
    const std::vector<std::uint32_t> thick = thick_node_ids(s);
    std::vector<glm::dvec3> at;
    at.reserve(thick.size());
    for (const std::uint32_t n : thick) at.push_back(s.position[n]);
    const std::vector<std::uint8_t> inside = inside_closed_mesh(mesh.mesh, at);
    for (std::size_t k = 0; k < thick.size(); ++k) {
      if (!inside[k]) outside_nodes.push_back(NodeId(thick[k]));
    }
  }
  const Groups groups(s, crossings.pairs, outside_nodes);
  stats.groups = groups.count;
  if (groups.count == 0) return stats;
  const Watched watched(s, groups);
  const std::vector<std::size_t> outside_before = watched.outside(s, mesh.mesh, groups.count);
  const std::vector<double> web_before = webs(s, mesh.mesh, groups);
  auto sum = [](const std::vector<std::size_t>& v) { return std::accumulate(v.begin(), v.end(), std::size_t{0}); };
  const std::size_t outside_total = sum(outside_before);
  stats.outside_before = stats.outside_after = outside_total;

  // Each group's forks (and the edges above them, for the slice step) at `scale[group]`.
  auto local_for = [&](const std::vector<LocalContourScale>& scale) {
    std::vector<LocalContourScale> local(s.size());
    for (std::size_t f = 0; f < groups.forks.size(); ++f) {
      const NodeId n = groups.forks[f];
      const LocalContourScale& v = scale[groups.group[f]];
      local[n.idx()] = v;
      for (const NodeId c : s.children[n.idx()]) {
        if (c.valid()) local[c.idx()].slice_step = v.slice_step;
      }
    }
    return local;
  };
  // One run of the contour and meshing stages and of the fold repair near the forks.
  auto run = [&](const std::vector<LocalContourScale>& scale) {
    const std::vector<LocalContourScale> local = local_for(scale);
    Run out;
    out.scale = scale;
    out.state.contours = compute_contours(s, in.particles, in.strands, in.contour_params, local);
    StitchedMesh stitched = stitch_mesh(s, out.state.contours, in.mesh_params);
    out.state.folds =
        repair_junction_folds(stitched, s, out.state.contours, params, out.state.crossings, out.state.warnings);
    out.state.mesh = finish_mesh(std::move(stitched), in.mesh_params);
    // A trial mesh that is not closed (a bug) counts every node as outside: never kept.
    out.outside = out.state.mesh.stats.bad_edges > 0 ? std::vector<std::size_t>(groups.count, s.size())
                                                     : watched.outside(s, out.state.mesh.mesh, groups.count);
    out.web = webs(s, out.state.mesh.mesh, groups);
    return out;
  };

  // Every group tries every variant at once (their pairs and nodes are counted apart). A
  // variant may not leave more pairs or more thick nodes outside at a group than the first run
  // did, and is better with fewer nodes outside, then fewer pairs. The trials are taken in the
  // order of kVariants up to the first after which no pairs or nodes are left, so the outcome
  // is the same for any thread count.
  using Score = std::pair<std::size_t, std::size_t>;  // (thick nodes outside, pairs)
  const std::vector<std::size_t> pairs_before = groups.tally(s, crossings.pairs);
  std::vector<Score> best(groups.count);
  for (std::size_t g = 0; g < groups.count; ++g) best[g] = {outside_before[g], pairs_before[g]};
  std::vector<LocalContourScale> best_scale(groups.count);
  Score best_total{outside_total, crossings.pairs.size()};
  const Score first_total = best_total;
  auto admissible = [](const Score& x, const Score& limit) { return x.first <= limit.first && x.second <= limit.second; };
  std::optional<Run> best_run;  // the best run, if better than the first
  auto take = [&](Run& out) {
    ++stats.runs;
    if (!out.state.crossings.counted) return;
    const std::vector<std::size_t> count = groups.tally(s, out.state.crossings.pairs);
    auto webbed = [&](std::size_t g) { return out.web[g] > kWebGrowth * web_before[g]; };
    bool any_web = false;
    for (std::size_t g = 0; g < groups.count; ++g) {
      const Score here{out.outside[g], count[g]};
      const bool better = admissible(here, {outside_before[g], pairs_before[g]}) && here < best[g];
      any_web = any_web || webbed(g);
      if (better && webbed(g)) ++stats.webs_refused;
      if (better && !webbed(g)) {
        best[g] = here;
        best_scale[g] = out.scale[g];
      }
    }
    const Score total{sum(out.outside), out.state.crossings.pairs.size()};
    if (admissible(total, first_total) && !any_web && total < best_total) {
      best_total = total;
      best_run = std::move(out);
    }
  };
  // The trials are handed out in order to one worker per thread as each becomes free (their
  // lengths differ severalfold: in batches of two, one thread waited for the other), and taken
  // as soon as all before them are in; once the trials taken leave nothing, no more start.
  {
    const std::size_t n = kVariants.size();
    const std::size_t workers = std::min<std::size_t>(n, std::max(1, tbb::this_task_arena::max_concurrency()));
    std::vector<std::optional<Run>> finished(n);
    std::size_t taken = 0;
    std::atomic<std::size_t> next{0}, stop{n};
    std::mutex mutex;
    tbb::parallel_for(std::size_t{0}, workers, [&](std::size_t) {
      for (std::size_t k = next++; k < stop.load(); k = next++) {
        // Isolated: while a trial waits for its own parallel loops, its thread takes no other
        // trial onto its stack.
        Run out = tbb::this_task_arena::isolate(
            [&] { return run(std::vector<LocalContourScale>(groups.count, kVariants[k])); });
        const std::lock_guard lock(mutex);
        finished[k] = std::move(out);
        for (; taken < stop.load() && finished[taken]; ++taken) {
          take(*finished[taken]);
          finished[taken].reset();
          if (best_total == Score{}) stop = taken + 1;
        }
        if (progress) progress("fork retry", double(taken) / double(n + 1));
      }
    }, tbb::simple_partitioner());
  }
  // Each group with its best variant, unless that is one of the runs made already (all the
  // same variant).
  const bool mixed = std::any_of(best_scale.begin(), best_scale.end(),
                                 [&](const LocalContourScale& v) { return !(v == best_scale.front()); });
  if (mixed && best_total != Score{}) {
    if (progress) progress("fork retry", double(kVariants.size()) / double(kVariants.size() + 1));
    Run out = run(best_scale);
    take(out);
  }
  if (best_run) first = std::move(best_run->state);
  stats.pairs_after = first.crossings.pairs.size();
  stats.outside_after = best_total.first;
  if (progress) progress("fork retry", 1.0);
  return stats;
}

std::string to_text(const ForkRetryStats& fr) {
  char line[320];
  std::snprintf(
      line, sizeof line,
      "%zu -> %zu self-intersecting pairs, %zu -> %zu thick nodes outside; %zu group(s) of forks sliced "
      "again in %zu runs of contours and meshing; %zu better result(s) refused for spanning a crotch with a web",
      fr.pairs_before, fr.pairs_after, fr.outside_before, fr.outside_after, fr.groups, fr.runs, fr.webs_refused);
  return line;
}

void warn_self_intersections_left(const Crossings& crossings, const Skeleton& s, Warnings& warnings) {
  std::vector<NodeId> named;
  for (const Crossing& c : crossings.pairs) {
    const std::vector<NodeId> forks = forks_of(s, c);
    const bool fresh = !forks.empty() && std::find(named.begin(), named.end(), forks.front()) == named.end();
    if (fresh) named.push_back(forks.front());
    warnings.add("self_intersections_left",
                 "self-intersecting triangle pairs left near a crotch after the fold repair, the fork retry and the "
                 "outer surface",
                 fresh ? s.describe(forks.front()) : std::string{});
  }
}

}  // namespace sm
