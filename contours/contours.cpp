// Contours: slicing, split detection and boundary loops (Interactive Invigoration, Li et al.).
//
// The walk is top-down over "tubes". A tube carries the strands of one subtree (rooted at
// node X, hanging below an anchor node: the fork whose split started the tube, or nothing for
// the root tube) and slices it at increasing distance d above the anchor. A slice at distance
// d "cuts" the subtree: every edge that spans distance d above the anchor contributes its
// strands evaluated at the matching t, so bundles are followed across nodes (this is what lets
// us handle bundles that do not separate before the next node, and chains of binarized forks
// a tiny step apart).
//
// Along a chain of single-child nodes the cut is one edge. Past the first fork F of the tube
// the cut holds the two child bundles; while they are closer than split_gap x s the slice is
// one fused loop around both; the first distance where they are farther apart (bisection
// between the last loop and the first separated slice) is the split, where the tube ends in a
// Junction and two child tubes start (anchored at F). Forks deeper in a child's subtree that
// were passed while fused are handled by the child tube, which tests them first. A bundle
// whose strands all end (tips) before separating is absorbed into its sibling's tube (counted
// warning), unless its tip is a stub (thick, or outside the sibling's cones: it then splits
// below its tip; ContourParams::split_outside_tips); bundles still touching where the shorter child edge ends are split there if they
// are at least loosely apart and clear of each other's cones (counted warning), otherwise
// they stay fused.
//
// Tubes are walked in parallel (oneTBB tasks: a junction spawns its two child tubes). Each
// walk reads only the inputs and per-node tables computed once (Tables) and writes its own
// Fragment; the fragments are then concatenated in a fixed depth-first order (main child
// first), so the ContourSet is identical for any number of threads.

#include "contours/contours.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>
#include <optional>
#include <span>

#include <tbb/concurrent_vector.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include "core/errors.h"

namespace sm {
namespace {

// Tips at least this fraction of their fork's radius thick are stubs: when their bundle has
// not separated by the last slice below the tip, it splits there (see Walker). Thinner tips
// are absorbed, unless they lie outside the other child's round cones (only thick ones, at
// least the median radius, with split_outside_tips off): absorbed, the twig would be missing
// from the mesh. Every tip a stub gave more self-intersecting pairs on the samples (293
// against 277 at particle seeds 1-3).
constexpr double kStubRadius = 0.3;

// Turn (radians) beyond which a node of a child's chain ends the fused section above its fork
// (see Walker::walk).
constexpr double kFusedMaxTurn = 2.0943951023931957;  // 120 degrees

// The height of an equilateral triangle on a unit edge: slices this far apart (x the ring's
// edge) make isotropic triangles.
constexpr double kIsotropic = 0.8660254037844386;

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

/// How deep inside its cloud (in the cloud's own particle spacings below its angular sector's
/// farthest point) a particle may still be sliced as a boundary candidate (see outer_points).
/// Large grown tree: 12.5 M -> 8.9 M strand evaluations, the contours stage 25 % faster; the
/// same loops (bit for bit) on the samples at particle seeds 1-3 and on the grown presets,
/// down to a band of 2 (boutdenoylum2 changes there).
constexpr double kOuterBand = 4.0;

/// One cut edge: the strands of node `node` evaluated at `t` on its edge.
struct CutEdge {
  NodeId node;
  double t;
};

/// The strand points of a slice and where they come from.
/// How far the straight chord from `from` to `to` passes from p (0 for a chord of no length):
/// how much a strip between loops at those points cuts the corner at p.
double chord_miss(const dvec3& p, const dvec3& from, const dvec3& to) {
  const double chord = glm::length(to - from);
  return chord > 0 ? glm::length(glm::cross(p - from, to - from)) / chord : 0.0;
}

struct SlicePoints {
  std::vector<dvec3> point;
  std::vector<StrandId> strand;
  std::vector<double> offset;  // how far the surface lies outside the strand (metres)
  void clear() {
    point.clear();
    strand.clear();
    offset.clear();
  }
  /// Just the point p, on the surface (a probe for cone_clearance).
  void assign_point(const dvec3& p) {
    clear();
    point.push_back(p);
    offset.push_back(0.0);
  }
  void append(const SlicePoints& o) { append(o, 0, o.point.size()); }
  /// Appends points [begin, end) of o.
  void append(const SlicePoints& o, std::size_t begin, std::size_t end) {
    point.insert(point.end(), o.point.begin() + std::ptrdiff_t(begin), o.point.begin() + std::ptrdiff_t(end));
    strand.insert(strand.end(), o.strand.begin() + std::ptrdiff_t(begin), o.strand.begin() + std::ptrdiff_t(end));
    offset.insert(offset.end(), o.offset.begin() + std::ptrdiff_t(begin), o.offset.begin() + std::ptrdiff_t(end));
  }
};

struct SliceGeometry {
  dvec3 center;
  Frame frame;
  double radius = 0;
  NodeId node;  // edge the geometry is taken from
  double t = 1;
};

/// Indices of the points that can lie on the boundary of `pts`: those within 40% of the
/// farthest point of their angular sector around the centroid and at most kOuterBand particle
/// spacings inside it (all of them for small sets). A particle deep inside its cloud at both
/// ends of an edge stays inside every section of the edge (the sections interpolate the two
/// clouds linearly), so only these are sliced.
struct OuterScratch {
  std::vector<double> smax, dist;
  std::vector<std::size_t> sec;
};
void outer_points(const dvec2* pts, std::uint32_t n, std::vector<std::uint32_t>& out, OuterScratch& scratch) {
  out.clear();
  if (n <= 32) {
    for (std::uint32_t i = 0; i < n; ++i) out.push_back(i);
    return;
  }
  dvec2 c(0);
  for (std::uint32_t i = 0; i < n; ++i) c += pts[i];
  c /= double(n);
  const std::size_t sectors = std::clamp<std::size_t>(n / 8, 16, 256);
  auto sector = [&](std::uint32_t i) {
    // A pseudo-angle in [0, 4) (monotone in the angle, no trigonometry).
    const dvec2 d = pts[i] - c;
    const double sum = std::abs(d.x) + std::abs(d.y);
    const double r = sum > 0 ? d.y / sum : 0.0;
    const double a = d.x >= 0 ? (d.y >= 0 ? r : 4 + r) : 2 - r;
    return std::min(sectors - 1, static_cast<std::size_t>(a * 0.25 * double(sectors)));
  };
  std::vector<double>& smax = scratch.smax;
  std::vector<double>& dist = scratch.dist;
  std::vector<std::size_t>& sec = scratch.sec;
  smax.assign(sectors, 0.0);
  dist.resize(n);
  sec.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    sec[i] = sector(i);
    dist[i] = glm::length(pts[i] - c);
    smax[sec[i]] = std::max(smax[sec[i]], dist[i]);
  }
  // The cloud's own particle spacing (trunk clouds hold every strand of the tree, far denser
  // than the tips' spacing): its disc's area shared among its particles.
  const double extent = *std::max_element(smax.begin(), smax.end());
  const double band = kOuterBand * extent * std::sqrt(std::numbers::pi / double(n));
  for (std::uint32_t i = 0; i < n; ++i) {
    if (dist[i] >= std::max(0.6 * smax[sec[i]], smax[sec[i]] - band)) out.push_back(i);
  }
}

/// What a tube's walk starts from.
struct Task {
  NodeId anchor;     // the fork whose split starts the tube; invalid for the root tube
  NodeId x;          // subtree root carried by the tube
  double split = 0;  // distance above the anchor of the tube's first loop (the split section)
  /// The tube resumes the fused section of fork `anchor` (both its bundles; `x` is the fork's
  /// main child, whose branch the tube belongs to) from distance `split` above it, after a
  /// lateral inside it split off (see nested_split).
  bool fused = false;
  /// Laterals that already have their own tube: their subtrees are left out of every cut, and
  /// their fork is walked as a plain node.
  std::vector<NodeId> excluded;
};

/// The output of one tube's walk: its loops, the loops [loop_first, loop_end) of the
/// walking thread's store (their vertices from vertex_first on; `part.tubes[0]` is the tube,
/// its loops numbered as in the store), its figures in `part.stats` and, if it ends in a
/// junction, the junction and the tasks of its two child tubes.
struct Fragment {
  ContourSet part;
  const ContourSet* store = nullptr;
  std::uint32_t loop_first = 0, loop_end = 0, vertex_first = 0;
  bool has_junction = false;
  Junction junction;           // lower loop in the store's numbering; upper loops set on assembly
  std::array<Task, 2> next{};  // main child, lateral
  std::array<Fragment*, 2> child{};
};

/// Read-only per-node tables every walk uses, computed once.
struct Tables {
  Tables(const Skeleton& s, const ParticleField& f, const StrandSet& st, const ContourParams& p,
         std::span<const LocalContourScale> local);

  const Skeleton& s;
  const ParticleField& f;
  const StrandSet& st;
  const ContourParams& p;
  std::span<const LocalContourScale> local;     // #N factors, or empty (compute_contours)
  double spacing;                               // distance between neighbouring particles (metres)
  double median_radius;                         // the skeleton's median radius: thick nodes reach it
  std::vector<double> root_distance;            // #N distance from the root along the tree (for UV distances)
  std::vector<std::uint32_t> branch;            // #N first node of each node's branch
  std::vector<double> node_offset;              // #N surface offset of each node's cloud (metres)
  std::vector<std::uint32_t> cand_begin, cand;  // boundary candidates per edge (see below)
  std::vector<std::uint32_t> dfs_in, dfs_out;   // #N subtree of x = nodes y with in[x] <= in[y] < out[x]

  [[nodiscard]] bool in_subtree(NodeId y, NodeId x) const {
    return dfs_in[x.idx()] <= dfs_in[y.idx()] && dfs_in[y.idx()] < dfs_out[x.idx()];
  }
};

Tables::Tables(const Skeleton& s_, const ParticleField& f_, const StrandSet& st_, const ContourParams& p_,
               std::span<const LocalContourScale> local_)
    : s(s_),
      f(f_),
      st(st_),
      p(p_),
      local(local_),
      spacing(f_.neighbour_distance > 0 ? f_.neighbour_distance : (f_.spacing > 0 ? 1.9 * f_.spacing : 1e-3)),
      median_radius(s_.median_radius()) {
  const std::size_t n = s.size();
  root_distance.assign(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) root_distance[i] = root_distance[s.parent[i].idx()] + s.edge_length(NodeId(i));
  branch = s.branch_ids();
  dfs_in.assign(n, 0);
  dfs_out.assign(n, 0);
  if (n > 0) {
    std::vector<std::pair<std::uint32_t, bool>> stack{{0u, false}};
    std::uint32_t clock = 0;
    while (!stack.empty()) {
      const auto [v, leaving] = stack.back();
      stack.pop_back();
      if (leaving) {
        dfs_out[v] = clock;
        continue;
      }
      dfs_in[v] = clock++;
      stack.emplace_back(v, true);
      for (const NodeId c : s.children[v]) {
        if (c.valid()) stack.emplace_back(c.value, false);
      }
    }
  }

  // Per node n: the local particle indices of n that may be on the boundary of a section of
  // n's edge: outer in n's own cloud, or outer in n's bundle inside its parent's cloud. And
  // how far the wood surface lies outside the cloud's boundary strands: the skeleton radius
  // minus the mean distance of the convex-hull particles from the node centre (relaxed
  // clouds keep their outer ring somewhat inside the disc), at most half the radius.
  node_offset.assign(n, 0.0);
  std::vector<std::vector<std::uint32_t>> per_node(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 64), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<std::uint32_t> a, b;
    std::vector<std::uint8_t> mark;
    std::vector<dvec2> pts;
    OuterScratch scratch;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const NodeId node(i);
      const std::uint32_t count = f.count(node);
      const dvec2* own = f.position.data() + f.node_begin[i];
      outer_points(own, count, a, scratch);
      pts.clear();
      for (auto j : a) pts.push_back(own[j]);
      const auto hull = boundary_loop(pts, 0.0, nullptr, 0.0);
      if (hull.size() >= 3) {
        double mean = 0;
        for (auto k : hull) mean += glm::length(pts[k]);
        mean /= double(hull.size());
        node_offset[i] = std::clamp(s.radius[i] - mean, 0.0, 0.5 * s.radius[i]);
      }
      mark.assign(count, 0);
      for (auto j : a) mark[j] = 1;
      const NodeId parent = s.parent[i];
      if (parent.valid()) {
        outer_points(f.position.data() + f.node_begin[parent.idx()] + parent_index(s, f, node, 0), count, b, scratch);
        for (auto j : b) mark[j] = 1;
      }
      for (std::uint32_t j = 0; j < count; ++j) {
        if (mark[j]) per_node[i].push_back(j);
      }
    }
  });
  cand_begin.assign(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i)
    cand_begin[i + 1] = cand_begin[i] + static_cast<std::uint32_t>(per_node[i].size());
  cand.resize(cand_begin[n]);
  for (std::size_t i = 0; i < n; ++i) std::copy(per_node[i].begin(), per_node[i].end(), cand.begin() + cand_begin[i]);
}

