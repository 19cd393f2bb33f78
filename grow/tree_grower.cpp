// Self-organizing trees and space colonization.
//
// Growth follows Clasping Trees §3 (buds with a perception cone of radius and apex angle,
// terminal and lateral buds, branching angle β and phyllotaxis φ, inertia μ, occupancy radius,
// one internode per bud and metamer) and Pałubicki et al. 2009 as summarized in Tomasson 2022
// §3: the extended Borchert–Honda rule v_m = v·λQ_m / (λQ_m + (1−λ)Q_l), v_l = v·(1−λ)Q_l /
// (…), pipe-model diameters d^n = d1^n + d2^n (Clasping Trees eq. 1 with exponent 1.8–2.8,
// Tomasson 2022 §3.2), and shadow propagation in a voxel grid, Δs = a·b^(−q) in a pyramid below
// every new node (Tomasson 2022 §3.3). Space colonization (Runions et al. 2007) is the same
// loop with a full sphere as perception volume, no resource model, and one new internode per
// node and iteration; Clasping Trees uses it for roots. docs/growers.md lists the references.
//
// Randomness (core/rng.h): every node owns purpose-specific streams derived from a key that
// depends only on its place in the topology (the parent's key and whether it is a
// continuation or a lateral), never on the order in which nodes were created.
//
// What the papers leave open and the strand mesher needs (issue 6): a binary tree
// (one lateral bud per node), bounded bends and branching angles, and edges that are long
// relative to the radius. The cleanup after growth merges chain nodes on thick branches and
// prunes thin laterals crowded onto thick axes; both are counted in the stats.

#include "grow/tree_grower.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <string>

#include <nanoflann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/errors.h"
#include "core/rng.h"
#include "skeleton/build.h"

namespace sm {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// Stream kinds (one generator per purpose, so adding a purpose later does
// not shift the numbers of the others).
constexpr std::uint64_t kTreeKey = 0x7EEE;        // root key
constexpr std::uint64_t kPointsStream = 0x90175;  // attraction points
constexpr std::uint64_t kDirectionStream = 1;     // jitter of a node's internode direction
constexpr std::uint64_t kPhylloStream = 2;        // lateral bud azimuth of a node

std::string fmt(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

/// nanoflann adaptor over a vector of points.
struct Cloud {
  std::vector<dvec3> pts;
  [[nodiscard]] std::size_t kdtree_get_point_count() const { return pts.size(); }
  [[nodiscard]] double kdtree_get_pt(std::size_t i, std::size_t d) const {
    return pts[i][static_cast<glm::length_t>(d)];
  }
  template <class B>
  bool kdtree_get_bbox(B&) const {
    return false;
  }
};
using KdTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 3, std::uint32_t>;

/// Rotates unit d by `angle` towards the azimuth `phi` around it (phi measured from `side`).
dvec3 deflect(const dvec3& d, const dvec3& side, double angle, double phi) {
  const dvec3 u = normalize_or(side - glm::dot(side, d) * d, any_perpendicular(d));
  const dvec3 v = glm::cross(d, u);
  return glm::normalize(std::cos(angle) * d + std::sin(angle) * (std::cos(phi) * u + std::sin(phi) * v));
}

double angle_between(const dvec3& a, const dvec3& b) {
  return std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0));
}

/// Distance between segments [p1, q1] and [p2, q2].
double segment_distance(const dvec3& p1, const dvec3& q1, const dvec3& p2, const dvec3& q2) {
  double s = 0, t = 0;
  closest_segment_params(p1, q1, p2, q2, s, t);
  return glm::length((p1 + s * (q1 - p1)) - (p2 + t * (q2 - p2)));
}

/// The unit vector in the plane of `ref` and `w` (on w's side) whose angle from ref is
/// angle(ref, w) clamped into [lo, hi] (radians).
dvec3 clamp_angle(const dvec3& w, const dvec3& ref, double lo, double hi) {
  const double a = angle_between(w, ref);
  if (a >= lo && a <= hi) return w;
  const dvec3 u = normalize_or(w - glm::dot(w, ref) * ref, any_perpendicular(ref));
  const double t = std::clamp(a, lo, hi);
  return glm::normalize(std::cos(t) * ref + std::sin(t) * u);
}

/// One search hit: attraction point id and squared distance.
struct Hit {
  std::uint32_t point;
  double d2;
};

/// A bud: a node and a slot (0 terminal / continuation, 1 lateral).
struct Bud {
  std::uint32_t node;
  std::uint32_t slot;
};

class TreeGrower {
 public:
  TreeGrower(const GrowerParams& p, const ProgressFn& progress) : p_(p), progress_(progress) {}

  GrowResult run() {
    Stopwatch clock;
    GrowResult result;
    stats_ = &result.stats;
    report("scatter", 0);
    const Volume volume(p_.crown);
    points_ = scatter_points(volume, p_.attraction_points, derive_seed(p_.seed, kPointsStream));
    alive_.assign(points_.size(), 1);
    live_ = points_.size();
    best_d2_.assign(points_.size(), 0);
    best_bud_.assign(points_.size(), kNone);
    stamp_.assign(points_.size(), 0);
    stats_->attraction_points = points_.size();
    rebuild_index();
    if (p_.shadow) init_shadow(volume);
    const dvec3 lo = volume.lower(), hi = volume.upper();
    const dvec3 t = glm::normalize(p_.trunk_direction);
    crown_reach_ =
        std::max(lo.x * t.x, hi.x * t.x) + std::max(lo.y * t.y, hi.y * t.y) + std::max(lo.z * t.z, hi.z * t.z);
    stats_->timings.add("scatter", clock.lap());

    grow();
    stats_->grown_nodes = pos_.size();
    stats_->points_reached = points_.size() - live_;
    stats_->timings.add("grow", clock.lap());

    report("cleanup", 0);
    cleanup();
    stats_->timings.add("cleanup", clock.lap());
    untangle();
    stats_->timings.add("collisions", clock.lap());
    result.skeleton = emit();
    {
      // Branches the cleanup could not keep apart are swung apart the way build_skeleton
      // does for imported skeletons (and nothing else: no collars, which would break the
      // pipe model at forks), so the grown tree needs no repair when it is read back.
      SkeletonParams sp;
      sp.collar_ratio = 0;
      sp.merge_inner_branches = false;
      sp.max_lateral_angle = 0;
      const SkeletonResult clean = build_skeleton(result.skeleton, sp);
      if (clean.report.branch_collisions > 0) {
        result.skeleton = raw_from_skeleton(clean.skeleton, result.skeleton.source);
        result.skeleton.grown = true;
      }
    }
    stats_->timings.add("separation", clock.lap());
    report("cleanup", 1);
    result.attraction_points = std::move(points_);
    return result;
  }