/// A slice plane tilted against its edge's axis (frames turn smoothly through a bend, edges
/// do not) cuts the edge's round cone in an ellipse, not a circle: an offset in the plane is
/// stretched within the plane until its distance from the axis is its length (at most twice).
/// The factor for an offset of squared length l2 whose component along the axis is s.
double unslant_factor(double l2, double s) {
  const double perp2 = l2 - s * s;
  return perp2 > 0.25 * l2 ? std::sqrt(l2 / perp2) : 2.0;
}
dvec3 unslant(const dvec3& w, const dvec3& axis) {
  return w * unslant_factor(glm::dot(w, w), glm::dot(w, axis));
}

/// Walks one tube (see the top of this file) into a Fragment. One per task: it holds scratch
/// buffers only.
class Walker {
 public:
  explicit Walker(const Tables& t) : s_(t.s), f_(t.f), st_(t.st), p_(t.p), spacing_(t.spacing), tables_(t) {}

  /// Appends the tube's loops to `store` (the thread's: a walk runs on one thread from start
  /// to end, without another walk in between).
  void walk(const Task& task, Fragment& out, ContourSet& store);

 private:
  // --- geometry helpers -------------------------------------------------------------------
  [[nodiscard]] double len(NodeId n) const { return s_.edge_length(n); }
  // The parameters with their local factors (compute_contours' `local`) at node n.
  [[nodiscard]] const LocalContourScale& local(NodeId n) const {
    static const LocalContourScale kOne{};
    return n.idx() < tables_.local.size() ? tables_.local[n.idx()] : kOne;
  }
  [[nodiscard]] double split_gap(NodeId fork) const { return p_.split_gap * local(fork).split_gap; }
  [[nodiscard]] double fork_transition(NodeId fork) const {
    return p_.fork_transition * local(fork).fork_transition;
  }
  [[nodiscard]] double slice_step(NodeId n) const { return p_.slice_step * local(n).slice_step; }
  /// How far along child n's edge its bundle takes its own round section (metres; n's parent
  /// a fork): fork_transition x the fork's radius, but for a child that starts thinner than
  /// the fork (Skeleton::base_radius: a lateral leaving from inside the trunk) no farther than
  /// where its axis leaves the fork's radius, so it is round where it comes out of the parent.
  [[nodiscard]] double transition_length(NodeId n) const {
    const NodeId fork = s_.parent[n.idx()];
    const double rf = s_.radius[fork.idx()];
    const double ramp = fork_transition(fork) * rf;
    if (!(s_.start_radius(n) < rf)) return ramp;
    const dvec3 d = normalize_or(s_.position[n.idx()] - s_.position[fork.idx()], dvec3(0));
    const double sine = glm::length(glm::cross(d, s_.frame[fork.idx()].tangent));
    return sine * ramp > rf ? rf / sine : ramp;
  }

  /// Distance of node y above the anchor, given the distance of its parent.
  [[nodiscard]] SliceGeometry edge_geometry(NodeId n, double t) const {
    SliceGeometry g;
    const NodeId p = s_.parent[n.idx()];
    g.node = n;
    g.t = t;
    if (!p.valid()) {
      g.center = s_.position[n.idx()];
      g.frame = s_.frame[n.idx()];
      g.radius = s_.radius[n.idx()];
      return g;
    }
    const Frame& fp = s_.frame[p.idx()];
    const Frame& fn = s_.frame[n.idx()];
    g.center = glm::mix(s_.position[p.idx()], s_.position[n.idx()], t);
    g.radius = glm::mix(s_.start_radius(n), s_.radius[n.idx()], t);
    const dvec3 tangent = normalize_or(glm::mix(fp.tangent, fn.tangent, t), fn.tangent);
    g.frame = transport_frame(fp, tangent);
    return g;
  }

  /// The target edge length of a loop (ContourParams::ring_edge; metres), 0 when off.
  [[nodiscard]] double ring_edge() const {
    return p_.ring_edge > 0 ? p_.ring_edge * spacing_ / p_.resolution : 0.0;
  }
  /// Vertices a loop of this perimeter keeps (ContourParams::ring_edge) at most.
  [[nodiscard]] std::size_t ring_vertices(double perimeter) const {
    const auto fewest = std::max<std::size_t>(3, static_cast<std::size_t>(std::lround(p_.min_ring_vertices * p_.resolution)));
    return std::max(fewest, static_cast<std::size_t>(std::ceil(perimeter / ring_edge())));
  }
  /// The mean and the shortest edge length of stored loop l (metres).
  [[nodiscard]] std::pair<double, double> loop_edges(std::uint32_t l) const {
    const ContourSet& c = *store_;
    const std::uint32_t b = c.loop_begin[l], n = c.loop_begin[l + 1] - b;
    double perimeter = 0, shortest = std::numeric_limits<double>::infinity();
    for (std::uint32_t k = 0; k < n; ++k) {
      const double e = glm::length(c.point[b + (k + 1) % n] - c.point[b + k]);
      perimeter += e;
      shortest = std::min(shortest, e);
    }
    return {perimeter / double(std::max<std::uint32_t>(n, 1)), shortest};
  }
  /// The edge length of a round section's loop of the local radius (ring_edge > 0; metres).
  [[nodiscard]] double ring_edge_at(const SliceGeometry& g) const {
    const double circumference = 2.0 * std::numbers::pi * g.radius;
    return circumference / double(ring_vertices(circumference));
  }
  /// The slice step: with ring_edge, the height of an equilateral triangle on the edge of a
  /// round section of the local radius (times the node's local factor); else slice_step x the
  /// local radius. At least min_slice_step x the neighbour distance (over the resolution).
  [[nodiscard]] double fine_step(const SliceGeometry& g) const {
    if (ring_edge() > 0) {
      return std::max(local(g.node).slice_step * kIsotropic * ring_edge_at(g),
                      p_.min_slice_step * spacing_ / p_.resolution);
    }
    return std::max(slice_step(g.node) * g.radius, p_.min_slice_step * spacing_);
  }
  /// Distance to the next slice from a slice with geometry g: fine_step, but no more than
  /// max_slices_per_edge slices on one edge (a long thin twig is a straight round cone between
  /// its nodes and needs no more), except where a bundle is still leaving its fork.
  ///
  /// `loop` (optional) is the loop just sliced there: with ring_edge, the aspect limit is on its
  /// edges (a thin bundle keeps fewer vertices than the round section's, an uneven outline more,
  /// and the shortest edge makes the thinnest triangle); without it, the round section's.
  [[nodiscard]] double step_at(const SliceGeometry& g, std::uint32_t loop = UINT32_MAX) const {
    double step = fine_step(g);
    const NodeId parent = s_.parent[g.node.idx()];
    if (parent.valid() && p_.max_slices_per_edge > 0) {
      const double l = len(g.node);
      const bool in_transition = s_.is_fork(parent) && g.t * l < transition_length(g.node);
      if (!in_transition) {
        double capped = l / (double(p_.max_slices_per_edge) * (ring_edge() > 0 ? p_.resolution : 1.0));
        // With rings from an edge length, the cap only stretches the slices of thin twigs
        // (loops finer than ring_edge), and no more than max_slice_aspect of their shortest edge,
        // so their triangles are not needles; elsewhere the slices stay isotropic.
        if (ring_edge() > 0) {
          const auto [mean, shortest] = loop != UINT32_MAX ? loop_edges(loop) : std::pair{ring_edge_at(g), ring_edge_at(g)};
          const double w = std::clamp((0.9 - mean / ring_edge()) / 0.2, 0.0, 1.0);
          const double aspect = kIsotropic + w * std::max(p_.max_slice_aspect - kIsotropic, 0.0);
          capped = std::min(capped, aspect * shortest);
        }
        step = std::max(step, capped);
      }
    }
    return step;
  }

  /// How far the wood surface lies outside a node's boundary strands (metres; see Tables).
  [[nodiscard]] double surface_offset(NodeId n) const { return tables_.node_offset[n.idx()]; }

  /// Appends the strands of node n at t on its edge.
  void evaluate(NodeId n, double t, SlicePoints& out) {
    const std::uint32_t* cand = tables_.cand.data() + tables_.cand_begin[n.idx()];
    const std::uint32_t count = tables_.cand_begin[n.idx() + 1] - tables_.cand_begin[n.idx()];
    const std::uint32_t base = f_.node_begin[n.idx()];
    out_->stats.evaluated_points += count;
    const NodeId parent = s_.parent[n.idx()];
    // Sections are stretched into the round cone's ellipse (unslant), except in a fork's own
    // section, where the bundles sit beside each other rather than round on one axis.
    const dvec3 axis =
        parent.valid() ? normalize_or(s_.position[n.idx()] - s_.position[parent.idx()], dvec3(0)) : dvec3(0);
    // The points and strands are written in place (room made once per node).
    const std::size_t at = out.point.size();
    out.point.resize(at + count);
    out.strand.resize(at + count);
    dvec3* const point = out.point.data() + at;
    StrandId* const strand = out.strand.data() + at;
    for (std::uint32_t k = 0; k < count; ++k) strand[k] = f_.strand[base + cand[k]];
    if (t >= 1.0 || !parent.valid()) {
      out.offset.insert(out.offset.end(), count, surface_offset(n));
      const dvec3& c = s_.position[n.idx()];
      const bool unslanted = parent.valid() && !s_.is_fork(n);
      for (std::uint32_t k = 0; k < count; ++k) {
        const dvec3& q = st_.point[base + cand[k]];
        point[k] = unslanted ? c + unslant(q - c, axis) : q;
      }
      return;
    }
    // Each particle's cross-section coordinates are interpolated between its two nodes and
    // placed with the slice's frame on the edge axis, so a section halfway along an edge has
    // the interpolated radius of the skeleton's round cone. (The 3D Catmull-Rom strands sag
    // inwards before a fork, where the continuation tangents diverge; sliced directly they
    // pinch the branch by up to 15% of its radius.)
    //
    // Both ends are first scaled to the round cone's radius at t (the clouds are fitted to
    // their own nodes' radii), so sections follow the skeleton as it tapers. Above a fork, a
    // child's bundle starts squeezed beside its sibling's in the fork's section; interpolated
    // over the whole edge it would stay thin and off its axis for the edge's length. Instead
    // it takes its own round section within fork_transition x the fork's radius
    // (smoothstep), the way wood leaves a fork.
    const SliceGeometry g = edge_geometry(n, t);
    const std::uint32_t pbase = f_.node_begin[parent.idx()] + parent_index(s_, f_, n, 0);
    double w = t;
    if (s_.is_fork(parent)) {
      const double l = len(n);
      const double ramp = std::min(l, transition_length(n));
      const double x = ramp > 0 ? std::clamp(t * l / ramp, 0.0, 1.0) : 1.0;
      w = x * x * (3.0 - 2.0 * x);
    }
    // (The parent's end is scaled along the cone from the parent's own radius: a lateral
    // starting thinner than its fork, Skeleton::base_radius, still begins in the fork's section.)
    const double scale_p = glm::mix(s_.radius[parent.idx()], s_.radius[n.idx()], t) / s_.radius[parent.idx()];
    const double scale_n = g.radius / s_.radius[n.idx()];
    out.offset.insert(out.offset.end(), count,
                      glm::mix(surface_offset(parent) * scale_p, surface_offset(n) * scale_n, w));
    // A wide lateral's section near its fork is tilted against the fork's own section; part
    // of it would dip back below the fork's plane and fold the surface there. Points above a
    // fork are kept at least a little above its plane (a third of their distance along the
    // edge), which only touches the first sections of steep laterals.
    const dvec3& fork_pos = s_.position[parent.idx()];
    const dvec3& fork_up = s_.frame[parent.idx()].tangent;
    const double rf = s_.radius[parent.idx()];
    const double along = t * len(n);
    // Only where the child leaves upwards, within its transition, by at most half the fork's
    // radius (a drooping branch is meant to go below the fork's plane).
    const bool above_fork =
        s_.is_fork(parent) && along < transition_length(n) && glm::dot(s_.position[n.idx()] - fork_pos, fork_up) > 0;
    const double min_height = along / 3.0;
    // Above a fork, as the bundle gets its own round section: weight w^4 of the transition's
    // smoothstep (slices near the fork lie in its plane, far from perpendicular to the child,
    // and stretched early they would press into the sibling).
    const double w_round = s_.is_fork(parent) ? (w * w) * (w * w) : 1.0;
    const double na = glm::dot(g.frame.normal, axis), nb = glm::dot(g.frame.binormal, axis);
    for (std::uint32_t k = 0; k < count; ++k) {
      const std::uint32_t j = cand[k];
      const dvec2 q = glm::mix(f_.position[pbase + j] * scale_p, f_.position[base + j] * scale_n, w);
      // (The offset's component along the axis from the frame's: no 3D vector per point.)
      const double stretch = unslant_factor(glm::dot(q, q), q.x * na + q.y * nb);
      dvec3 pt = g.center + g.frame.to_world(q) * (w_round < 1.0 ? (1.0 - w_round) + w_round * stretch : stretch);
      if (above_fork) {
        const double h = glm::dot(pt - fork_pos, fork_up);
        if (h < min_height) pt += fork_up * std::min(min_height - h, 0.5 * rf);
      }
      point[k] = pt;
    }
  }

  /// The edges of the subtree rooted at x that span distance d above the anchor, where x's
  /// own edge starts at distance `base` (0 when x's parent is the anchor). Main children
  /// first, so the first entry follows the main chain.
  void cut(NodeId x, double base, double d, std::vector<CutEdge>& out) const {
    stack_.clear();
    stack_.emplace_back(x, base);
    while (!stack_.empty()) {
      const auto [y, start] = stack_.back();
      stack_.pop_back();
      const double l = len(y);
      if (d < start + l || !s_.parent[y.idx()].valid()) {
        out.push_back({y, s_.parent[y.idx()].valid() ? std::clamp((d - start) / l, 0.0, 1.0) : 1.0});
        continue;
      }
      const auto& c = s_.children[y.idx()];
      if (c[1].valid() && !excluded(c[1])) stack_.emplace_back(c[1], start + l);
      if (c[0].valid()) stack_.emplace_back(c[0], start + l);
    }
  }

  void evaluate_cut(const std::vector<CutEdge>& edges, SlicePoints& out) {
    for (const auto& e : edges) evaluate(e.node, e.t, out);
  }

  /// Smallest distance between the two point sets (3D) when it is below `cap`; otherwise
  /// infinity. May stop early with any distance <= `enough`.
  static double gap(const std::vector<dvec3>& a, const std::vector<dvec3>& b, double cap, double enough);

  // --- output -------------------------------------------------------------------------------

  /// Selects the boundary of `pts` in the plane of `g`, offsets it outwards to the surface and
  /// appends it as a loop of `tube`. Returns the loop index.
  std::uint32_t add_loop(const SlicePoints& pts, const SliceGeometry& g, LoopKind kind, double distance,
                         std::uint32_t tube);
  std::uint32_t add_loop_vertices(const SlicePoints& pts, const std::vector<std::uint32_t>& loop,
                                  const SliceGeometry& g, LoopKind kind, double distance, std::uint32_t tube);

  /// Junction::lower_side for loop `loop` below fork `fork`: particle order at the fork is
  /// [main child's strands | lateral's | new at the fork] (particles/particles.h).
  std::vector<std::uint8_t> bundle_sides(NodeId fork, std::uint32_t loop) const {
    const std::uint32_t base = f_.node_begin[fork.idx()];
    const std::uint32_t n_main = f_.count(s_.children[fork.idx()][0]);
    return loop_sides(loop, 2, [&](auto&& side_of) {
      for (std::uint32_t j = 0; j < f_.new_begin[fork.idx()]; ++j) side_of(f_.strand[base + j], j < n_main ? 0 : 1);
    });
  }
  /// Per vertex of `loop`: the side `mark` gives its strand (mark calls side_of(strand,
  /// side) for some strands), else `unmarked`. A fork carries many strands (every strand of
  /// the tree at the root), a loop few: the loop's strands are flagged in the thread's table
  /// of strands, the marked ones looked up there, and the flags cleared again (rather than a
  /// hash map of the fork's strands per junction, which showed as 6 % of a profile of the
  /// contours on the large grown tree).
  template <class Mark>
  std::vector<std::uint8_t> loop_sides(std::uint32_t loop, std::uint8_t unmarked, Mark&& mark) const {
    constexpr std::uint8_t kNotInLoop = 0xff;
    std::vector<std::uint8_t>& table = scratch_.strand_side;
    table.resize(f_.strand_count(), kNotInLoop);
    const std::span<const StrandId> ids(store_->strand.data() + store_->loop_begin[loop], store_->loop_size(loop));
    for (const StrandId s : ids) {
      if (s.valid() && s.value < table.size()) table[s.value] = unmarked;
    }
    mark([&](StrandId s, std::uint8_t side) {
      if (s.value < table.size() && table[s.value] == unmarked) table[s.value] = side;
    });
    std::vector<std::uint8_t> out(ids.size(), unmarked);
    for (std::size_t k = 0; k < ids.size(); ++k) {
      if (ids[k].valid() && ids[k].value < table.size()) out[k] = table[ids[k].value];
    }
    for (const StrandId s : ids) {
      if (s.valid() && s.value < table.size()) table[s.value] = kNotInLoop;
    }
    return out;
  }
  /// The distance in (lo, hi] where `apart` turns true (false at lo, true at hi), by
  /// split_bisection_steps halvings: where two bundles come apart.
  template <class Apart>
  double bisect(double lo, double hi, Apart&& apart) const {
    for (std::uint32_t k = 0; k < p_.split_bisection_steps; ++k) {
      const double mid = 0.5 * (lo + hi);
      (apart(mid) ? hi : lo) = mid;
    }
    return hi;
  }
  /// After split_gap_at: the section's geometry (on the main side's cut, or the lateral's once
  /// the main side has ended).
  [[nodiscard]] SliceGeometry fused_geometry() const { return cut_geometry(cut_a_.empty() ? cut_b_ : cut_a_); }
  /// After split_gap_at: both bundles' points into pts_.
  void fuse_points() {
    pts_.clear();
    pts_.append(pts_a_);
    pts_.append(pts_b_);
  }
  /// Makes the tube's last loop the lower loop of the fragment's end junction at `fork`.
  Junction& open_junction(Fragment& fragment, NodeId fork, std::uint32_t tube, double split_distance) const {
    Junction& j = fragment.junction;
    fragment.has_junction = true;
    j.fork = fork;
    j.lower = out_->tubes[tube].loops.back();
    j.lower_tube = tube;
    j.split_distance = split_distance;
    return j;
  }
  /// The task's exclusions inside x's subtree, for a child tube that walks it.
  [[nodiscard]] std::vector<NodeId> excluded_within(NodeId x) const {
    std::vector<NodeId> out;
    for (const NodeId e : excluded_) {
      if (tables_.in_subtree(e, x)) out.push_back(e);
    }
    return out;
  }
  /// Gap between the bundles of fork's two children at distance u above the anchor (the
  /// fork sits at distance fork_base). Leaves the points in pts_a_ / pts_b_.
  double split_gap_at(NodeId fork, double fork_base, double u);
  /// Smallest distance from the surface points `pts` (strand point + offset) to the round cones
  /// of the subtree rooted at x (x's edge starting at `base` above the anchor), over the edges
  /// starting below `reach`. Negative when a point is inside a cone. Returns as soon as it is
  /// at most `enough` (callers only ask whether it is larger).
  double cone_clearance(const SlicePoints& pts, NodeId x, double base, double reach, double enough) const;
  /// The clearance the split test asks for (surfaces clear of the other subtree's cones).
  [[nodiscard]] double min_clearance(NodeId fork) const { return 0.5 * split_gap(fork) * spacing_; }
  /// After split_gap_at: is each bundle's surface clear of the other child's subtree cones by
  /// min_clearance? Computed on first use for that section (only once the points are apart:
  /// a split and a forced split both ask it, each after its own test of the points).
  bool surfaces_clear();
  /// After split_gap_at: are the bundles apart (points and cones)?
  bool separated_now() { return last_gap_ > threshold(last_fork_) && surfaces_clear(); }
  /// Geometry of a slice through a cut: the first (main-chain) edge of the cut.
  SliceGeometry cut_geometry(const std::vector<CutEdge>& edges) const {
    return edge_geometry(edges.front().node, edges.front().t);
  }
  /// The split gap's unit at a fork: the neighbour distance, or thin_gap_radii x the thinner
  /// child's radius where that is less (ContourParams::thin_gap_radii).
  [[nodiscard]] double gap_unit(NodeId fork) const {
    if (!(p_.thin_gap_radii > 0)) return spacing_;
    const auto& c = s_.children[fork.idx()];
    return std::min(spacing_, p_.thin_gap_radii * std::min(s_.radius[c[0].idx()], s_.radius[c[1].idx()]));
  }
  [[nodiscard]] double threshold(NodeId fork) const { return split_gap(fork) * gap_unit(fork); }
  [[nodiscard]] bool excluded(NodeId n) const {
    return !excluded_.empty() && std::find(excluded_.begin(), excluded_.end(), n) != excluded_.end();
  }
  /// A fork in the walk: two children, neither of them split off already.
  [[nodiscard]] bool fork_here(NodeId n) const { return s_.is_fork(n) && !excluded(s_.children[n.idx()][1]); }
  /// In the fused section of `fork` (sitting at fork_base above the anchor), after
  /// split_gap_at(fork, fork_base, u): the lateral of a fork inside either child's subtree,
  /// below u, whose bundle has come apart from everything else in the section (points and
  /// cones, as for the fork's own split). Invalid if none. Its fork's distance above the
  /// anchor goes to `base`.
  NodeId nested_split(NodeId fork, double u, double& base);
  /// Is the bundle of `lateral` (its edge starting at `base` above the anchor) apart from the
  /// rest of `fork`'s fused section at distance u?
  bool nested_apart(NodeId fork, double fork_base, NodeId lateral, double base, double u);
  /// How far above the anchor the bundle of `fork`'s child c (its edge starting at `base`, its
  /// sibling `other`) may stay in a fused section: `stub`, up to its tip (node `tip`) when its
  /// segment ends in a stub's tip; `turn`, up to its segment's first node turning back by more
  /// than kFusedMaxTurn. Infinity where neither applies.
  struct Leave {
    double stub, turn;
    NodeId tip;
  };
  Leave leave_by(NodeId fork, NodeId c, NodeId other, double base) const;
  /// In the fused section of `fork`, after split_gap_at(fork, .., u): a lateral of a fork inside
  /// either child's subtree (as nested_split's) whose segment ends in a stub's tip (Leave)
  /// before the next slice, u + step, outside the round cones of the rest of the section, and
  /// whose bundle is still in the section at u. Invalid if none; its fork's distance above the
  /// anchor goes to `base`.
  NodeId nested_due(NodeId fork, double u, double step, double& base);
  /// In the fused section of `fork` (at fork_base above the anchor), after split_gap_at: the
  /// distance of the first node in (after, before) on a bundle's chain (from the fork's
  /// children, and from the laterals of the forks inside the section) where slices at
  /// `after` and `before` would cut the corner by more than max_corner_cut x its radius;
  /// `before` if none. Hairpins are left out (the section splits below them).
  double next_corner(NodeId fork, double fork_base, double after, double before);
  /// The laterals of the forks on the paths from `fork`'s children to the cut at the last
  /// split_gap_at (cut_a_ / cut_b_), in cut order.
  void nested_candidates(NodeId fork, std::vector<NodeId>& out) const;
  /// Junction::lower_side for a lateral split off inside a fused section: 1 for its strands,
  /// 0 for every other.
  std::vector<std::uint8_t> lateral_sides(NodeId lateral, std::uint32_t loop) const;