 private:
  // ---- progress ----------------------------------------------------------------------------
  void report(const char* phase, double f) {
    if (progress_) progress_(phase, std::clamp(f, 0.0, 1.0));
  }

  // ---- attraction points -------------------------------------------------------------------
  /// Indexes the live points only; called again when many have been removed, so queries do
  /// not wade through dead ones.
  void rebuild_index() {
    index_.reset();
    cloud_.pts.clear();
    indexed_.clear();
    for (std::uint32_t i = 0; i < points_.size(); ++i) {
      if (alive_[i]) {
        cloud_.pts.push_back(points_[i]);
        indexed_.push_back(i);
      }
    }
    if (!indexed_.empty()) {
      index_ = std::make_unique<KdTree>(3, cloud_, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    }
  }

  /// Live points within `radius` of q, sorted by point id (so sums do not depend on the
  /// k-d tree layout). `buffer` is scratch space.
  void query(const dvec3& q, double radius, std::vector<std::pair<std::uint32_t, double>>& buffer,
             std::vector<Hit>& out, bool& any_live) const {
    out.clear();
    any_live = false;
    if (!index_) return;
    buffer.clear();
    const double qp[3] = {q.x, q.y, q.z};
    index_->radiusSearch(qp, radius * radius, buffer, nanoflann::SearchParams(32, 0.f, false));
    for (const auto& [k, d2] : buffer) {
      const std::uint32_t id = indexed_[k];
      if (alive_[id]) out.push_back({id, d2});
    }
    any_live = !out.empty();
    std::sort(out.begin(), out.end(), [](const Hit& a, const Hit& b) { return a.point < b.point; });
  }

  void kill_near(const dvec3& q) {
    std::vector<std::pair<std::uint32_t, double>> buffer;
    std::vector<Hit> hits;
    bool any = false;
    query(q, p_.occupancy_radius, buffer, hits, any);
    for (const Hit& h : hits) {
      alive_[h.point] = 0;
      --live_;
    }
  }

  // ---- shadow propagation (Tomasson 2022 §3.3) ---------------------------------------------
  void init_shadow(const Volume& volume) {
    cell_ = p_.shadow_voxel_size > 0 ? p_.shadow_voxel_size : 2.0 * p_.internode_length;
    const double margin = p_.perception_radius + 2 * cell_;
    const dvec3 lo = glm::min(volume.lower(), dvec3(0)) - dvec3(margin);
    const dvec3 hi = glm::max(volume.upper(), dvec3(0)) + dvec3(margin);
    grid_origin_ = lo;
    std::size_t total = 1;
    for (int a = 0; a < 3; ++a) {
      grid_dims_[static_cast<std::size_t>(a)] = static_cast<int>(std::ceil((hi[a] - lo[a]) / cell_)) + 1;
      total *= static_cast<std::size_t>(grid_dims_[static_cast<std::size_t>(a)]);
    }
    if (total > (64u << 20)) {
      throw InvalidInputError("shadow_voxel_size: " + fmt(cell_) + " m gives " + std::to_string(total) +
                              " shadow voxels, more than 64M; raise it");
    }
    shade_.assign(total, 0.0);
  }

  [[nodiscard]] bool cell_of(const dvec3& q, int& i, int& j, int& k) const {
    const dvec3 c = (q - grid_origin_) / cell_;
    i = static_cast<int>(std::floor(c.x));
    j = static_cast<int>(std::floor(c.y));
    k = static_cast<int>(std::floor(c.z));
    return i >= 0 && j >= 0 && k >= 0 && i < grid_dims_[0] && j < grid_dims_[1] && k < grid_dims_[2];
  }
  [[nodiscard]] std::size_t cell_index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * static_cast<std::size_t>(grid_dims_[1]) + static_cast<std::size_t>(j)) *
               static_cast<std::size_t>(grid_dims_[0]) +
           static_cast<std::size_t>(i);
  }

  /// A new node shades the pyramid below it: layer q gets a·b^(−q) over (2q+1)² voxels.
  void add_shadow(const dvec3& q) {
    int i, j, k;
    if (!cell_of(q, i, j, k)) return;
    for (int d = 0; d <= static_cast<int>(p_.shadow_depth) && k - d >= 0; ++d) {
      const double ds = p_.shadow_a * std::pow(p_.shadow_b, -double(d));
      for (int y = std::max(0, j - d); y <= std::min(grid_dims_[1] - 1, j + d); ++y) {
        for (int x = std::max(0, i - d); x <= std::min(grid_dims_[0] - 1, i + d); ++x) {
          shade_[cell_index(x, y, k - d)] += ds;
        }
      }
    }
  }

  /// Light of a bud at q in [0, 1]: max(C − s + a, 0) / C (Pałubicki 2009; the + a discounts
  /// the shadow of the bud's own node).
  [[nodiscard]] double exposure(const dvec3& q) const {
    if (!p_.shadow) return 1.0;
    int i, j, k;
    if (!cell_of(q, i, j, k)) return 1.0;
    const double s = shade_[cell_index(i, j, k)];
    return std::clamp((p_.shadow_full - s + p_.shadow_a) / p_.shadow_full, 0.0, 1.0);
  }

  /// Unit direction from q to the least shaded of the 26 neighbouring voxels inside the
  /// perception cone around d (Pałubicki 2009: buds grow towards light); d when none is
  /// inside the grid or the cone. Ties go to the first voxel in scan order.
  [[nodiscard]] dvec3 lightest(const dvec3& q, const dvec3& d, double cos_half) const {
    int i, j, k;
    if (!cell_of(q, i, j, k)) return d;
    double best = std::numeric_limits<double>::infinity();
    dvec3 out = d;
    for (int z = k - 1; z <= k + 1; ++z) {
      for (int y = j - 1; y <= j + 1; ++y) {
        for (int x = i - 1; x <= i + 1; ++x) {
          if ((x == i && y == j && z == k) || x < 0 || y < 0 || z < 0 || x >= grid_dims_[0] || y >= grid_dims_[1] ||
              z >= grid_dims_[2]) {
            continue;
          }
          const dvec3 e = glm::normalize(dvec3(x - i, y - j, z - k));
          if (glm::dot(e, d) < cos_half) continue;
          const double s = shade_[cell_index(x, y, z)];
          if (s < best) {
            best = s;
            out = e;
          }
        }
      }
    }
    return out;
  }

  // ---- nodes -------------------------------------------------------------------------------
  [[nodiscard]] bool sot() const { return p_.mode == GrowMode::self_organizing; }

  std::uint32_t add_root() {
    pos_.push_back(dvec3(0));
    dir_.push_back(trunk_dir_);
    side_.push_back(any_perpendicular(trunk_dir_));
    parent_.push_back(kNone);
    child_.push_back({kNone, kNone});
    key_.push_back(derive_seed(p_.seed, kTreeKey));
    phyllo_.push_back(0.0);
    lat_dir_.push_back(trunk_dir_);  // unused: the root has no lateral bud
    dead_.push_back({0, 1});
    branch_order_.push_back(0);
    return 0;
  }

  /// Appends the internode grown from bud (n, slot) in direction d and returns the new node.
  std::uint32_t add_node(std::uint32_t n, std::uint32_t slot, const dvec3& d) {
    const auto m = static_cast<std::uint32_t>(pos_.size());
    const std::uint64_t key = derive_seed(key_[n], slot + 1);
    pos_.push_back(pos_[n] + p_.internode_length * d);
    dir_.push_back(d);
    side_.push_back(normalize_or(side_[n] - glm::dot(side_[n], d) * d, any_perpendicular(d)));
    parent_.push_back(n);
    child_.push_back({kNone, kNone});
    child_[n][slot] = m;
    key_.push_back(key);
    Rng phyllo_rng(derive_seed(key, kPhylloStream));
    const double start =
        slot == 0 ? phyllo_[n] + p_.phyllotaxis_degrees * kDeg : phyllo_rng.uniform(0, 2 * std::numbers::pi);
    phyllo_.push_back(start);
    const double azimuth = start + phyllo_rng.normal(0, 10.0 * kDeg);
    lat_dir_.push_back(deflect(d, side_.back(), p_.branching_angle_degrees * kDeg, azimuth));
    dead_.push_back({0, 0});
    branch_order_.push_back(branch_order_[n] + slot);
    return m;
  }

  /// Direction of the next internode from bud (n, slot): inertia-weighted mix of the bud's
  /// own direction `base` and the direction to its attraction points `toward`, plus tropism
  /// and jitter, then held within the bend and branching limits.
  /// Returns false when the limits cannot be met (the bud then stays put).
  bool next_direction(std::uint32_t n, std::uint32_t slot, const dvec3& base, const dvec3& toward, std::uint64_t key,
                      dvec3& out) const {
    const bool on_trunk = slot == 0 && branch_order_[n] == 0;
    dvec3 w =
        p_.inertia * base + (1.0 - p_.inertia) * toward + (on_trunk ? p_.trunk_tropism : p_.tropism) * dvec3(0, 0, 1);
    w = normalize_or(w, base);
    if (p_.direction_jitter_degrees > 0) {
      Rng rng(derive_seed(key, kDirectionStream));
      const double a = std::abs(rng.normal(0, p_.direction_jitter_degrees * kDeg));
      w = deflect(w, any_perpendicular(w), a, rng.uniform(0, 2 * std::numbers::pi));
    }
    const dvec3 ref = dir_[n];
    const double turn = p_.max_turn_degrees * kDeg;
    const double bmin = p_.min_branch_angle_degrees * kDeg, bmax = p_.max_branch_angle_degrees * kDeg;
    const bool lateral = slot == 1;
    w = lateral ? clamp_angle(w, ref, bmin, bmax) : clamp_angle(w, ref, 0.0, turn);
    // Keep the two children of a fork apart.
    const std::uint32_t other = child_[n][1 - slot];
    if (other != kNone) {
      const dvec3 e = glm::normalize(pos_[other] - pos_[n]);
      if (angle_between(w, e) < bmin) {
        w = clamp_angle(w, e, bmin, std::numbers::pi);
        const double a = angle_between(w, ref);
        if (lateral ? (a < bmin - 1e-9 || a > bmax + 1e-9) : a > turn + 1e-9) return false;
      }
    }
    out = w;
    return true;
  }

  // ---- growth ------------------------------------------------------------------------------
  [[nodiscard]] bool bud_exists(std::uint32_t n, std::uint32_t slot) const {
    if (sot()) return child_[n][slot] == kNone && !dead_[n][slot];
    // Space colonization: one perceiver per node with a free slot (slot 0 stands for it).
    if (slot == 1) return false;
    const bool free = child_[n][0] == kNone || (n != 0 && child_[n][1] == kNone);
    return free && !dead_[n][0];
  }

  [[nodiscard]] dvec3 bud_dir(std::uint32_t n, std::uint32_t slot) const { return slot == 0 ? dir_[n] : lat_dir_[n]; }

  /// A straight trunk of trunk_height, then extended until its top bud perceives a live
  /// attraction point (or passes the far end of the crown's bounds), so a crown that starts
  /// higher than the trunk is still reached.
  void grow_trunk() {
    const auto count = static_cast<std::size_t>(std::lround(p_.trunk_height / p_.internode_length));
    std::uint32_t n = 0;
    std::vector<std::pair<std::uint32_t, double>> buffer;
    std::vector<Hit> hits;
    for (std::size_t i = 0; pos_.size() < p_.max_nodes; ++i) {
      if (i >= count) {
        bool any = false;
        query(pos_[n], p_.perception_radius, buffer, hits, any);
        if (any || glm::dot(pos_[n], trunk_dir_) > crown_reach_) break;
      }
      n = add_node(n, 0, trunk_dir_);
      kill_near(pos_[n]);
      if (p_.shadow) add_shadow(pos_[n]);
    }
  }

  void grow() {
    trunk_dir_ = glm::normalize(p_.trunk_direction);
    add_root();
    grow_trunk();
    const double cos_half = sot() ? std::cos(0.5 * p_.perception_angle_degrees * kDeg) : -2.0;
    std::vector<Bud> active;
    std::vector<std::vector<Hit>> hits;
    std::vector<std::uint8_t> any_live;
    std::vector<std::uint32_t> count;
    std::vector<dvec3> toward;
    double fraction = 0;
    std::size_t it = 0;
    bool grew_crown = false;
    for (; it < p_.max_iterations && live_ > 0 && pos_.size() < p_.max_nodes; ++it) {
      // 1. Perception: every live bud gathers the live points in its cone (in parallel, each
      //    bud writing its own slot).
      active.clear();
      for (std::uint32_t n = 0; n < pos_.size(); ++n) {
        for (std::uint32_t s = 0; s < 2; ++s) {
          if (bud_exists(n, s)) active.push_back({n, s});
        }
      }
      if (active.empty()) break;
      hits.resize(active.size());
      any_live.assign(active.size(), 0);
      tbb::parallel_for(
          tbb::blocked_range<std::size_t>(0, active.size(), 64), [&](const tbb::blocked_range<std::size_t>& r) {
            std::vector<std::pair<std::uint32_t, double>> buffer;
            for (std::size_t k = r.begin(); k != r.end(); ++k) {
              const Bud b = active[k];
              const dvec3 o = pos_[b.node], d = bud_dir(b.node, b.slot);
              bool any = false;
              query(o, p_.perception_radius, buffer, hits[k], any);
              any_live[k] = any ? 1 : 0;
              auto& h = hits[k];
              h.erase(std::remove_if(
                          h.begin(), h.end(),
                          [&](const Hit& x) { return glm::dot(points_[x.point] - o, d) < cos_half * std::sqrt(x.d2); }),
                      h.end());
            }
          });
      // A bud whose perception ball holds no live point will never see one again (points are
      // only ever removed): it dies for good, which keeps the active set small.
      for (std::size_t k = 0; k < active.size(); ++k) {
        if (!any_live[k]) dead_[active[k].node][active[k].slot] = 1;
      }
      // 2. Each point goes to the nearest bud that perceives it (ties: the lower bud), in bud
      //    order, so the result does not depend on threads.
      ++stamp_now_;
      for (std::uint32_t k = 0; k < active.size(); ++k) {
        for (const Hit& h : hits[k]) {
          if (stamp_[h.point] != stamp_now_ || h.d2 < best_d2_[h.point]) {
            stamp_[h.point] = stamp_now_;
            best_d2_[h.point] = h.d2;
            best_bud_[h.point] = k;
          }
        }
      }
      count.assign(active.size(), 0);
      toward.assign(active.size(), dvec3(0));
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, active.size(), 256),
                        [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t k = r.begin(); k != r.end(); ++k) {
                            dvec3 sum(0);
                            std::uint32_t c = 0;
                            const dvec3 o = pos_[active[k].node];
                            for (const Hit& h : hits[k]) {
                              if (best_bud_[h.point] != k) continue;
                              sum += (points_[h.point] - o) / std::sqrt(h.d2);
                              ++c;
                            }
                            count[k] = c;
                            const dvec3 d = bud_dir(active[k].node, active[k].slot);
                            toward[k] = normalize_or(sum, d);
                            if (p_.shadow && p_.shadow_steering > 0 && c > 0) {
                              toward[k] = normalize_or(toward[k] + p_.shadow_steering * lightest(o, d, cos_half), d);
                            }
                          }
                        });
      // 3. Growth.
      const std::size_t before = pos_.size();
      if (sot()) {
        grow_self_organizing(active, count, toward);
      } else {
        grow_colonization(active, count, toward);
      }
      if (pos_.size() == before) break;
      grew_crown = true;
      // 4. Occupancy: points near the new nodes are reached; new nodes shade those below.
      for (std::size_t m = before; m < pos_.size(); ++m) {
        kill_near(pos_[m]);
        if (p_.shadow) add_shadow(pos_[m]);
      }
      if (live_ * 2 < indexed_.size()) rebuild_index();
      const double reached = 1.0 - double(live_) / double(std::max<std::size_t>(points_.size(), 1));
      fraction = std::max(
          {fraction, reached, double(it + 1) / double(p_.max_iterations), double(pos_.size()) / double(p_.max_nodes)});
      report("grow", fraction);
    }
    stats_->iterations = it;
    if (!grew_crown) {
      stats_->warnings.add("no_growth",
                           "no bud perceived an attraction point: the crown is out of reach of the trunk (check "
                           "trunk_height, perception_radius and the crown volume)");
    }
    if (pos_.size() >= p_.max_nodes) {
      stats_->warnings.add("max_nodes", "growth stopped at max_nodes = " + std::to_string(p_.max_nodes));
    } else if (it >= p_.max_iterations && live_ > 0) {
      stats_->warnings.add("max_iterations", "growth stopped at max_iterations = " + std::to_string(p_.max_iterations) +
                                                 " with " + std::to_string(live_) + " attraction points left");
    }
  }

  /// Borchert–Honda: light Q flows down (basipetal), resource v = α·Q_root flows up
  /// (acropetal) and splits at every node into v_m and v_l by apical control λ; a bud with
  /// v ≥ 1 grows ⌊v⌋ internodes (at most max_shoot_internodes).
  void grow_self_organizing(const std::vector<Bud>& active, const std::vector<std::uint32_t>& count,
                            const std::vector<dvec3>& toward) {
    const std::size_t n_nodes = pos_.size();
    std::vector<std::array<double, 2>> bud_q(n_nodes, {0.0, 0.0});
    std::vector<std::array<dvec3, 2>> bud_toward(n_nodes);
    for (std::size_t k = 0; k < active.size(); ++k) {
      if (count[k] == 0) continue;
      const Bud b = active[k];
      bud_q[b.node][b.slot] = exposure(pos_[b.node]);
      bud_toward[b.node][b.slot] = toward[k];
    }
    std::vector<double> q_main(n_nodes), q_lat(n_nodes), q_acc(n_nodes);
    for (std::size_t i = n_nodes; i-- > 0;) {  // children have larger indices than parents
      const auto& c = child_[i];
      q_main[i] = c[0] != kNone ? q_acc[c[0]] : bud_q[i][0];
      q_lat[i] = c[1] != kNone ? q_acc[c[1]] : bud_q[i][1];
      q_acc[i] = q_main[i] + q_lat[i];
    }
    const double lambda = p_.apical_control;
    std::vector<double> v(n_nodes, 0.0);
    std::vector<std::array<double, 2>> bud_v(n_nodes, {0.0, 0.0});
    v[0] = p_.vigor * q_acc[0];
    for (std::size_t i = 0; i < n_nodes; ++i) {
      const double denom = lambda * q_main[i] + (1 - lambda) * q_lat[i];
      const double vm = denom > 0 ? v[i] * lambda * q_main[i] / denom : 0.0;
      const double vl = denom > 0 ? v[i] * (1 - lambda) * q_lat[i] / denom : 0.0;
      const auto& c = child_[i];
      (c[0] != kNone ? v[c[0]] : bud_v[i][0]) = vm;
      (c[1] != kNone ? v[c[1]] : bud_v[i][1]) = vl;
    }
    for (const Bud b : active) {
      if (bud_q[b.node][b.slot] <= 0) continue;
      const double vb = bud_v[b.node][b.slot];
      const auto shoot = static_cast<std::uint32_t>(std::min<double>(std::floor(vb), p_.max_shoot_internodes));
      std::uint32_t n = b.node, slot = b.slot;
      dvec3 base = bud_dir(n, slot);
      for (std::uint32_t k = 0; k < shoot && pos_.size() < p_.max_nodes; ++k) {
        dvec3 d;
        if (!next_direction(n, slot, base, bud_toward[b.node][b.slot], derive_seed(key_[n], slot + 1), d)) {
          dead_[n][slot] = 1;
          break;
        }
        n = add_node(n, slot, d);
        slot = 0;
        base = d;
      }
    }
  }

  /// Runions et al. 2007: every node with attraction points grows one internode towards them
  /// (its continuation first, then one lateral; never more than two children).
  void grow_colonization(const std::vector<Bud>& active, const std::vector<std::uint32_t>& count,
                         const std::vector<dvec3>& toward) {
    for (std::size_t k = 0; k < active.size() && pos_.size() < p_.max_nodes; ++k) {
      if (count[k] == 0) continue;
      const std::uint32_t n = active[k].node;
      const std::uint32_t slot = child_[n][0] == kNone ? 0 : 1;
      dvec3 d;
      if (!next_direction(n, slot, dir_[n], toward[k], derive_seed(key_[n], slot + 1), d)) {
        if (slot == 1) dead_[n][0] = 1;
        continue;
      }
      add_node(n, slot, d);
    }
  }

  // ---- cleanup -----------------------------------------------------------------------------
  [[nodiscard]] int kids(std::uint32_t n) const { return int(child_[n][0] != kNone) + int(child_[n][1] != kNone); }
  [[nodiscard]] std::uint32_t only_child(std::uint32_t n) const {
    return child_[n][0] != kNone ? child_[n][0] : child_[n][1];
  }
  [[nodiscard]] double edge(std::uint32_t n) const { return glm::length(pos_[n] - pos_[parent_[n]]); }

  /// Live nodes in depth-first pre-order from the root, continuation first: parents before
  /// children. (Sliding moves subtrees, so creation order is no longer topological.)
  [[nodiscard]] std::vector<std::uint32_t> order() const {
    std::vector<std::uint32_t> out, stack{0};
    out.reserve(pos_.size());
    while (!stack.empty()) {
      const std::uint32_t v = stack.back();
      stack.pop_back();
      out.push_back(v);
      if (child_[v][1] != kNone) stack.push_back(child_[v][1]);
      if (child_[v][0] != kNone) stack.push_back(child_[v][0]);
    }
    return out;
  }

  /// Pipe model from the tips down: r^n = Σ r_c^n (Clasping Trees eq. 1; radii instead of
  /// diameters, which is the same rule).
  void compute_radii() {
    const double e = p_.pipe_exponent;
    const auto ord = order();
    for (auto it = ord.rbegin(); it != ord.rend(); ++it) {
      const std::uint32_t i = *it;
      if (kids(i) == 0) {
        radius_[i] = p_.tip_radius;
        continue;
      }
      if (kids(i) == 1) {  // exact copy: pow(pow(r, n), 1/n) may round above r
        radius_[i] = radius_[only_child(i)];
        continue;
      }
      double s = 0;
      for (std::uint32_t c : child_[i]) {
        if (c != kNone) s += std::pow(radius_[c], e);
      }
      radius_[i] = std::pow(s, 1.0 / e);
    }
  }

  [[nodiscard]] double limit(std::uint32_t a, std::uint32_t b) const {
    return p_.min_edge_ratio * std::max(radius_[a], radius_[b]);
  }

  /// Removes chain nodes (one child) whose incoming edge is shorter than min_edge_ratio ×
  /// radius, or whose outgoing edge is and ends at a node that must stay (a fork or tip).
  /// Radii along a chain are equal, so the pipe model is unaffected.
  std::size_t merge_chains() {
    std::size_t merged = 0;
    for (const std::uint32_t n : order()) {
      if (n == 0 || kids(n) != 1) continue;
      const std::uint32_t p = parent_[n], c = only_child(n);
      const bool short_in = edge(n) < limit(p, n);
      const bool short_out = edge(c) < limit(n, c) && kids(c) != 1;
      if (!short_in && !short_out) continue;
      child_[p][child_[p][0] == n ? 0 : 1] = c;
      parent_[c] = p;
      child_[n] = {kNone, kNone};
      removed_[n] = 1;
      ++merged;
    }
    return merged;
  }

  /// The child of fork n that carries the fewer pipes (the lateral in the pipe-model sense).
  [[nodiscard]] std::uint32_t thinner_child(std::uint32_t n) const {
    return radius_[child_[n][1]] <= radius_[child_[n][0]] ? child_[n][1] : child_[n][0];
  }

  /// Forks closer together than min_edge_ratio × radius cannot be merged. The lateral of the
  /// upper fork is slid up its axis to the first plain node far enough from the lower fork
  /// (its subtree translated with it, a move of a few internodes); where the axis forks or
  /// ends first, the thinnest lateral involved is pruned with its subtree when it is thinner
  /// than prune_ratio × its parent, as a tree sheds shaded twigs on its trunk; otherwise the
  /// short edge stays (counted in the stats).
  std::size_t fix_crowded_forks(std::size_t& pruned) {
    std::size_t slid = 0;
    for (const std::uint32_t n : order()) {
      if (removed_[n] || n == 0 || kids(n) != 2) continue;
      const std::uint32_t p = parent_[n];
      if (kids(p) != 2 || edge(n) >= limit(p, n)) continue;
      const std::uint32_t x = thinner_child(n);
      // Walk up n's main axis to the first plain node at least the limit away from p.
      std::uint32_t m = child_[n][0] == x ? child_[n][1] : child_[n][0];
      const double need = limit(p, n);
      while (kids(m) == 1 && glm::length(pos_[m] - pos_[p]) < need) m = only_child(m);
      if (kids(m) == 1 && glm::length(pos_[m] - pos_[p]) >= need) {
        slide_subtree(x, m);
        ++slid;
        continue;
      }
      if (p_.prune_ratio <= 0) continue;
      const std::uint32_t sibling = child_[p][0] == n ? child_[p][1] : child_[p][0];
      const std::uint32_t y = radius_[sibling] < radius_[x] ? sibling : x;
      if (radius_[y] > p_.prune_ratio * radius_[parent_[y]]) continue;
      stats_->pruned_nodes += remove_subtree(y);
      ++pruned;
    }
    return slid;
  }

  /// Re-attaches the subtree of x as the lateral of chain node m, translated by the move.
  void slide_subtree(std::uint32_t x, std::uint32_t m) {
    const std::uint32_t n = parent_[x];
    const dvec3 delta = pos_[m] - pos_[n];
    detach(x);
    child_[m][1] = x;
    parent_[x] = m;
    std::vector<std::uint32_t> stack{x};
    while (!stack.empty()) {
      const std::uint32_t v = stack.back();
      stack.pop_back();
      pos_[v] += delta;
      for (std::uint32_t c : child_[v]) {
        if (c != kNone) stack.push_back(c);
      }
    }
  }

  /// Unlinks x from its parent, keeping the remaining child in slot 0.
  void detach(std::uint32_t x) {
    const std::uint32_t p = parent_[x];
    child_[p][child_[p][0] == x ? 0 : 1] = kNone;
    if (child_[p][0] == kNone && child_[p][1] != kNone) std::swap(child_[p][0], child_[p][1]);
  }

  /// Removes x and everything above it; returns the number of nodes removed.
  std::size_t remove_subtree(std::uint32_t x) {
    detach(x);
    std::size_t count = 0;
    std::vector<std::uint32_t> stack{x};
    while (!stack.empty()) {
      const std::uint32_t v = stack.back();
      stack.pop_back();
      removed_[v] = 1;
      ++count;
      for (std::uint32_t c : child_[v]) {
        if (c != kNone) stack.push_back(c);
      }
    }
    return count;
  }

  /// True when edges (parent(a), a) and (parent(b), b) share a node within kRelated steps
  /// towards the root: such edges meet at a fork and are meant to be close there.
  [[nodiscard]] bool related(std::uint32_t a, std::uint32_t b) const {
    constexpr int kRelated = 4;
    std::array<std::uint32_t, kRelated + 1> up{};
    int n = 0;
    for (std::uint32_t v = a; n <= kRelated; v = parent_[v]) {
      up[static_cast<std::size_t>(n++)] = v;
      if (v == 0) break;
    }
    for (int k = 0; k <= kRelated; ++k, b = parent_[b]) {
      if (std::find(up.begin(), up.begin() + n, b) != up.begin() + n) return true;
      if (b == 0) break;
    }
    return false;
  }

  /// Edges of unrelated branches that come closer than the sum of their radii would make the
  /// mesh intersect itself. The attraction points keep branches apart almost always; the rare
  /// touching pair (twigs grown into the same gap) is resolved, when `prune` is set, by
  /// removing the thinner edge's subtree if it is small (≤ kMaxCollisionPrune nodes). Returns
  /// the pairs left touching.
  std::size_t resolve_collisions(bool prune) {
    constexpr std::size_t kMaxCollisionPrune = 40;
    const auto ord = order();
    std::vector<std::uint32_t> size(pos_.size(), 0);  // subtree sizes
    for (auto it = ord.rbegin(); it != ord.rend(); ++it) {
      size[*it] += 1;
      if (*it != 0) size[parent_[*it]] += size[*it];
    }
    Cloud mids;                          // edge midpoints
    std::vector<std::uint32_t> edge_of;  // midpoint index -> the edge's child node
    double max_half = 0;
    for (const std::uint32_t v : ord) {
      if (v == 0) continue;
      mids.pts.push_back(0.5 * (pos_[v] + pos_[parent_[v]]));
      edge_of.push_back(v);
      max_half = std::max(max_half, 0.5 * edge(v));
    }
    if (edge_of.empty()) return 0;
    const KdTree index(3, mids, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    std::size_t touching = 0;
    std::vector<std::pair<std::uint32_t, double>> found;
    for (std::uint32_t k = 0; k < edge_of.size(); ++k) {
      const std::uint32_t a = edge_of[k];
      if (removed_[a]) continue;
      // Each pair is examined from its thicker edge (ties: the lower index), whose search then
      // needs to reach only half_a + max_half + 2·ra.
      const double ra = radius_[parent_[a]];  // the thicker end of the edge
      const double reach = 0.5 * edge(a) + max_half + 2 * ra;
      const double q[3] = {mids.pts[k].x, mids.pts[k].y, mids.pts[k].z};
      found.clear();
      index.radiusSearch(q, reach * reach, found, nanoflann::SearchParams(32, 0.f, false));
      std::sort(found.begin(), found.end());
      for (const auto& [j, d2] : found) {
        const std::uint32_t b = edge_of[j];
        if (j == k || removed_[b] || removed_[a]) continue;
        const double rb = radius_[parent_[b]];
        if (rb > ra || (rb == ra && j < k)) continue;  // examined from b
        if (segment_distance(pos_[parent_[a]], pos_[a], pos_[parent_[b]], pos_[b]) >= ra + rb) continue;
        if (related(a, b)) continue;
        // The thinner edge's subtree goes (ties: the smaller subtree, then the later node).
        const bool a_goes = ra != rb ? ra < rb : size[a] != size[b] ? size[a] < size[b] : a > b;
        const std::uint32_t x = a_goes ? a : b;
        if (prune && size[x] <= kMaxCollisionPrune) {
          stats_->collision_pruned_nodes += remove_subtree(x);
          ++stats_->collisions_pruned;
        } else {
          ++touching;
        }
      }
    }
    return touching;
  }

  void cleanup() {
    removed_.assign(pos_.size(), 0);
    radius_.assign(pos_.size(), 0.0);
    compute_radii();
    stats_->merged_nodes += merge_chains();
    constexpr int kRounds = 16;
    for (int round = 0; round < kRounds; ++round) {
      std::size_t pruned = 0;
      const std::size_t slid = fix_crowded_forks(pruned);
      if (slid + pruned == 0) break;
      stats_->slid_laterals += slid;
      stats_->pruned_laterals += pruned;
      compute_radii();
      stats_->merged_nodes += merge_chains();
      report("cleanup", double(round + 1) / (kRounds + 2));
    }
  }

  void untangle() {
    if (p_.min_edge_ratio > 0) {  // the whole cleanup is off with min_edge_ratio = 0
      resolve_collisions(true);
      compute_radii();
      stats_->merged_nodes += merge_chains();
    }
    stats_->touching_edges = resolve_collisions(false);
  }

  RawSkeleton emit() {
    RawSkeleton raw;
    raw.up_axis = UpAxis::z;
    raw.grown = true;
    raw.source = std::string("strandmesh ") + (sot() ? "self-organizing" : "space colonization") + " grower (seed " +
                 std::to_string(p_.seed) + ")";
    std::vector<std::int64_t> new_id(pos_.size(), -1);
    double top = 0;
    for (const std::uint32_t i : order()) {
      new_id[i] = static_cast<std::int64_t>(raw.size());
      raw.add(new_id[i], i == 0 ? -1 : new_id[parent_[i]], pos_[i], radius_[i]);
      top = std::max(top, glm::dot(pos_[i], trunk_dir_));
      const int k = kids(i);
      stats_->tips += k == 0 ? 1 : 0;
      stats_->forks += k == 2 ? 1 : 0;
      if (i != 0 && (k == 2 || kids(parent_[i]) == 2) && edge(i) < limit(i, parent_[i])) ++stats_->short_edges;
    }
    stats_->nodes = raw.size();
    stats_->height = top;
    stats_->trunk_radius = radius_[0];
    return raw;
  }

  const GrowerParams& p_;
  const ProgressFn& progress_;
  GrowStats* stats_ = nullptr;
  dvec3 trunk_dir_{0, 0, 1};
  double crown_reach_ = 0;  // largest extent of the crown bounds along trunk_dir_ (metres)

  // Attraction points.
  std::vector<dvec3> points_;
  std::vector<std::uint8_t> alive_;
  std::size_t live_ = 0;
  Cloud cloud_;
  std::vector<std::uint32_t> indexed_;  // cloud index -> point id
  std::unique_ptr<KdTree> index_;
  std::vector<double> best_d2_;
  std::vector<std::uint32_t> best_bud_, stamp_;
  std::uint32_t stamp_now_ = 0;

  // Nodes (structure of arrays; parents before children).
  std::vector<dvec3> pos_, dir_, side_, lat_dir_;
  std::vector<std::uint32_t> parent_;
  std::vector<std::array<std::uint32_t, 2>> child_;  // [continuation, lateral]
  std::vector<std::uint64_t> key_;
  std::vector<double> phyllo_;
  std::vector<std::array<std::uint8_t, 2>> dead_;  // bud has nothing left to perceive
  std::vector<std::uint32_t> branch_order_;        // branch order: 0 on the trunk axis, +1 per lateral

  // Cleanup.
  std::vector<std::uint8_t> removed_;
  std::vector<double> radius_;

  // Shadow grid.
  double cell_ = 1;
  dvec3 grid_origin_{0};
  std::array<int, 3> grid_dims_{0, 0, 0};
  std::vector<double> shade_;
};

}  // namespace