  const Skeleton& s_;
  const ParticleField& f_;
  const StrandSet& st_;
  const ContourParams& p_;
  double spacing_;        // distance between neighbouring particles (metres)
  const Tables& tables_;  // per-node tables shared by all walks
  // Of the last split_gap_at: its arguments, the point gap, and the surfaces' clearance once asked.
  NodeId last_fork_;
  double last_fork_base_ = 0, last_u_ = 0, last_gap_ = 0;
  std::optional<double> last_clearance_;
  ContourSet* out_ = nullptr;     // the walk's Fragment::part: its tube and figures
  ContourSet* store_ = nullptr;   // the thread's store: the loops
  std::vector<NodeId> excluded_;  // of the task
  double anchor_distance_ = 0;    // of the task's anchor, from the root
  // Scratch buffers, the thread's (a walk runs on one thread from start to end, and most
  // tubes are a few slices long: buffers of their own were allocated anew for each).
  struct Scratch {
    std::vector<std::pair<NodeId, double>> stack, cone_stack;
    SlicePoints pts, pts_a, pts_b, pts_l, pts_rest, tip;
    std::vector<CutEdge> cut_a, cut_b, cut_n;
    std::vector<dvec2> flat, moved, edge_normal;
    std::vector<dvec3> lift;
    std::vector<std::uint32_t> loop, keep, more;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> gaps;
    std::vector<double> arc;
    std::vector<std::uint8_t> strand_side;  ///< per strand, for loop_sides (0xff between calls)
    std::vector<NodeId> candidates;         ///< nested laterals (nested_candidates)
  };
  static Scratch& thread_scratch() {
    thread_local Scratch scratch;
    return scratch;
  }
  Scratch& scratch_ = thread_scratch();
  std::vector<std::pair<NodeId, double>>& stack_ = scratch_.stack;
  SlicePoints &pts_ = scratch_.pts, &pts_a_ = scratch_.pts_a, &pts_b_ = scratch_.pts_b, &pts_l_ = scratch_.pts_l,
              &pts_rest_ = scratch_.pts_rest;
  std::vector<CutEdge>& cut_a_ = scratch_.cut_a;
  std::vector<CutEdge>& cut_b_ = scratch_.cut_b;
  std::vector<CutEdge>& cut_n_ = scratch_.cut_n;
  std::vector<dvec2>& flat_ = scratch_.flat;
};

double Walker::gap(const std::vector<dvec3>& a, const std::vector<dvec3>& b, double cap, double enough) {
  // Exact below `cap`, otherwise infinity: a uniform grid of cell size cap over both sets, so
  // only pairs in neighbouring cells are compared (the split test only asks "farther than").
  if (a.empty() || b.empty()) return std::numeric_limits<double>::infinity();
  dvec3 lo_a(std::numeric_limits<double>::infinity()), hi_a(-lo_a), lo_b = lo_a, hi_b = hi_a;
  for (const auto& p : a) {
    lo_a = glm::min(lo_a, p);
    hi_a = glm::max(hi_a, p);
  }
  for (const auto& p : b) {
    lo_b = glm::min(lo_b, p);
    hi_b = glm::max(hi_b, p);
  }
  const dvec3 sep = glm::max(glm::max(lo_a - hi_b, lo_b - hi_a), dvec3(0));
  if (glm::length(sep) >= cap) return std::numeric_limits<double>::infinity();
  // (From infinity rather than cap^2, so that `enough` may be `cap` itself.)
  double best2 = std::numeric_limits<double>::infinity();
  const double enough2 = enough * enough;
  // Small sets pair by pair: up to 16,384 pairs the grid's sorts and 27 merges cost more
  // (pairwise up to 1,024 / 4,096 / 16,384 / 65,536 pairs: BM_Contours 785 / 763 / 753 / 762 ms
  // on 1 thread, 812 with the grid alone). The same distance, or where the grid would stop at
  // another one at most `enough`, this one: callers compare with more than `enough`.
  // Only the points within cap of the other set's box can be nearer than cap to it (bundles
  // side by side: about the facing halves).
  thread_local std::vector<dvec3> near_a, near_b;
  auto near = [&](const std::vector<dvec3>& pts, const dvec3& lo, const dvec3& hi, std::vector<dvec3>& out) {
    out.clear();
    const dvec3 lo_c = lo - dvec3(cap), hi_c = hi + dvec3(cap);
    for (const dvec3& p : pts) {
      if (glm::all(glm::lessThanEqual(lo_c, p)) && glm::all(glm::lessThanEqual(p, hi_c))) out.push_back(p);
    }
  };
  near(a, lo_b, hi_b, near_a);
  near(b, lo_a, hi_a, near_b);
  constexpr std::size_t kPairwise = 16384;
  if (a.size() * b.size() <= kPairwise) {
    for (const dvec3& p : near_a) {
      for (const dvec3& q : near_b) best2 = std::min(best2, glm::dot(p - q, p - q));
      if (best2 <= enough2) break;
    }
    return best2 < cap * cap ? std::sqrt(best2) : std::numeric_limits<double>::infinity();
  }
  const double inv = 1.0 / cap;
  auto cell = [&](const dvec3& p) { return glm::i64vec3(glm::floor((p - lo_b) * inv)); };
  auto key = [](glm::i64vec3 c) {
    return (std::uint64_t(c.x + (1 << 20)) << 42) ^ (std::uint64_t(c.y + (1 << 20)) << 21) ^
           std::uint64_t(c.z + (1 << 20));
  };
  // Cell keys are linear in the cell coordinates (21 bits each, offset so they stay
  // positive), so shifting every cell of a by one neighbour offset shifts its keys by one
  // constant and keeps their order: each of the 27 offsets is one merge of two sorted lists.
  thread_local std::vector<std::pair<std::uint64_t, std::uint32_t>> cells_a, cells_b;
  auto sorted_cells = [&](const std::vector<dvec3>& pts,
                          std::vector<std::pair<std::uint64_t, std::uint32_t>>& cells) -> const auto& {
    cells.clear();
    for (std::uint32_t k = 0; k < pts.size(); ++k) cells.emplace_back(key(cell(pts[k])), k);
    std::sort(cells.begin(), cells.end());
    return cells;
  };
  const auto& cb = sorted_cells(near_b, cells_b);
  const auto& ca = sorted_cells(near_a, cells_a);
  for (int dx = -1; dx <= 1 && best2 > enough2; ++dx)
    for (int dy = -1; dy <= 1 && best2 > enough2; ++dy)
      for (int dz = -1; dz <= 1 && best2 > enough2; ++dz) {
        const std::uint64_t shift = (std::uint64_t(std::int64_t(dx)) << 42) + (std::uint64_t(std::int64_t(dy)) << 21) +
                                    std::uint64_t(std::int64_t(dz));
        std::size_t jb = 0;
        for (std::size_t ia = 0; ia < ca.size() && best2 > enough2;) {
          const std::uint64_t k = ca[ia].first + shift;
          while (jb < cb.size() && cb[jb].first < k) ++jb;
          if (jb == cb.size()) break;
          if (cb[jb].first != k) {
            ++ia;
            continue;
          }
          std::size_t je = jb;
          while (je < cb.size() && cb[je].first == k) ++je;
          for (; ia < ca.size() && ca[ia].first + shift == k; ++ia) {
            const dvec3& p = near_a[ca[ia].second];
            for (std::size_t t = jb; t < je; ++t)
              best2 = std::min(best2, glm::dot(p - near_b[cb[t].second], p - near_b[cb[t].second]));
          }
        }
      }
  return best2 < cap * cap ? std::sqrt(best2) : std::numeric_limits<double>::infinity();
}

std::uint32_t Walker::add_loop(const SlicePoints& pts, const SliceGeometry& g, LoopKind kind, double distance,
                               std::uint32_t tube) {
  flat_.resize(pts.point.size());
  for (std::size_t i = 0; i < pts.point.size(); ++i) flat_[i] = g.frame.to_local(pts.point[i] - g.center);
  bool fallback = false;
  std::vector<std::uint32_t>& loop = scratch_.loop;
  boundary_loop(flat_, p_.concave_turn_degrees, loop, &fallback, p_.fallback_max_edge);
  if (fallback) {
    ++out_->stats.boundary_fallbacks;
    out_->stats.warnings.add("boundary_fallback", "slice not star-shaped around its centroid; concave outline used",
                             s_.describe(g.node));
  }
  if (loop.size() >= 3) return add_loop_vertices(pts, loop, g, kind, distance, tube);

  // Fewer than three non-collinear strand points (a degenerate bundle): replace the slice by
  // a small triangle around the points so the surface stays closed.
  out_->stats.warnings.add("degenerate_slice", "slice with fewer than 3 boundary strands widened to a triangle",
                           s_.describe(g.node));
  dvec2 c(0);
  for (const auto& q : flat_) c += q;
  c /= double(std::max<std::size_t>(flat_.size(), 1));
  SlicePoints extra;
  loop.clear();
  for (std::uint32_t k = 0; k < 3; ++k) {
    const double a = 2.0943951023931953 * k;
    const dvec2 q = c + 0.3 * g.radius * dvec2(std::cos(a), std::sin(a));
    extra.point.push_back(g.center + g.frame.to_world(q));
    extra.strand.push_back(pts.strand.empty() ? StrandId{}
                                              : pts.strand[std::min<std::size_t>(k, pts.strand.size() - 1)]);
    extra.offset.push_back(0.0);
    loop.push_back(k);
  }
  flat_.assign({c + 0.3 * g.radius * dvec2(1, 0), c + 0.3 * g.radius * dvec2(-0.5, 0.8660254037844386),
                c + 0.3 * g.radius * dvec2(-0.5, -0.8660254037844386)});
  return add_loop_vertices(extra, loop, g, kind, distance, tube);
}

std::uint32_t Walker::add_loop_vertices(const SlicePoints& pts, const std::vector<std::uint32_t>& loop,
                                        const SliceGeometry& g, LoopKind kind, double distance, std::uint32_t tube) {
  const std::size_t m = loop.size();
  // The boundary strands are particle centres; the wood surface lies outside them, by the
  // node's surface offset (see surface_offset) interpolated along the edge like the strands,
  // so consecutive loops of any kind agree. Each vertex moves outwards in the slice plane
  // along its vertex normal.
  dvec2 centroid(0);
  for (auto i : loop) centroid += flat_[i];
  centroid /= double(m);
  auto outward = [](dvec2 e) {
    const double l = glm::length(e);
    return l > 0 ? dvec2(e.y, -e.x) / l : dvec2(0);  // outward normal of a CCW loop's edge
  };
  std::vector<dvec2>& moved = scratch_.moved;
  std::vector<dvec2>& edge_normal = scratch_.edge_normal;  // of edge k -> k + 1, once for its two ends
  std::vector<dvec3>& lift = scratch_.lift;  // each point's component off the slice plane, kept as is
  moved.resize(m);
  edge_normal.resize(m);
  lift.resize(m);
  for (std::size_t k = 0; k < m; ++k) edge_normal[k] = outward(flat_[loop[(k + 1) % m]] - flat_[loop[k]]);
  for (std::size_t k = 0; k < m; ++k) {
    const dvec2& b = flat_[loop[k]];
    dvec2 nrm = edge_normal[(k + m - 1) % m] + edge_normal[k];
    const double l = glm::length(nrm);
    nrm = l > 1e-12 ? nrm / l : (glm::length(b - centroid) > 0 ? glm::normalize(b - centroid) : dvec2(1, 0));
    moved[k] = b + pts.offset[loop[k]] * nrm;
    const dvec3 rel = pts.point[loop[k]] - g.center;
    lift[k] = g.frame.tangent * glm::dot(rel, g.frame.tangent);
  }
  // A single bundle centred on its branch is a round section: small clouds leave some hull
  // vertices on their inner ring, which would dent the surface. Such vertices move out along
  // their ray from the centroid to 90% of the mean radius (the loop stays star-shaped around
  // the centroid, so it stays simple). Off-centre bundles (next to a sibling at a fork) and
  // fused unions keep their shape.
  if (kind == LoopKind::plain || kind == LoopKind::tip) {
    dvec2 c2(0);
    for (const auto& q : moved) c2 += q;
    c2 /= double(m);
    double mean = 0;
    for (const auto& q : moved) mean += glm::length(q - c2);
    mean /= double(m);
    if (glm::length(c2) < 0.25 * g.radius) {
      const double floor = 0.9 * mean;
      for (auto& q : moved) {
        const double d = glm::length(q - c2);
        if (d > 0 && d < floor) q = c2 + (q - c2) * (floor / d);
      }
    }
  }
  // Ring resolution (ContourParams::ring_edge): the vertices nearest to evenly spaced marks
  // along the loop, in order, the first kept.
  std::vector<std::uint32_t>& keep = scratch_.keep;
  keep.clear();
  if (ring_edge() > 0) {
    std::vector<double>& arc = scratch_.arc;
    arc.resize(m + 1);
    arc[0] = 0;
    for (std::size_t k = 0; k < m; ++k) arc[k + 1] = arc[k] + glm::length(moved[(k + 1) % m] - moved[k]);
    const std::size_t n = std::min(m, ring_vertices(arc[m]));
    if (n < m) {
      std::size_t i = 0;
      for (std::size_t k = 0; k < n; ++k) {
        const double mark = arc[m] * double(k) / double(n);
        // Advance while the next vertex is nearer the mark and leaves room for the rest.
        while (i + 1 < m - (n - 1 - k) && std::abs(arc[i + 1] - mark) <= std::abs(arc[i] - mark)) ++i;
        keep.push_back(static_cast<std::uint32_t>(i));
        ++i;
      }
      // Shape kept: between two kept vertices, the dropped vertex farthest from their chord
      // comes back while it is farther than the tolerance (Douglas-Peucker), so a thin bundle's
      // bump on a fused outline is not cut off. The tolerance is above the sag of a round
      // section's chords, so round loops are left as sampled.
      const double edge = arc[m] / double(n), round_radius = arc[m] / (2.0 * std::numbers::pi);
      const double tol = std::max(0.25 * spacing_, 1.5 * edge * edge / (8.0 * round_radius));
      std::vector<std::uint32_t>& more = scratch_.more;
      more.clear();
      std::vector<std::pair<std::uint32_t, std::uint32_t>>& gaps = scratch_.gaps;
      gaps.clear();
      for (std::size_t k = 0; k < n; ++k) gaps.emplace_back(keep[k], k + 1 < n ? keep[k + 1] : keep[0] + std::uint32_t(m));
      while (!gaps.empty()) {
        const auto [a, b] = gaps.back();
        gaps.pop_back();
        const dvec2 pa = moved[a % m], pb = moved[b % m];
        const dvec2 d = pb - pa;
        const double l2 = glm::dot(d, d);
        double worst = tol;
        std::uint32_t at = 0;
        for (std::uint32_t x = a + 1; x < b; ++x) {
          const dvec2 q = moved[x % m] - pa;
          const double t = l2 > 0 ? std::clamp(glm::dot(q, d) / l2, 0.0, 1.0) : 0.0;
          const double e = glm::length(q - t * d);
          if (e > worst) {
            worst = e;
            at = x;
          }
        }
        if (at == 0) continue;
        more.push_back(at % std::uint32_t(m));
        gaps.emplace_back(a, at);
        gaps.emplace_back(at, b);
      }
      keep.insert(keep.end(), more.begin(), more.end());
      std::sort(keep.begin(), keep.end());
    }
  }
  if (keep.empty()) {
    for (std::size_t k = 0; k < m; ++k) keep.push_back(static_cast<std::uint32_t>(k));
  }
  ContourSet& store = *store_;
  const auto loop_index = static_cast<std::uint32_t>(store.loop_kind.size());
  for (const std::uint32_t k : keep) {
    store.point.push_back(g.center + g.frame.to_world(moved[k]) + lift[k]);
    store.strand.push_back(pts.strand[loop[k]]);
  }
  store.loop_begin.push_back(static_cast<std::uint32_t>(store.point.size()));
  store.loop_node.push_back(g.node);
  store.loop_t.push_back(g.t);
  store.loop_distance.push_back(distance);
  store.loop_center.push_back(g.center);
  store.loop_frame.push_back(g.frame);
  store.loop_radius.push_back(g.radius);
  store.loop_kind.push_back(kind);
  out_->tubes[tube].loops.push_back(loop_index);
  if (kind == LoopKind::fused) ++out_->stats.fused_loops;
  return loop_index;
}

double Walker::split_gap_at(NodeId fork, double fork_base, double u) {
  const auto& c = s_.children[fork.idx()];
  cut_a_.clear();
  cut_b_.clear();
  cut(c[0], fork_base, u, cut_a_);
  cut(c[1], fork_base, u, cut_b_);
  pts_a_.clear();
  pts_b_.clear();
  evaluate_cut(cut_a_, pts_a_);
  evaluate_cut(cut_b_, pts_b_);
  // Exact up to the threshold; may stop early at any distance that passes neither the
  // threshold nor the 0.5 x the neighbour distance a forced split needs (the gap is only
  // compared with those).
  last_gap_ = gap(pts_a_.point, pts_b_.point, threshold(fork), std::min(threshold(fork), 0.5 * spacing_));
  last_fork_ = fork;
  last_fork_base_ = fork_base;
  last_u_ = u;
  last_clearance_.reset();
  return last_gap_;
}

bool Walker::surfaces_clear() {
  // Bundles can also run into the other branch at a different distance from the fork (a
  // lateral leaving a thick trunk at an angle lies below the trunk's slice at the same
  // distance): each bundle's surface must also clear the other subtree's round cones.
  if (!last_clearance_) {
    const auto& c = s_.children[last_fork_.idx()];
    const double reach = last_u_ + 2.0 * s_.radius[last_fork_.idx()];
    const double enough = min_clearance(last_fork_);
    double clearance = cone_clearance(pts_b_, c[0], last_fork_base_, reach, enough);
    if (clearance > enough) clearance = std::min(clearance, cone_clearance(pts_a_, c[1], last_fork_base_, reach, enough));
    last_clearance_ = clearance;
  }
  return *last_clearance_ > min_clearance(last_fork_);
}

double Walker::cone_clearance(const SlicePoints& pts, NodeId x, double base, double reach, double enough) const {
  // Edges of x's subtree starting within `reach` above the anchor (x's edge starts at base).
  std::vector<std::pair<NodeId, double>>& stack = scratch_.cone_stack;
  stack.assign(1, {x, base});
  double best = std::numeric_limits<double>::infinity();
  while (!stack.empty()) {
    const auto [y, start] = stack.back();
    stack.pop_back();
    const NodeId py = s_.parent[y.idx()];
    const dvec3 a = s_.position[py.idx()], b = s_.position[y.idx()];
    const double ra = s_.start_radius(y), rb = s_.radius[y.idx()];
    const dvec3 ab = b - a;
    for (std::size_t k = 0; k < pts.point.size(); ++k) {
      const double t = segment_param(pts.point[k], a, b);
      const double d = glm::length(pts.point[k] - (a + t * ab)) - glm::mix(ra, rb, t) - pts.offset[k];
      if (d <= enough) return d;  // (at the first such point, not the edge's nearest)
      best = std::min(best, d);
    }
    const double l = len(y);
    if (start + l < reach) {
      for (const NodeId c : s_.children[y.idx()]) {
        if (c.valid() && !excluded(c)) stack.emplace_back(c, start + l);
      }
    }
  }
  return best;
}

NodeId Walker::nested_split(NodeId fork, double u, double& base) {
  if (!p_.split_nested_laterals) return {};
  // Forks on the paths from the fork's children down to the cut (pts_a_ / pts_b_ and
  // cut_a_ / cut_b_ hold the section at u), in cut order.
  std::vector<NodeId>& candidates = scratch_.candidates;
  nested_candidates(fork, candidates);
  // Where the walk put the fork (split_gap_at's section), so nested_apart reuses its points.
  const double fork_base = last_fork_base_;
  for (const NodeId lateral : candidates) {
    const double b = tables_.root_distance[s_.parent[lateral.idx()].idx()] - anchor_distance_;
    if (nested_apart(fork, fork_base, lateral, b, u)) {
      base = b;
      return lateral;
    }
  }
  return {};
}

void Walker::nested_candidates(NodeId fork, std::vector<NodeId>& out) const {
  out.clear();
  for (const auto* edges : {&cut_a_, &cut_b_}) {
    for (const CutEdge& e : *edges) {
      for (NodeId y = s_.parent[e.node.idx()]; y.valid() && y != fork; y = s_.parent[y.idx()]) {
        if (!fork_here(y)) continue;
        const NodeId lateral = s_.children[y.idx()][1];
        if (std::find(out.begin(), out.end(), lateral) == out.end()) out.push_back(lateral);
      }
    }
  }
}

Walker::Leave Walker::leave_by(NodeId fork, NodeId c, NodeId other, double base) const {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Leave out{kInf, kInf, {}};
  // The turn: at the segment's first node turning back by more than kFusedMaxTurn (a hairpin
  // or zigzag node: a fused section carried round it folds, its loops around both bundles
  // crossing).
  const double cos_turn = std::cos(kFusedMaxTurn);
  double l = len(c);
  while (s_.child_count(c) == 1) {
    const NodeId n = s_.children[c.idx()][0];
    const dvec3 in = s_.position[c.idx()] - s_.position[s_.parent[c.idx()].idx()];
    const dvec3 next = s_.position[n.idx()] - s_.position[c.idx()];
    if (out.turn == kInf && glm::dot(in, next) < cos_turn * glm::length(in) * glm::length(next)) out.turn = base + l;
    c = n;
    l += len(c);
  }
  // The tip: a stub is at least kStubRadius x the fork's radius thick, or has its tip outside
  // the other child's round cones, where an absorbed twig would be missing from the mesh
  // (with split_outside_tips off, only a tip at least the median radius thick).
  if (!s_.is_tip(c)) return out;
  const double r = s_.radius[c.idx()];
  bool stub = r >= kStubRadius * s_.radius[fork.idx()];
  if (!stub && (p_.split_outside_tips || r >= tables_.median_radius)) {
    SlicePoints& tip = scratch_.tip;
    tip.assign_point(s_.position[c.idx()]);
    stub = cone_clearance(tip, other, base, l + 2.0 * s_.radius[fork.idx()], 0.0) > 0.0;
  }
  if (stub) {
    out.stub = base + l;
    out.tip = c;
  }
  return out;
}