void validate_grower_params(const GrowerParams& p) {
  auto fail = [](const std::string& field, const std::string& rule) { throw InvalidInputError(field + ": " + rule); };
  auto positive = [&](double v, const char* field) {
    if (!(v > 0) || !std::isfinite(v)) fail(field, fmt(v) + " must be > 0");
  };
  auto range = [&](double v, double lo, double hi, const char* field) {
    if (!(v >= lo && v <= hi)) fail(field, fmt(v) + " must be in [" + fmt(lo) + ", " + fmt(hi) + "]");
  };
  if (p.mode != GrowMode::self_organizing && p.mode != GrowMode::space_colonization) fail("mode", "unknown mode");
  if (p.attraction_points < 1 || p.attraction_points > 50'000'000) {
    fail("attraction_points", std::to_string(p.attraction_points) + " must be in [1, 50000000]");
  }
  positive(p.internode_length, "internode_length");
  positive(p.perception_radius, "perception_radius");
  positive(p.occupancy_radius, "occupancy_radius");
  if (p.occupancy_radius >= p.perception_radius) {
    fail("occupancy_radius", fmt(p.occupancy_radius) + " must be smaller than perception_radius " +
                                 fmt(p.perception_radius) + " (buds would never see a point)");
  }
  range(p.perception_angle_degrees, 1, 360, "perception_angle_degrees");
  range(p.branching_angle_degrees, 0, 90, "branching_angle_degrees");
  range(p.phyllotaxis_degrees, -360, 360, "phyllotaxis_degrees");
  range(p.inertia, 0, 1, "inertia");
  range(p.tropism, -10, 10, "tropism");
  range(p.trunk_tropism, -10, 10, "trunk_tropism");
  range(p.direction_jitter_degrees, 0, 45, "direction_jitter_degrees");
  range(p.apical_control, 0, 1, "apical_control");
  positive(p.vigor, "vigor");
  if (p.max_shoot_internodes < 1) fail("max_shoot_internodes", "must be >= 1");
  if (!(p.shadow_voxel_size >= 0) || !std::isfinite(p.shadow_voxel_size)) fail("shadow_voxel_size", "must be >= 0");
  if (p.shadow_depth > 64) fail("shadow_depth", std::to_string(p.shadow_depth) + " must be <= 64");
  positive(p.shadow_a, "shadow_a");
  if (!(p.shadow_b > 1) || !std::isfinite(p.shadow_b)) fail("shadow_b", fmt(p.shadow_b) + " must be > 1");
  positive(p.shadow_full, "shadow_full");
  range(p.shadow_steering, 0, 100, "shadow_steering");
  const double tl = glm::length(p.trunk_direction);
  if (!(tl > 1e-9) || !std::isfinite(tl)) fail("trunk_direction", "must be a non-zero finite vector");
  if (!(p.trunk_height >= 0) || !std::isfinite(p.trunk_height)) fail("trunk_height", "must be >= 0");
  if (p.max_iterations < 1) fail("max_iterations", "must be >= 1");
  if (p.max_nodes < 2) fail("max_nodes", "must be >= 2");
  positive(p.tip_radius, "tip_radius");
  range(p.pipe_exponent, 1.8, 2.8, "pipe_exponent");
  range(p.max_turn_degrees, 1, 90, "max_turn_degrees");
  range(p.min_branch_angle_degrees, 0, 90, "min_branch_angle_degrees");
  range(p.max_branch_angle_degrees, 1, 90, "max_branch_angle_degrees");
  if (p.min_branch_angle_degrees > p.max_branch_angle_degrees) {
    fail("min_branch_angle_degrees", "must not exceed max_branch_angle_degrees");
  }
  range(p.min_edge_ratio, 0, 20, "min_edge_ratio");
  range(p.prune_ratio, 0, 1, "prune_ratio");
}

GrowResult grow_tree(const GrowerParams& params, const ProgressFn& progress) {
  validate_grower_params(params);
  return TreeGrower(params, progress).run();
}

}  // namespace sm