double Walker::next_corner(NodeId fork, double fork_base, double after, double before) {
  const double cos_hairpin = std::cos(kFusedMaxTurn);
  double best = before;
  // Along the chain from c (its edge starting at `base` above the anchor) through single
  // nodes and forks whose lateral has its own tube already: the straight chord between the
  // chain's points at `after` and `best` misses a node by more than max_corner_cut x its
  // radius (hairpins, turning back by over kFusedMaxTurn, split before them instead).
  auto chain = [&](NodeId c, double base) {
    double l = base + len(c);
    while (l < best && (s_.child_count(c) == 1 || (s_.is_fork(c) && !fork_here(c)))) {
      const NodeId n = s_.children[c.idx()][0];
      if (l > after) {
        const dvec3 p = s_.position[c.idx()];
        const dvec3 u = p - s_.position[s_.parent[c.idx()].idx()], v = s_.position[n.idx()] - p;
        const double lu = glm::length(u), lv = glm::length(v);
        if (lu > 0 && lv > 0 && glm::dot(u, v) >= cos_hairpin * lu * lv) {
          const dvec3 from = p - u * (std::min(l - after, lu) / lu), to = p + v * (std::min(best - l, lv) / lv);
          if (chord_miss(p, from, to) > p_.max_corner_cut * s_.radius[c.idx()]) {
            best = l;
            return;
          }
        }
      }
      c = n;
      l += len(c);
    }
  };
  for (const NodeId c : s_.children[fork.idx()]) chain(c, fork_base);
  std::vector<NodeId>& candidates = scratch_.candidates;
  nested_candidates(fork, candidates);
  // A nested fork's main child is left out: a split of `fork` moved back to its corner leaves
  // that corner in the nested fork's own fused section all the same, and moves the split
  // below where the bundles came apart for nothing.
  for (const NodeId lateral : candidates) {
    chain(lateral, tables_.root_distance[s_.parent[lateral.idx()].idx()] - anchor_distance_);
  }
  return best;
}

NodeId Walker::nested_due(NodeId fork, double u, double step, double& base) {
  std::vector<NodeId>& candidates = scratch_.candidates;
  nested_candidates(fork, candidates);
  const auto& c = s_.children[fork.idx()];
  for (const NodeId lateral : candidates) {
    const NodeId y = s_.parent[lateral.idx()];
    const double b = tables_.root_distance[y.idx()] - anchor_distance_;
    const Leave leave = leave_by(y, lateral, s_.children[y.idx()][0], b);
    if (u + step < leave.stub) continue;
    // Only a tip outside the rest of the section's round cones (the fork's two subtrees
    // without the lateral's): inside them, nothing is missing, and a tube of its own would
    // run through the rest's.
    SlicePoints& probe = scratch_.tip;
    probe.assign_point(s_.position[leave.tip.idx()]);
    const double reach = leave.stub + 2.0 * s_.radius[fork.idx()];
    excluded_.push_back(lateral);
    const bool outside = cone_clearance(probe, c[0], last_fork_base_, reach, 0.0) > 0.0 &&
                         cone_clearance(probe, c[1], last_fork_base_, reach, 0.0) > 0.0;
    excluded_.pop_back();
    if (!outside) continue;
    cut_n_.clear();
    cut(lateral, b, u, cut_n_);
    if (cut_n_.empty()) continue;  // (already past its tip)
    base = b;
    return lateral;
  }
  return {};
}

bool Walker::nested_apart(NodeId fork, double fork_base, NodeId lateral, double base, double u) {
  cut_n_.clear();
  cut(lateral, base, u, cut_n_);
  pts_l_.clear();
  evaluate_cut(cut_n_, pts_l_);
  if (pts_l_.point.empty()) return false;
  pts_rest_.clear();
  if (fork == last_fork_ && fork_base == last_fork_base_ && u == last_u_) {
    // The section split_gap_at evaluated (nested_split's case): the rest is its points off
    // the lateral's subtree, the same points in the same order as evaluated afresh with the
    // lateral excluded. (A hub of 5,000 twigs: the contour stage spent most of its time
    // evaluating the whole section once per candidate lateral.)
    for (const auto& [edges, pts] : {std::pair(&cut_a_, &pts_a_), std::pair(&cut_b_, &pts_b_)}) {
      std::size_t at = 0;
      for (const CutEdge& e : *edges) {
        const std::size_t count = tables_.cand_begin[e.node.idx() + 1] - tables_.cand_begin[e.node.idx()];
        if (!tables_.in_subtree(e.node, lateral)) pts_rest_.append(*pts, at, at + count);
        at += count;
      }
    }
  } else {
    excluded_.push_back(lateral);
    cut_n_.clear();
    cut(s_.children[fork.idx()][0], fork_base, u, cut_n_);
    cut(s_.children[fork.idx()][1], fork_base, u, cut_n_);
    evaluate_cut(cut_n_, pts_rest_);
    excluded_.pop_back();
  }
  if (pts_rest_.point.empty()) return false;
  const double threshold_here = threshold(fork), enough = min_clearance(fork);
  if (!(gap(pts_l_.point, pts_rest_.point, threshold_here, threshold_here) > threshold_here)) return false;
  const NodeId y = s_.parent[lateral.idx()];
  const double reach = u + 2.0 * s_.radius[y.idx()];
  return cone_clearance(pts_l_, s_.children[y.idx()][0], base, reach, enough) > enough &&
         cone_clearance(pts_rest_, lateral, base, reach, enough) > enough;
}

std::vector<std::uint8_t> Walker::lateral_sides(NodeId lateral, std::uint32_t loop) const {
  const std::uint32_t base = f_.node_begin[lateral.idx()];
  return loop_sides(loop, 0, [&](auto&& side_of) {
    for (std::uint32_t j = 0; j < f_.count(lateral); ++j) side_of(f_.strand[base + j], 1);
  });
}

void Walker::walk(const Task& task, Fragment& fragment, ContourSet& store) {
  out_ = &fragment.part;
  store_ = &store;
  fragment.store = &store;
  fragment.loop_first = static_cast<std::uint32_t>(store.loop_count());
  fragment.vertex_first = static_cast<std::uint32_t>(store.point.size());
  out_->tubes.assign(1, Tube{});
  constexpr std::uint32_t tube = 0;
  const NodeId anchor = task.anchor;
  out_->tubes[tube].branch = NodeId(tables_.branch[task.x.idx()]);
  const double anchor_distance = anchor.valid() ? tables_.root_distance[anchor.idx()] : 0.0;
  anchor_distance_ = anchor_distance;
  excluded_ = task.excluded;
  // The tube's first loop: the root's section, or the split section above the anchor.
  double last = task.split;
  double d = 0;
  NodeId cur = task.x;
  double cur_base = 0;  // distance above the anchor where cur's edge starts
  if (task.fused) {
    // The rest of anchor's fused section, from where a lateral inside it split off: its first
    // loop is around both bundles there; the walk goes on at the fork (its edge ending at
    // distance 0 above the anchor).
    split_gap_at(anchor, 0.0, task.split);
    fuse_points();
    const SliceGeometry g = fused_geometry();
    add_loop(pts_, g, LoopKind::split, anchor_distance + task.split, tube);
    d = task.split + step_at(g);
    cur = anchor;
    cur_base = -len(anchor);
  } else if (!anchor.valid()) {
    pts_.clear();
    evaluate(task.x, 1.0, pts_);
    const SliceGeometry g = edge_geometry(task.x, 1.0);
    add_loop(pts_, g, LoopKind::plain, 0.0, tube);
    d = step_at(g);
  } else {
    std::vector<CutEdge> edges;
    cut(task.x, 0.0, task.split, edges);
    pts_.clear();
    evaluate_cut(edges, pts_);
    const SliceGeometry g = cut_geometry(edges);
    add_loop(pts_, g, LoopKind::split, anchor_distance + task.split, tube);
    d = task.split + step_at(g);
  }
  auto end_of = [&](NodeId n, double base) { return base + (s_.parent[n.idx()].valid() ? len(n) : 0.0); };

  for (;;) {
    const double end = end_of(cur, cur_base);
    if (d < end) {
      const double t = (d - cur_base) / len(cur);
      const SliceGeometry g = edge_geometry(cur, t);
      const double step = step_at(g);
      if (s_.is_tip(cur) && end - d < 0.35 * step) {
        d = end;  // close enough: the tip's own section comes next
        continue;
      }
      pts_.clear();
      evaluate(cur, t, pts_);
      const std::uint32_t loop = add_loop(pts_, g, LoopKind::plain, anchor_distance + d, tube);
      last = d;
      d += ring_edge() > 0 ? step_at(g, loop) : step;
      continue;
    }
    // d has reached node cur.
    if (s_.is_tip(cur)) {
      if (last < end - 1e-12 * std::max(1.0, end)) {
        pts_.clear();
        evaluate(cur, 1.0, pts_);
        add_loop(pts_, edge_geometry(cur, 1.0), LoopKind::tip, anchor_distance + end, tube);
      }
      return;  // the tube ends at a tip: capped by the meshing stage
    }
    if (!fork_here(cur)) {
      const NodeId next = s_.children[cur.idx()][0];
      // A bend at cur: the strip between the loops on either side is a straight chord and
      // cuts the corner; on a thin twig sliced coarsely it can leave the node (and the
      // skeleton) outside the surface. Then the node's own section becomes a loop.
      const NodeId parent = s_.parent[cur.idx()];
      if (parent.valid() && d > end && end - last > 1e-12) {
        const dvec3 p = s_.position[cur.idx()];
        const dvec3 u = p - s_.position[parent.idx()], v = s_.position[next.idx()] - p;
        const double lu = glm::length(u), lv = glm::length(v);
        if (lu > 0 && lv > 0) {
          const double a = end - last, b = std::min(d - end, lv);
          const dvec3 from = p - u * (a / lu), to = p + v * (b / lv);
          if (chord_miss(p, from, to) > p_.max_corner_cut * s_.radius[cur.idx()]) {
            const SliceGeometry g = edge_geometry(cur, 1.0);
            pts_.clear();
            evaluate(cur, 1.0, pts_);
            add_loop(pts_, g, LoopKind::plain, anchor_distance + end, tube);
            last = end;
            d = std::max(d, end + 0.5 * step_at(g));
          }
        }
      }
      cur_base = end;
      cur = next;
      continue;
    }

    // A fork: fused slices until the two bundles split.
    const NodeId fork = cur;
    const double fork_base = end;
    {
      // Keep the last loop below the split close to the fork (the pants stay short even when
      // the edge below was sliced coarsely): a loop at the fork's own section.
      const SliceGeometry g = edge_geometry(fork, 1.0);
      const double near = slice_step(fork) * g.radius;
      if (end - last > 0.5 * near && !out_->tubes[tube].loops.empty()) {
        pts_.clear();
        evaluate(fork, 1.0, pts_);
        add_loop(pts_, g, LoopKind::plain, anchor_distance + end, tube);
        last = end;
      }
      // Slices above the fork start at the fine, radius-based step, however coarsely the edge
      // below was sliced.
      d = std::max(last + 0.5 * near, std::min(d, end + near));  // (the fork may lie below `last`)
    }
    const NodeId a = s_.children[fork.idx()][0];
    const NodeId b = s_.children[fork.idx()][1];
    // Bundles still touching where the shorter child's segment ends (its next fork or its tip;
    // collar nodes and other single-child nodes do not end a segment), and at least
    // min_fused_length x the fork's radius above it, are split there.
    auto segment = [&](NodeId c) {
      double l = len(c);
      while (s_.child_count(c) == 1) {
        c = s_.children[c.idx()][0];
        l += len(c);
      }
      return l;
    };
    const double shorter_end =
        fork_base + std::max(std::min(segment(a), segment(b)), p_.min_fused_length * s_.radius[fork.idx()]);
    const Leave leave_a = leave_by(fork, a, b, fork_base), leave_b = leave_by(fork, b, a, fork_base);
    const double stub_end = std::min(leave_a.stub, leave_b.stub);
    const double turn_end = std::min(leave_a.turn, leave_b.turn);
    bool absorbed = false;
    for (;;) {
      const double g_ab = split_gap_at(fork, fork_base, d);
      if (pts_a_.point.empty() || pts_b_.point.empty()) {
        if (pts_a_.point.empty() && pts_b_.point.empty()) return;  // everything ended: cap the last loop
        // One bundle ended (its tips) before separating: the other carries on alone.
        out_->stats.warnings.add("absorbed_bundle", "branch ended before separating from its sibling; absorbed",
                                 s_.describe(pts_b_.point.empty() ? b : a));
        cur = pts_b_.point.empty() ? a : b;
        cur_base = fork_base;
        absorbed = true;
        break;
      }
      const bool separated = separated_now();
      // A forced split asks less of the points (loosely apart) but as much of the surfaces as
      // a split does: each bundle clear of the other subtree's round cones. Branches whose
      // cones still overlap (near-parallel siblings running together) stay fused, as one
      // loop around both, instead of two tubes through each other. (Self-intersecting pairs
      // on the samples, particle seeds 1-3: 1,806 in all with the point test alone, 936 with
      // the cone test; agraf 302 -> 95, callistemon 47 -> 8 at seed 1.)
      const SliceGeometry g = fused_geometry();
      const double step = step_at(g);
      // A stub still inside the section at the last slice before its tip splits there, cones
      // clear or not: absorbed, its tip would lie outside the mesh, and the section's loops
      // would flatten it into a flap. (boutdenoylum2, particle seeds 1-3: thick nodes inside
      // 135 / 133 / 135 -> 138 / 136 / 138 of 144; fidelity p95 0.186 / 0.186 / 0.189 ->
      // 0.189 / 0.179 / 0.186; self-intersecting pairs on the samples x seeds 1-3 272 -> 277.)
      const bool forced =
          !separated && ((d >= shorter_end && g_ab > 0.5 * spacing_ && surfaces_clear()) || d + step >= std::min(stub_end, turn_end));
      // A split at least a quarter of a step above the section's last loop; at a fork thinner
      // than the particles' neighbour distance, a quarter of the fine step. (A quarter of the
      // step along the edge, up to a quarter of the edge, held thin twigs' splits up to 9 mm
      // above where their bundles came apart, a web between them: conifer grow seed 1, whose
      // twigs are 1.5 mm thick against a neighbour distance of 5.7 mm, splits 4.9 -> 3.8
      // radii above their forks at the median, 7.5 -> 5.2 at the 90th percentile. At every
      // fork, small_pine kept pairs at particle seeds 3 and 4. Measuring the split gap in the
      // fork's radius where that is smaller than the neighbour distance split them earlier
      // still, 2.6 radii at the median, but the bench tree's fold repair then found 10,306
      // pairs instead of 1,922 and the fork retry ran 9 times.)
      const double min_sep = 0.25 * (s_.radius[fork.idx()] < spacing_ ? fine_step(g) : step);
      // The lateral of a fork inside the section opens its own tube at `split`.
      auto split_nested = [&](NodeId lateral, double nested_base, double split, bool forced_here) {
        const NodeId y = s_.parent[lateral.idx()];
        Junction& j = open_junction(fragment, y, tube, split - nested_base);
        j.forced = forced_here;
        j.lower_side = lateral_sides(lateral, j.lower);
        // The fused section goes on without the lateral: distances relative to `fork`.
        const double abs_split = anchor_distance + split;
        Task rest{fork, s_.children[fork.idx()][0], abs_split - tables_.root_distance[fork.idx()], true, excluded_};
        rest.excluded.push_back(lateral);
        fragment.next[0] = std::move(rest);
        fragment.next[1] =
            Task{y, lateral, abs_split - tables_.root_distance[y.idx()], false, excluded_within(lateral)};
        ++out_->stats.nested_splits;
        if (forced_here) ++out_->stats.forced_splits;
      };
      if (separated || forced) {
        double split = d;
        if (separated) {
          split = bisect(std::max(last, fork_base), d, [&](double u) {
            split_gap_at(fork, fork_base, u);
            return separated_now();
          });
        } else {
          ++out_->stats.forced_splits;
          out_->stats.warnings.add(
              "forced_split",
              "bundles still touching where the shorter child edge ends, or just below a stub's tip; split there",
              s_.describe(fork));
        }
        split = std::min(d, std::max(split, last + min_sep));
        // A child turning between the last loop and the split (by more than max_corner_cut
        // allows) splits at the turning node, so its tube starts with the node's own section
        // instead of the junction cutting the corner, where the bundles are at least loosely
        // apart there (a forced split's point test; its cone test is left out, as for a stub's
        // tip: the node would lie outside the mesh). Closer, the two tubes would start inside
        // each other.
        if (const double corner = next_corner(fork, fork_base, last + min_sep, split); corner < split) {
          const double g_corner = split_gap_at(fork, fork_base, corner);
          if (!pts_a_.point.empty() && !pts_b_.point.empty() && (g_corner > 0.5 * spacing_ || separated_now()))
            split = corner;
        }
        // After a coarse step (along a long straight edge) the bundles may have been apart
        // for most of it: one more fused loop a fine step below the split, where they still
        // touch, keeps the crotch short.
        if (separated) {
          const double fine = fine_step(g), below = split - fine;
          if (below - std::max(last, fork_base) > 0.5 * fine) {
            split_gap_at(fork, fork_base, below);
            if (!pts_a_.point.empty() && !pts_b_.point.empty() && !separated_now()) {
              fuse_points();
              add_loop(pts_, fused_geometry(), LoopKind::fused, anchor_distance + below, tube);
              last = below;
            }
          }
        }
        // The junction: the tube's last loop below; each child's tube starts with its own
        // section at the split (the junction's upper loops, linked on assembly).
        Junction& j = open_junction(fragment, fork, tube, split - fork_base);
        j.forced = forced;
        j.lower_side = bundle_sides(fork, j.lower);
        fragment.next[0] = Task{fork, a, split - fork_base, false, excluded_within(a)};
        fragment.next[1] = Task{fork, b, split - fork_base, false, excluded_within(b)};
        return;
      }
      // Still together. A lateral of a fork inside the section (a whorl: forks a tiny step
      // apart) that has come apart from the rest splits off first, so it does not stay in the
      // section's loops (or the child tube's split loop) far out along its own edge.
      double nested_base = 0;
      const NodeId lateral = nested_split(fork, d, nested_base);
      if (lateral.valid()) {
        const double apart = bisect(std::max(last, nested_base), d,
                                    [&](double u) { return nested_apart(fork, fork_base, lateral, nested_base, u); });
        split_nested(lateral, nested_base, std::min(d, std::max(apart, last + min_sep)), false);
        return;
      }
      // A lateral inside the section whose segment ends in a stub's tip before the next slice
      // splits off here, apart or not, as the fork's own children do: carried on, its tip
      // would be missing from the mesh (a twig of a whorl running inside the trunk, then out).
      double due_base = 0;
      const NodeId due = nested_due(fork, d, step, due_base);
      if (due.valid()) {
        out_->stats.warnings.add("forced_split",
                                 "bundles still touching where the shorter child edge ends, or just below a stub's tip; split there",
                                 s_.describe(s_.parent[due.idx()]));
        split_nested(due, due_base, d, true);
        return;
      }
      // One loop around both bundles.
      fuse_points();
      add_loop(pts_, g, LoopKind::fused, anchor_distance + d, tube);
      last = d;
      d += step;
    }
    if (absorbed) continue;
  }
}

/// Concatenates the fragments depth-first from the root tube (main child before lateral), so
/// tubes are numbered parents first and the result does not depend on the walks' order.
ContourSet assemble(Fragment& root) {
  ContourSet out;
  out.loop_begin.assign(1, 0);
  out.tubes.emplace_back();
  struct Item {
    Fragment* fragment;
    std::uint32_t tube;
    std::uint32_t start_junction;
    std::size_t side;  // which upper loop of start_junction the tube's first loop is
  };
  // The fragments in depth-first order (main child first) with where their loops and
  // vertices go; tubes, junctions and figures as they come. The loops and vertices are then
  // copied to their places in parallel (on the large grown tree 1.7 M vertices and 136 k
  // loops: one thread copying them took a twentieth of the stage).
  struct Placed {
    Fragment* fragment;
    std::uint32_t loop_offset, vertex_offset;
  };
  std::vector<Placed> placed;
  std::uint32_t loops = 0, vertices = 0;
  std::vector<Item> stack{{&root, 0, kNone, 0}};
  while (!stack.empty()) {
    const Item item = stack.back();
    stack.pop_back();
    Fragment& fr = *item.fragment;
    ContourSet& part = fr.part;
    const std::uint32_t loop_offset = loops;
    placed.push_back({&fr, loops, vertices});
    loops += fr.loop_end - fr.loop_first;
    vertices += fr.store->loop_begin[fr.loop_end] - fr.vertex_first;
    {
      Tube& t = out.tubes[item.tube];
      t.branch = part.tubes[0].branch;
      t.start_junction = item.start_junction;
      for (const std::uint32_t l : part.tubes[0].loops) t.loops.push_back(loop_offset + (l - fr.loop_first));
      if (item.start_junction != kNone) out.junctions[item.start_junction].upper[item.side] = t.loops.front();
    }
    out.stats.evaluated_points += part.stats.evaluated_points;
    out.stats.fused_loops += part.stats.fused_loops;
    out.stats.forced_splits += part.stats.forced_splits;
    out.stats.nested_splits += part.stats.nested_splits;
    out.stats.boundary_fallbacks += part.stats.boundary_fallbacks;
    out.stats.warnings.merge(part.stats.warnings);
    if (!fr.has_junction) continue;
    Junction j = std::move(fr.junction);
    j.lower = loop_offset + (j.lower - fr.loop_first);
    j.lower_tube = item.tube;
    const auto junction = static_cast<std::uint32_t>(out.junctions.size());
    const auto first_child = static_cast<std::uint32_t>(out.tubes.size());
    j.upper_tubes = {first_child, first_child + 1};
    out.tubes.resize(out.tubes.size() + 2);
    out.tubes[item.tube].end_junction = junction;
    out.junctions.push_back(std::move(j));
    // Lateral first onto the stack so the main child's tube comes next.
    stack.push_back({fr.child[1], first_child + 1, junction, 1});
    stack.push_back({fr.child[0], first_child, junction, 0});
  }
  out.point.resize(vertices);
  out.strand.resize(vertices);
  out.loop_begin.resize(std::size_t(loops) + 1);
  out.loop_begin[loops] = vertices;
  out.loop_node.resize(loops);
  out.loop_t.resize(loops);
  out.loop_distance.resize(loops);
  out.loop_center.resize(loops);
  out.loop_frame.resize(loops);
  out.loop_radius.resize(loops);
  out.loop_kind.resize(loops);
  // Each fragment's tube and figures are released once copied, by the thread that copied
  // them (freed one by one after the stage, they took a serial 15 ms of the large grown tree).
  tbb::parallel_for(std::size_t{0}, placed.size(), [&](std::size_t k) {
    const Fragment& fr = *placed[k].fragment;
    const ContourSet& st = *fr.store;
    const std::uint32_t lo = placed[k].loop_offset, vo = placed[k].vertex_offset;
    const std::uint32_t l0 = fr.loop_first, l1 = fr.loop_end, v0 = fr.vertex_first, v1 = st.loop_begin[l1];
    auto copy = [](const auto& from, std::size_t begin, std::size_t end, auto& to, std::size_t at) {
      std::copy(from.begin() + std::ptrdiff_t(begin), from.begin() + std::ptrdiff_t(end),
                to.begin() + std::ptrdiff_t(at));
    };
    copy(st.point, v0, v1, out.point, vo);
    copy(st.strand, v0, v1, out.strand, vo);
    for (std::uint32_t l = l0; l < l1; ++l) out.loop_begin[lo + (l - l0)] = vo + (st.loop_begin[l] - v0);
    copy(st.loop_node, l0, l1, out.loop_node, lo);
    copy(st.loop_t, l0, l1, out.loop_t, lo);
    copy(st.loop_distance, l0, l1, out.loop_distance, lo);
    copy(st.loop_center, l0, l1, out.loop_center, lo);
    copy(st.loop_frame, l0, l1, out.loop_frame, lo);
    copy(st.loop_radius, l0, l1, out.loop_radius, lo);
    copy(st.loop_kind, l0, l1, out.loop_kind, lo);
    placed[k].fragment->part = ContourSet{};
  });
  out.stats.loops = out.loop_count();
  out.stats.loop_vertices = out.point.size();
  return out;
}

/// The plane a loop's points lie in (near a fork not across its frame's tangent): the points'
/// centroid and the polygon's area normal (Newell), towards the tips (loops are counter-
/// clockwise seen from there).
std::pair<dvec3, dvec3> loop_plane(const ContourSet& c, std::uint32_t l) {
  const std::uint32_t b = c.loop_begin[l], e = c.loop_begin[l + 1];
  dvec3 centre(0), normal(0);
  for (std::uint32_t v = b; v < e; ++v) {
    const dvec3& p = c.point[v];
    const dvec3& q = c.point[v + 1 < e ? v + 1 : b];
    centre += p;
    normal += glm::cross(p - c.loop_center[l], q - c.loop_center[l]);
  }
  centre /= double(std::max<std::uint32_t>(1, e - b));
  if (glm::dot(normal, c.loop_frame[l].tangent) < 0) normal = -normal;
  return {centre, normalize_or(normal, c.loop_frame[l].tangent)};
}

/// Whether loops a (towards the root) and b of one tube cross, more than `tol` x the larger
/// radius: `strict`, a point of b behind a's plane or a point of a in front of b's (the strip
/// between them would fold back); otherwise only where each has points on both sides of the
/// other's plane (their discs intersect). A tube's first loop lies in its fork's section, tilted
/// against the branch (a drooping lateral leaves below it): it is compared the second way.
bool loops_cross(const ContourSet& c, std::uint32_t a, std::uint32_t b, double tol, bool strict) {
  const double limit = tol * std::max(c.loop_radius[a], c.loop_radius[b]);
  // Points of `other` behind (-1) and in front of (+1) the plane of `plane`.
  auto sides = [&](std::uint32_t plane, std::uint32_t other) {
    const auto [o, n] = loop_plane(c, plane);
    std::pair<bool, bool> s{false, false};
    for (std::uint32_t v = c.loop_begin[other]; v < c.loop_begin[other + 1]; ++v) {
      const double h = glm::dot(c.point[v] - o, n);
      s.first = s.first || h < -limit;
      s.second = s.second || h > limit;
    }
    return s;
  };
  const auto [b_behind, b_ahead] = sides(a, b);
  const auto [a_behind, a_ahead] = sides(b, a);
  if (strict) return b_behind || a_ahead;
  return b_behind && b_ahead && a_behind && a_ahead;
}

/// Leaves out interior loops of each tube until consecutive loops do not cross: a loop crossing
/// the last kept one is skipped; the tube's last loop (a junction's or a cap's) is kept, and
/// kept loops crossing it are dropped instead. Loops more than `reach` radii apart along the
/// branch do not count as crossing. The first and last loops always stay. The loops
/// left out are then removed from the set (every loop stays in exactly one tube).
void uncross_loops(ContourSet& c, double tol, double reach) {
  std::vector<std::uint8_t> dropped(c.loop_count(), 0);
  for (Tube& t : c.tubes) {
    if (t.loops.size() < 3) continue;
    std::vector<std::uint32_t> kept{t.loops.front()};
    auto cross = [&](std::uint32_t a, std::uint32_t b) {
      const double apart = std::abs(c.loop_distance[b] - c.loop_distance[a]);
      if (apart > reach * std::max(c.loop_radius[a], c.loop_radius[b])) return false;
      return loops_cross(c, a, b, tol, a != t.loops.front());
    };
    for (std::size_t k = 1; k + 1 < t.loops.size(); ++k) {
      if (!cross(kept.back(), t.loops[k])) kept.push_back(t.loops[k]);
    }
    while (kept.size() > 1 && cross(kept.back(), t.loops.back())) kept.pop_back();
    kept.push_back(t.loops.back());
    if (kept.size() == t.loops.size()) continue;
    for (const std::uint32_t l : t.loops) dropped[l] = 1;
    for (const std::uint32_t l : kept) dropped[l] = 0;
    c.stats.uncrossed_loops += t.loops.size() - kept.size();
    t.loops = std::move(kept);
  }
  if (c.stats.uncrossed_loops == 0) return;
  // Compact: loops and their vertices in order, without the dropped ones.
  std::vector<std::uint32_t> renumber(c.loop_count(), UINT32_MAX);
  std::uint32_t nl = 0, nv = 0;
  for (std::uint32_t l = 0; l < c.loop_count(); ++l) {
    if (dropped[l]) continue;
    renumber[l] = nl;
    const std::uint32_t b = c.loop_begin[l], e = c.loop_begin[l + 1];
    for (std::uint32_t v = b; v < e; ++v) {
      c.point[nv + (v - b)] = c.point[v];
      c.strand[nv + (v - b)] = c.strand[v];
    }
    c.loop_begin[nl] = nv;
    nv += e - b;
    c.loop_node[nl] = c.loop_node[l];
    c.loop_t[nl] = c.loop_t[l];
    c.loop_distance[nl] = c.loop_distance[l];
    c.loop_center[nl] = c.loop_center[l];
    c.loop_frame[nl] = c.loop_frame[l];
    c.loop_radius[nl] = c.loop_radius[l];
    c.loop_kind[nl] = c.loop_kind[l];
    ++nl;
  }
  c.loop_begin[nl] = nv;
  c.loop_begin.resize(std::size_t(nl) + 1);
  c.point.resize(nv);
  c.strand.resize(nv);
  c.loop_node.resize(nl);
  c.loop_t.resize(nl);
  c.loop_distance.resize(nl);
  c.loop_center.resize(nl);
  c.loop_frame.resize(nl);
  c.loop_radius.resize(nl);
  c.loop_kind.resize(nl);
  for (Tube& t : c.tubes) {
    for (std::uint32_t& l : t.loops) l = renumber[l];
  }
  for (Junction& j : c.junctions) {
    j.lower = renumber[j.lower];
    for (std::uint32_t& u : j.upper) u = renumber[u];
  }
  c.stats.loops = c.loop_count();
  c.stats.loop_vertices = c.point.size();
  c.stats.fused_loops = std::size_t(std::count(c.loop_kind.begin(), c.loop_kind.end(), LoopKind::fused));
}

}  // namespace

void validate_params(const ContourParams& p) { check_params(p); }

ContourSet compute_contours(const Skeleton& skeleton, const ParticleField& field, const StrandSet& strands,
                            const ContourParams& params, const ProgressFn& progress) {
  return compute_contours(skeleton, field, strands, params, {}, progress);
}

ContourSet compute_contours(const Skeleton& skeleton, const ParticleField& field, const StrandSet& strands,
                            const ContourParams& params, std::span<const LocalContourScale> local,
                            const ProgressFn& progress) {
  validate_params(params);
  const ParamChecker check{"contours"};
  for (const LocalContourScale& l : local) {
    check.positive(l.split_gap, "local split_gap factor");
    check.non_negative(l.fork_transition, "local fork_transition factor");
    check.positive(l.slice_step, "local slice_step factor");
  }
  SM_CHECK(field.node_count() == skeleton.size(), "particle field does not match the skeleton");
  SM_CHECK(strands.point.size() == field.position.size(), "strand set does not match the particle field");
  Stopwatch clock;
  if (skeleton.empty()) {
    ContourSet out;
    out.loop_begin.assign(1, 0);
    return out;
  }
  const Tables tables(skeleton, field, strands, params, local);
  const double t_tables = clock.lap();

  // Walk the tubes as tasks: each junction spawns its two child tubes.
  std::size_t forks = 0;
  for (std::size_t i = 0; i < skeleton.size(); ++i) forks += skeleton.is_fork(NodeId(i));
  const double total = double(2 * forks + 1);
  std::atomic<std::size_t> done{0};
  std::mutex progress_mutex;
  tbb::concurrent_vector<std::unique_ptr<Fragment>> fragments;
  // The loops go to one store per thread, copied out in order by assemble (a set of arrays
  // per tube, allocated and freed one by one: 65 k tubes of the large grown tree, whose frees
  // alone took 16-20 ms of the assembly on 2 threads).
  tbb::enumerable_thread_specific<ContourSet> stores([] {
    ContourSet store;
    store.loop_begin.assign(1, 0);
    return store;
  });
  tbb::task_group group;
  std::function<void(Fragment*, Task)> spawn = [&](Fragment* fragment, Task task) {
    group.run([&, fragment, task] {
      ContourSet& store = stores.local();
      {
        // (A walk's loops must be contiguous in its store: no walk may start on this thread
        // before it ends.)
        thread_local bool walking = false;
        SM_CHECK(!walking, "contour walks interleaved on one thread");
        struct Walking {
          Walking() { walking = true; }
          ~Walking() { walking = false; }
          Walking(const Walking&) = delete;
          Walking& operator=(const Walking&) = delete;
        } const guard;
        Walker(tables).walk(task, *fragment, store);
      }
      fragment->loop_end = static_cast<std::uint32_t>(store.loop_count());
      const std::size_t n = ++done;
      if (progress && (n & 63) == 0) {
        const std::lock_guard lock(progress_mutex);
        progress("contours", std::min(1.0, double(n) / total));
      }
      if (!fragment->has_junction) return;
      for (std::size_t k = 0; k < 2; ++k) {
        fragment->child[k] = fragments.push_back(std::make_unique<Fragment>())->get();
        spawn(fragment->child[k], fragment->next[k]);
      }
    });
  };
  fragments.push_back(std::make_unique<Fragment>());
  Fragment* root = fragments.front().get();
  spawn(root, Task{NodeId{}, Skeleton::root(), 0.0, false, {}});
  group.wait();
  const double t_walk = clock.lap();

  ContourSet out = assemble(*root);
  if (params.uncross_loops) uncross_loops(out, params.uncross_tolerance, params.uncross_reach);
  out.stats.timings.add("tables", t_tables);
  out.stats.timings.add("slicing", t_walk);
  out.stats.timings.add("assembly", clock.lap());
  return out;
}

}  // namespace sm
