// Sliver removal (see slivers.h): flips and collapses checked locally for shape, turn and
// texture seams, then, per round, for crossings with the triangles near them (exact tests).

#include "repair/slivers.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <tuple>
#include <unordered_map>
#include <set>
#include <span>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/math.h"
#include "meshcheck/intersections.h"

namespace sm {
namespace {

using glm::dvec3;
using Tri = Mesh::Triangle;
using CornerUvs = std::array<glm::vec2, 3>;
constexpr double kRadians = std::numbers::pi / 180.0;
/// Two sides of a seam differ by one translation where their shifts agree within this (UV units).
constexpr float kUvTolerance = 1e-5f;
/// An edge shorter than this share of the longest edge around it joins two vertices that stand
/// for one point.
constexpr double kDuplicateEdge = 0.01;

/// The first phase's sliver angle where the limit is larger (radians): needles of a degree.
constexpr double kNeedle = 1.0 * kRadians;

/// The smallest angle of triangle t (radians; 0 where it is degenerate): the one opposite the
/// shortest edge.
template <class Positions>
double smallest_angle(const Positions& pos, const Tri& t) {
  return sm::smallest_angle(pos(t[0]), pos(t[1]), pos(t[2]));
}
double smallest_angle(const Mesh& m, const Tri& t) {
  return smallest_angle([&](std::uint32_t v) -> const dvec3& { return m.positions[v]; }, t);
}

/// The mesh's positions with one vertex elsewhere: an edit tried without changing the mesh
/// (so that edits can be planned on several threads).
struct MovedVertex {
  const Mesh& m;
  std::uint32_t vertex;
  dvec3 at;
  const dvec3& operator()(std::uint32_t v) const { return v == vertex ? at : m.positions[v]; }
  [[nodiscard]] dvec3 normal(const Tri& t) const { return glm::cross((*this)(t[1]) - (*this)(t[0]), (*this)(t[2]) - (*this)(t[0])); }
};

bool collapsed(const Tri& t) { return t[0] == t[1] && t[1] == t[2]; }

/// Whether the angle between u and v is at most the one whose cosine is `cos_max` (false where
/// either is zero).
bool within(const dvec3& u, const dvec3& v, double cos_max) {
  const double lu = glm::length(u), lv = glm::length(v);
  return lu > 0 && lv > 0 && glm::dot(u, v) >= cos_max * lu * lv;
}

/// A hash of grid cell (x, y, z) at `level` (the grids below bin points and triangles by cell).
std::uint64_t cell_key(int level, std::int64_t x, std::int64_t y, std::int64_t z) {
  const auto h = [](std::int64_t v) { return static_cast<std::uint64_t>(v) * 0x9E3779B97F4A7C15ull; };
  return h(x) ^ (h(y) >> 21 | h(y) << 43) ^ (h(z) >> 42 | h(z) << 22) ^ (static_cast<std::uint64_t>(level) << 58);
}

/// One edit's previous values, to undo it.
struct Edit {
  std::vector<std::pair<std::uint32_t, Tri>> triangles;
  std::vector<std::pair<std::uint32_t, CornerUvs>> uvs;
  std::vector<std::pair<std::uint32_t, std::optional<std::vector<std::uint32_t>>>> faces;
  std::optional<std::pair<std::uint32_t, dvec3>> position;
  bool collapse = false;
  std::array<std::uint32_t, 3> key{};  ///< which edit (kind, vertices), not to try again once undone
  std::uint32_t sliver = 0;            ///< the sliver it was made for
  std::vector<std::pair<std::uint32_t, int>> winding;  ///< kept points' winding number changes (InsideGuard)
};

/// The points that must stay inside the mesh (SliverOptions::keep_inside) and their winding
/// numbers, kept up to date edit by edit. An edit replaces a patch of triangles by another
/// with the same boundary, so the winding number about a point changes by that of the closed
/// surface the new patch and the old one reversed make: the signed count of the ray crossings
/// with the triangles the edit changed (as inside_closed_mesh counts them; by their solid
/// angles where the ray passes within rounding of an edge), and none outside their bounding box.
/// Each point inside at the start is checked against a lower bound of its winding number
/// (what the kept edits left, less what the edits pending in the round take away), so that no
/// edit undone later for its crossings can leave one outside.
class InsideGuard {
 public:
  InsideGuard(const Mesh& m, std::span<const dvec3> points, double cell) : m_(m), cell_(std::max(cell, 1e-9)) {
    if (points.empty()) return;
    const std::vector<int> w = winding_numbers(m, points);
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (w[i] < 1) continue;  // (only those inside are kept inside)
      const auto id = static_cast<std::uint32_t>(points_.size());
      points_.push_back(points[i]);
      floor_.push_back(w[i]);
      const glm::i64vec3 c = cell_of(points[i]);
      bins_[cell_key(0, c.x, c.y, c.z)].push_back(id);
    }
  }
  bool empty() const { return points_.empty(); }
  /// The winding number changes edit e (applied) makes about the kept points near it, or
  /// nothing where one of them would leave the mesh (or where a change cannot be told).
  std::optional<std::vector<std::pair<std::uint32_t, int>>> change(const Edit& e) const {
    std::vector<std::pair<std::uint32_t, int>> out;
    if (points_.empty()) return out;
    // The old triangles (first recorded values, the moved vertex where it was) and the new.
    std::vector<std::array<dvec3, 3>> before, after;
    std::vector<std::uint32_t> seen;
    auto was = [&](std::uint32_t v) {
      return e.position && e.position->first == v ? e.position->second : m_.positions[v];
    };
    dvec3 lo(INFINITY), hi(-INFINITY);
    auto grow = [&](const std::array<dvec3, 3>& t) {
      for (const dvec3& p : t) lo = glm::min(lo, p), hi = glm::max(hi, p);
    };
    for (const auto& [g, old] : e.triangles) {
      if (std::find(seen.begin(), seen.end(), g) != seen.end()) continue;
      seen.push_back(g);
      if (!collapsed(old)) before.push_back({was(old[0]), was(old[1]), was(old[2])});
      const Tri& t = m_.triangles[g];
      if (!collapsed(t)) after.push_back({m_.positions[t[0]], m_.positions[t[1]], m_.positions[t[2]]});
    }
    for (const auto& t : before) grow(t);
    for (const auto& t : after) grow(t);
    if (!(lo.x <= hi.x)) return out;
    for (const std::uint32_t i : near(lo, hi)) {
      const dvec3& p = points_[i];
      int delta = 0;
      bool ambiguous = false;
      for (const auto* list : {&after, &before}) {
        for (const auto& t : *list) {
          const int c = ray_crossing(t[0], t[1], t[2], p);
          if (c == kRayAmbiguous) ambiguous = true;
          delta += list == &after ? c : -c;
        }
      }
      if (ambiguous) {
        double w = 0;
        for (const auto& t : after) w += solid_angle(t[0] - p, t[1] - p, t[2] - p);
        for (const auto& t : before) w -= solid_angle(t[0] - p, t[1] - p, t[2] - p);
        w /= 4 * std::numbers::pi;
        // (A point on the changed triangles: its side cannot be told.)
        if (!std::isfinite(w) || std::abs(w - std::round(w)) > 0.25) return std::nullopt;
        delta = static_cast<int>(std::lround(w));
      }
      if (delta == 0) continue;
      if (floor_[i] + std::min(delta, 0) < 1) return std::nullopt;
      out.emplace_back(i, delta);
    }
    return out;
  }
  /// An edit applied (its losses counted at once), undone, or kept at the end of its round.
  void apply(const std::vector<std::pair<std::uint32_t, int>>& c) {
    for (const auto& [i, d] : c) floor_[i] += std::min(d, 0);
  }
  void undo(const std::vector<std::pair<std::uint32_t, int>>& c) {
    for (const auto& [i, d] : c) floor_[i] -= std::min(d, 0);
  }
  void keep(const std::vector<std::pair<std::uint32_t, int>>& c) {
    for (const auto& [i, d] : c) floor_[i] += std::max(d, 0);
  }

 private:
  glm::i64vec3 cell_of(const dvec3& p) const { return glm::i64vec3(glm::floor(p / cell_)); }
  /// The kept points in the box [lo, hi], in increasing order.
  std::vector<std::uint32_t> near(const dvec3& lo, const dvec3& hi) const {
    std::vector<std::uint32_t> out;
    auto inside = [&](std::uint32_t i) {
      const dvec3& p = points_[i];
      return p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y && p.z <= hi.z;
    };
    const glm::i64vec3 a = cell_of(lo), b = cell_of(hi), span = b - a + glm::i64vec3(1);
    if (span.x * span.y * span.z > static_cast<std::int64_t>(points_.size())) {
      for (std::uint32_t i = 0; i < points_.size(); ++i) {
        if (inside(i)) out.push_back(i);
      }
      return out;
    }
    for (auto z = a.z; z <= b.z; ++z)
      for (auto y = a.y; y <= b.y; ++y)
        for (auto x = a.x; x <= b.x; ++x) {
          if (const auto it = bins_.find(cell_key(0, x, y, z)); it != bins_.end()) {
            for (const std::uint32_t i : it->second) {
              if (inside(i)) out.push_back(i);
            }
          }
        }
    std::sort(out.begin(), out.end());  // (two cells may share a bin)
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }
  const Mesh& m_;
  double cell_;
  std::vector<dvec3> points_;
  std::vector<int> floor_;  // lower bound of each kept point's winding number
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> bins_;
};

/// The crossings an edit takes part in, found locally: each triangle binned once on a grid
/// of the level whose cells are at least its size (cells double per level, from a typical
/// triangle's size), and again where an edit moved it, so that a round costs the tests near
/// its edits, not a pass over the whole mesh. Stale entries only add candidates, which the
/// exact test settles.
class LocalCrossings {
 public:
  LocalCrossings(const Mesh& m, const TriangleIntersections& exact) : m_(m), exact_(exact) {
    std::vector<double> sizes;
    sizes.reserve(m.triangles.size());
    for (std::uint32_t f = 0; f < m.triangles.size(); ++f) sizes.push_back(extent(f));
    if (!sizes.empty()) {
      const auto mid = sizes.begin() + static_cast<std::ptrdiff_t>(sizes.size() / 2);
      std::nth_element(sizes.begin(), mid, sizes.end());
      cell_ = std::max(*mid, 1e-9);
    }
    for (std::uint32_t f = 0; f < m.triangles.size(); ++f) add(f);
  }
  /// The grid's finest cell (a typical triangle's size).
  double cell() const { return cell_; }
  /// Bins triangle f where it lies now (after an edit).
  void add(std::uint32_t f) {
    if (collapsed(m_.triangles[f])) return;
    int level = 0;
    while (level + 1 < kLevels && cell_ * std::ldexp(1.0, level) < extent(f)) ++level;
    levels_[level].push_back(f);
    const auto [lo, hi] = cells(f, level);
    for (auto z = lo.z; z <= hi.z; ++z)
      for (auto y = lo.y; y <= hi.y; ++y)
        for (auto x = lo.x; x <= hi.x; ++x) bins_[cell_key(level, x, y, z)].push_back(f);
  }
  /// The crossing pairs (i < j) with a triangle in `triangles`, sorted.
  std::vector<std::array<std::uint32_t, 2>> touching(const std::vector<std::uint32_t>& triangles) const {
    std::vector<std::array<std::uint32_t, 2>> out;
    std::vector<std::uint32_t> candidates;
    for (const std::uint32_t f : triangles) {
      if (collapsed(m_.triangles[f])) continue;
      candidates.clear();
      for (int level = 0; level < kLevels; ++level) {
        if (levels_[level].empty()) continue;
        const auto [lo, hi] = cells(f, level);
        const glm::i64vec3 span = hi - lo + glm::i64vec3(1);
        if (span.x * span.y * span.z > static_cast<std::int64_t>(levels_[level].size())) {
          // (More cells than triangles at this level: all of them.)
          candidates.insert(candidates.end(), levels_[level].begin(), levels_[level].end());
          continue;
        }
        for (auto z = lo.z; z <= hi.z; ++z)
          for (auto y = lo.y; y <= hi.y; ++y)
            for (auto x = lo.x; x <= hi.x; ++x) {
              if (const auto it = bins_.find(cell_key(level, x, y, z)); it != bins_.end()) {
                candidates.insert(candidates.end(), it->second.begin(), it->second.end());
              }
            }
      }
      std::sort(candidates.begin(), candidates.end());
      candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
      const auto [flo, fhi] = box(f);
      for (const std::uint32_t g : candidates) {
        if (g == f || collapsed(m_.triangles[g])) continue;
        const auto [glo, ghi] = box(g);
        if (glo.x > fhi.x || glo.y > fhi.y || glo.z > fhi.z || flo.x > ghi.x || flo.y > ghi.y || flo.z > ghi.z) continue;
        if (exact_.intersect(f, g)) out.push_back({std::min(f, g), std::max(f, g)});
      }
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

 private:
  static constexpr int kLevels = 24;
  std::pair<dvec3, dvec3> box(std::uint32_t f) const {
    const Tri& t = m_.triangles[f];
    const dvec3 &a = m_.positions[t[0]], &b = m_.positions[t[1]], &c = m_.positions[t[2]];
    return {glm::min(a, glm::min(b, c)), glm::max(a, glm::max(b, c))};
  }
  double extent(std::uint32_t f) const {
    const auto [lo, hi] = box(f);
    return std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  }
  std::pair<glm::i64vec3, glm::i64vec3> cells(std::uint32_t f, int level) const {
    const auto [lo, hi] = box(f);
    const double c = cell_ * std::ldexp(1.0, level);
    return {glm::i64vec3(glm::floor(lo / c)), glm::i64vec3(glm::floor(hi / c))};
  }
  const Mesh& m_;
  const TriangleIntersections& exact_;
  double cell_ = 1;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> bins_;
  std::array<std::vector<std::uint32_t>, kLevels> levels_;
};

/// Pairs per triangle, to count those an edit's triangles take part in.
class PairsAt {
 public:
  explicit PairsAt(const std::vector<std::array<std::uint32_t, 2>>& pairs) {
    for (std::uint32_t k = 0; k < pairs.size(); ++k) {
      for (const std::uint32_t f : pairs[k]) of_[f].push_back(k);
    }
  }
  /// The pairs with a triangle the edit changed.
  std::size_t count(const Edit& e) const {
    std::vector<std::uint32_t> ks;
    for (const auto& [g, old] : e.triangles) {
      if (const auto it = of_.find(g); it != of_.end()) ks.insert(ks.end(), it->second.begin(), it->second.end());
    }
    std::sort(ks.begin(), ks.end());
    return static_cast<std::size_t>(std::unique(ks.begin(), ks.end()) - ks.begin());
  }

 private:
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> of_;
};

class SliverRemover {
 public:
  SliverRemover(MeshResult& r, const SliverOptions& o)
      : r_(r), m_(r.mesh), o_(o), vc_(vertex_corners(m_)), cos_turn_(std::cos(o.max_turn * kRadians)),
        uvs_(m_.corner_uvs.size() == m_.triangles.size()), limit_(o.angle * kRadians) {
    // The triangles at each vertex before any edit, sorted and unique (faces()).
    const std::size_t nv = m_.positions.size();
    first_face_.assign(nv + 1, 0);
    base_faces_.reserve(vc_.corner.size());
    for (std::size_t v = 0; v < nv; ++v) {
      const std::size_t from = base_faces_.size();
      for (std::uint32_t k = vc_.begin[v]; k < vc_.begin[v + 1]; ++k) base_faces_.push_back(vc_.corner[k] / 3);
      const auto b = base_faces_.begin() + static_cast<std::ptrdiff_t>(from);
      if (!std::is_sorted(b, base_faces_.end())) std::sort(b, base_faces_.end());
      base_faces_.erase(std::unique(b, base_faces_.end()), base_faces_.end());
      first_face_[v + 1] = static_cast<std::uint32_t>(base_faces_.size());
    }
  }

  SliverStats run() {
    SliverStats st;
    const TriangleIntersections intersections(m_);
    LocalCrossings crossings(m_, intersections);
    InsideGuard guard(m_, o_.keep_inside, 4 * crossings.cell());
    std::vector<std::uint32_t> all(m_.triangles.size());
    for (std::uint32_t f = 0; f < all.size(); ++f) all[f] = f;
    // The mesh's crossing pairs, found once and kept up to date: an edit may not take part in
    // more of them than its triangles did before it.
    std::vector<std::array<std::uint32_t, 2>> known;
    known = o_.known_pairs ? *o_.known_pairs : intersections.pairs(all);
    st.found = find(all, limit_).size();
    // Needles first: with a limit well above a degree, the edits on milder slivers would lock
    // and reshape the neighbourhoods that the few needles' edits need, and leave more of them.
    const double limit = limit_;
    std::vector<double> phases{limit};
    if (limit > kNeedle) phases.insert(phases.begin(), kNeedle);
    for (const double phase : phases) {
      limit_ = phase;
      // Round 0 looks at every triangle; later rounds only at the slivers held back and the
      // triangles at the vertices of those the kept edits changed (nothing else moved).
      std::vector<std::uint32_t> look = all;
      for (int round = 0; round < o_.max_rounds; ++round) {
        std::vector<std::uint32_t> slivers = find(look, limit_);
        if (slivers.empty()) break;
        // The thinnest first: an edit on a milder sliver must not lock the vertices a needle's
        // edit needs in the same round.
        std::vector<std::pair<double, std::uint32_t>> by_angle;
        by_angle.reserve(slivers.size());
        for (const std::uint32_t f : slivers) by_angle.emplace_back(smallest_angle(m_, m_.triangles[f]), f);
        std::sort(by_angle.begin(), by_angle.end());
        for (std::size_t i = 0; i < slivers.size(); ++i) slivers[i] = by_angle[i].second;
        // Those with no edit at all as the mesh is at the round's start are left for a round
        // after a kept edit changes their neighbourhood (found on all threads: planning only
        // reads the mesh). On a large tree most slivers are twigs' needles no edit can remove
        // within the move cap.
        {
          std::vector<std::uint8_t> viable(slivers.size(), 0);
          tbb::parallel_for(tbb::blocked_range<std::size_t>(0, slivers.size(), 256),
                            [&](const tbb::blocked_range<std::size_t>& range) {
                              for (std::size_t i = range.begin(); i != range.end(); ++i) viable[i] = has_edit(slivers[i]);
                            });
          std::size_t kept = 0;
          for (std::size_t i = 0; i < slivers.size(); ++i)
            if (viable[i]) slivers[kept++] = slivers[i];
          slivers.resize(kept);
        }
        ++st.rounds;
        const std::size_t undone_before = st.undone, kept_out_before = st.kept_out;
        const PairsAt before(known);

        std::vector<std::uint8_t> locked(m_.positions.size(), 0);
        std::vector<Edit> edits;
        // The slivers to look at again next round: those a clash held back and those whose edit
        // went back (they try their next best). A sliver with no edit at all is looked at again
        // only where a kept edit changes a triangle at one of its vertices.
        std::vector<std::uint32_t> retry;
        for (const std::uint32_t f : slivers) {
          const Tri t = m_.triangles[f];
          if (collapsed(t)) continue;
          if (locked[t[0]] || locked[t[1]] || locked[t[2]]) {
            retry.push_back(f);
            continue;
          }
          Edit e;
          if (!try_flip(f, e) && !try_collapse(f, e)) continue;
          e.sliver = f;
          // Edits of one round touch disjoint vertices (so that any of them can be undone
          // alone): one reaching a vertex an earlier edit of the round touched goes back.
          bool clash = false;
          for (const auto& [g, old] : e.triangles) {
            for (const std::uint32_t v : old) clash = clash || locked[v];
            for (const std::uint32_t v : m_.triangles[g]) clash = clash || locked[v];
          }
          if (clash) {
            undo(e);
            retry.push_back(f);
            continue;
          }
          // An edit that would leave a point to keep inside outside goes back, not to be tried
          // again (its sliver tries the next best in the next round).
          std::optional<std::vector<std::pair<std::uint32_t, int>>> winding = guard.change(e);
          if (!winding) {
            undo(e);
            forbidden_.insert(e.key);
            ++st.kept_out;
            retry.push_back(f);
            continue;
          }
          guard.apply(*winding);
          e.winding = std::move(*winding);
          for (const auto& [g, old] : e.triangles) {
            for (const std::uint32_t v : old) locked[v] = 1;
            for (const std::uint32_t v : m_.triangles[g]) locked[v] = 1;
          }
          edits.push_back(std::move(e));
        }
        // Edits whose triangles cross more than before are undone, until none does; such an
        // edit is not tried again (its sliver tries its next best in the next round). `now` holds the pairs of the
        // triangles `changed` as the mesh is now: after an undo only the restored triangles' pairs are found again.
        std::vector<std::uint8_t> active(edits.size(), 1);
        std::vector<std::uint32_t> changed;
        for (const Edit& e : edits) {
          for (const auto& [g, old] : e.triangles) changed.push_back(g);
        }
        std::sort(changed.begin(), changed.end());
        changed.erase(std::unique(changed.begin(), changed.end()), changed.end());
        for (const std::uint32_t g : changed) crossings.add(g);
        std::vector<std::array<std::uint32_t, 2>> now = crossings.touching(changed);
        for (;;) {
          const PairsAt after(now);
          std::vector<std::uint32_t> restored;
          for (std::size_t i = edits.size(); i-- > 0;) {
            if (!active[i] || after.count(edits[i]) <= before.count(edits[i])) continue;
            undo(edits[i]);
            guard.undo(edits[i].winding);
            active[i] = 0;
            forbidden_.insert(edits[i].key);
            retry.push_back(edits[i].sliver);
            ++st.undone;
            for (const auto& [g, old] : edits[i].triangles) restored.push_back(g);
          }
          if (restored.empty()) break;
          std::sort(restored.begin(), restored.end());
          restored.erase(std::unique(restored.begin(), restored.end()), restored.end());
          for (const std::uint32_t g : restored) crossings.add(g);
          std::erase_if(now, [&](const std::array<std::uint32_t, 2>& p) {
            return std::binary_search(restored.begin(), restored.end(), p[0]) ||
                   std::binary_search(restored.begin(), restored.end(), p[1]);
          });
          const std::vector<std::array<std::uint32_t, 2>> again = crossings.touching(restored);
          now.insert(now.end(), again.begin(), again.end());
          std::sort(now.begin(), now.end());
          now.erase(std::unique(now.begin(), now.end()), now.end());
        }
        bool kept_any = false;
        {
          std::vector<std::uint8_t> touched(m_.triangles.size(), 0);
          for (const std::uint32_t g : changed) touched[g] = 1;
          std::erase_if(known, [&](const std::array<std::uint32_t, 2>& p) { return touched[p[0]] || touched[p[1]]; });
          known.insert(known.end(), now.begin(), now.end());
          std::sort(known.begin(), known.end());
          known.erase(std::unique(known.begin(), known.end()), known.end());
        }
        // (The needles, few, are all looked at again: whether one can be edited depends on
        // more than its vertices' triangles, the link condition on its neighbours' neighbours.)
        look = limit_ > kNeedle ? std::move(retry) : std::move(slivers);
        for (std::size_t i = 0; i < edits.size(); ++i) {
          if (!active[i]) continue;
          kept_any = true;
          guard.keep(edits[i].winding);
          ++(edits[i].collapse ? st.collapses : st.flips);
          for (const auto& [g, old] : edits[i].triangles) {
            for (const std::uint32_t v : m_.triangles[g]) {
              const std::span<const std::uint32_t> around = faces(v);
              look.insert(look.end(), around.begin(), around.end());
            }
          }
        }
        std::sort(look.begin(), look.end());
        look.erase(std::unique(look.begin(), look.end()), look.end());
        if (!kept_any && st.undone == undone_before && st.kept_out == kept_out_before) break;
      }
    }
    st.left = find(all, limit_).size();
    return st;
  }

 private:
  /// The triangles at vertex v, in increasing order (valid until an edit changes v's list).
  std::span<const std::uint32_t> faces(std::uint32_t v) const {
    if (const auto it = faces_.find(v); it != faces_.end()) return it->second;
    return {base_faces_.data() + first_face_[v], base_faces_.data() + first_face_[v + 1]};
  }
  std::vector<std::uint32_t> neighbours(std::uint32_t v) const {
    std::vector<std::uint32_t> out;
    const std::span<const std::uint32_t> around = faces(v);
    out.reserve(2 * around.size());
    for (const std::uint32_t f : around) {
      for (const std::uint32_t w : m_.triangles[f]) {
        if (w != v) out.push_back(w);
      }
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

  /// The triangles of `among` (increasing) with an angle under `limit` (radians, under 90
  /// degrees), in increasing order: an angle atan2(|cross|, dot) is under it where the dot is
  /// positive and |cross| < tan(limit) dot, or where the triangle is degenerate.
  std::vector<std::uint32_t> find(const std::vector<std::uint32_t>& among, double limit) const {
    const double tan_limit = std::tan(limit);
    auto sliver = [&](const Tri& t) {
      for (int k = 0; k < 3; ++k) {
        const dvec3 a = m_.positions[t[(k + 1) % 3]] - m_.positions[t[k]], b = m_.positions[t[(k + 2) % 3]] - m_.positions[t[k]];
        const double c = glm::length(glm::cross(a, b)), d = glm::dot(a, b);
        if (!(c > 0) || (d > 0 && c < tan_limit * d)) return true;
      }
      return false;
    };
    std::vector<std::uint32_t> out;
    for (const std::uint32_t f : among) {
      const Tri& t = m_.triangles[f];
      if (!collapsed(t) && sliver(t)) out.push_back(f);
    }
    return out;
  }

  /// The other triangle on edge a->b of triangle f (the one holding b->a), if exactly one.
  std::optional<std::uint32_t> across(std::uint32_t f, std::uint32_t a, std::uint32_t b) const {
    std::optional<std::uint32_t> found;
    int n = 0;
    for (const std::uint32_t g : faces(a)) {
      if (g == f) continue;
      const Tri& t = m_.triangles[g];
      for (int k = 0; k < 3; ++k) {
        if (t[k] == b && t[(k + 1) % 3] == a) {
          found = g;
          ++n;
        }
        if (t[k] == a && t[(k + 1) % 3] == b) n += 2;  // a->b twice: not a manifold edge
      }
    }
    return n == 1 ? found : std::nullopt;
  }

  /// The corner UV of vertex v in triangle f.
  glm::vec2 uv(std::uint32_t f, std::uint32_t v) const { return m_.corner_uvs[f][corner_of(f, v)]; }
  void set_triangle(Edit& e, std::uint32_t f, const Tri& t, const CornerUvs* uv) {
    e.triangles.emplace_back(f, m_.triangles[f]);
    m_.triangles[f] = t;
    if (uvs_) {
      e.uvs.emplace_back(f, m_.corner_uvs[f]);
      if (uv) m_.corner_uvs[f] = *uv;
    }
  }
  void set_faces(Edit& e, std::uint32_t v, std::vector<std::uint32_t> list) {
    const auto it = faces_.find(v);
    e.faces.emplace_back(v, it == faces_.end() ? std::nullopt : std::optional(it->second));
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    faces_[v] = std::move(list);
  }
  void undo(Edit& e) {
    for (auto it = e.uvs.rbegin(); it != e.uvs.rend(); ++it) m_.corner_uvs[it->first] = it->second;
    for (auto it = e.triangles.rbegin(); it != e.triangles.rend(); ++it) m_.triangles[it->first] = it->second;
    for (auto it = e.faces.rbegin(); it != e.faces.rend(); ++it) {
      if (it->second) {
        faces_[it->first] = *it->second;
      } else {
        faces_.erase(it->first);
      }
    }
    if (e.position) m_.positions[e.position->first] = e.position->second;
  }

  /// Twice the signed area of a triangle's corner UVs, or 0 where it is too thin to tell (its
  /// sign then; under 1e-9 of its longest edge squared: a triangle collapsed in UV).
  static int uv_sign(const CornerUvs& u) {
    const glm::dvec2 p(u[0]), q(u[1]), r(u[2]);
    const double area = (q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x);
    const double l2 = std::max({glm::dot(q - p, q - p), glm::dot(r - q, r - q), glm::dot(p - r, p - r)});
    return std::abs(area) > 1e-9 * l2 ? (area > 0 ? 1 : -1) : 0;
  }
  /// Whether new corner UVs keep a triangle's orientation in UV (any, where it had none).
  bool keeps_uv_side(const CornerUvs& was, const CornerUvs& now) const {
    if (!uvs_) return true;
    const int s = uv_sign(was);
    return s == 0 || uv_sign(now) == s;
  }

  /// The corner of vertex v in triangle h (0, 1 or 2).
  int corner_of(std::uint32_t h, std::uint32_t v) const {
    const Tri& t = m_.triangles[h];
    return t[0] == v ? 0 : (t[1] == v ? 1 : 2);
  }
  /// The triangle next to h around vertex v: across h's edge (v, q) where h = (v, p, q)
  /// (`forward`), else across (v, p); with the shared vertex.
  std::optional<std::pair<std::uint32_t, std::uint32_t>> turn_around(std::uint32_t v, std::uint32_t h, bool forward) const {
    const int k = corner_of(h, v);
    const std::uint32_t z = m_.triangles[h][(k + (forward ? 2 : 1)) % 3];
    for (const std::uint32_t n : faces(v)) {
      if (n == h) continue;
      const int j = corner_of(n, v);
      if (m_.triangles[n][(j + (forward ? 1 : 2)) % 3] == z) return std::pair(n, z);
    }
    return std::nullopt;
  }

  /// The UV that triangle h's own linear map (its corners' positions to their UVs) gives the
  /// point p projected onto its plane; empty where h is degenerate.
  std::optional<glm::vec2> extrapolate(std::uint32_t h, const dvec3& p) const {
    const Tri& t = m_.triangles[h];
    const dvec3 &o = m_.positions[t[0]], &p1 = m_.positions[t[1]], &p2 = m_.positions[t[2]];
    const dvec3 e1 = p1 - o, e2 = p2 - o;
    const double a = glm::dot(e1, e1), b = glm::dot(e1, e2), c = glm::dot(e2, e2);
    if (!(a * c - b * b > 1e-12 * a * c)) return std::nullopt;
    const dvec3 l = barycentric(o, p1, p2, p);
    const CornerUvs& u = m_.corner_uvs[h];
    const glm::dvec2 out = glm::dvec2(u[0]) + l.y * glm::dvec2(u[1] - u[0]) + l.z * glm::dvec2(u[2] - u[0]);
    if (!std::isfinite(out.x) || !std::isfinite(out.y)) return std::nullopt;
    return glm::vec2(out);
  }

  /// The UV that vertex v, moved to point p whose UV is `uv1` in triangle s1 and `uv2` in
  /// triangle s2 (both at v), takes in each triangle at v. The UVs are carried around v from
  /// s1 one way and from s2 the other, through edges where the two triangles' UVs differ by
  /// one translation at both ends (none, or u's wrap), so the texture stays continuous where it
  /// was. Past another seam (charts that meet at a fork or a cut line) the triangles in between
  /// take the UV their best-shaped one's own map gives p (extrapolate), carried on from there.
  /// Empty where a triangle cannot be given one.
  std::optional<std::vector<std::pair<std::uint32_t, glm::vec2>>> carry(std::uint32_t v, const dvec3& p, std::uint32_t s1,
                                                                         std::uint32_t s2, glm::vec2 uv1, glm::vec2 uv2,
                                                                         bool* extrapolated = nullptr) const {
    const std::span<const std::uint32_t> fan = faces(v);
    std::vector<std::pair<std::uint32_t, glm::vec2>> out;
    if (!uvs_) {
      for (const std::uint32_t h : fan) out.emplace_back(h, glm::vec2(0));
      return out;
    }
    auto assigned = [&](std::uint32_t h) {
      return std::any_of(out.begin(), out.end(), [&](const auto& q) { return q.first == h; });
    };
    auto walk = [&](std::uint32_t h, glm::vec2 at, bool forward) {
      for (std::size_t steps = 0; steps < fan.size(); ++steps) {
        const auto next = turn_around(v, h, forward);
        if (!next || assigned(next->first)) return;
        const auto [n, z] = *next;
        const glm::vec2 shift = uv(n, v) - uv(h, v), other = uv(n, z) - uv(h, z);
        if (std::abs(shift.x - other.x) > kUvTolerance || std::abs(shift.y - other.y) > kUvTolerance) return;
        at += shift;
        out.emplace_back(n, at);
        h = n;
      }
    };
    auto start = [&](std::uint32_t h, glm::vec2 at) {
      out.emplace_back(h, at);
      walk(h, at, true);
      walk(h, at, false);
    };
    start(s1, uv1);
    if (!assigned(s2)) start(s2, uv2);
    while (out.size() < fan.size()) {
      std::optional<std::uint32_t> best;
      double best_angle = 0;
      for (const std::uint32_t h : fan) {
        if (assigned(h)) continue;
        const double angle = smallest_angle(m_, m_.triangles[h]);
        if (!best || angle > best_angle) best = h, best_angle = angle;
      }
      const std::optional<glm::vec2> at = extrapolate(*best, p);
      if (!at) return std::nullopt;
      if (extrapolated) *extrapolated = true;
      start(*best, *at);
    }
    return out;
  }

  /// A flip of edge (a, b) of sliver f = (c, a, b) with g = (d, b, a): the new triangles and
  /// the pair's smallest angle after.
  struct Flip {
    std::uint32_t g;
    Tri t1, t2;
    CornerUvs u1, u2;
    double angle;
    std::array<std::uint32_t, 3> key;
  };
  /// The smallest local radius of the given vertices (SliverOptions::vertex_radius), 0 where
  /// one is unknown and in the needles' phase (no limit on the move then: a needle's edit
  /// moves the surface by less than the needle's width).
  double scale(std::initializer_list<std::uint32_t> vs) const {
    if (o_.vertex_radius.size() != m_.positions.size() || !(o_.max_move > 0) || !(limit_ > kNeedle)) return 0;
    double r = INFINITY;
    for (const std::uint32_t v : vs) r = std::min(r, o_.vertex_radius[v]);
    return std::isfinite(r) && r > 0 ? r : 0;
  }
  /// The distance from q to triangle t as the mesh is now.
  double distance_to(const dvec3& q, const Tri& t) const {
    return glm::length(q - closest_on_triangle(q, m_.positions[t[0]], m_.positions[t[1]], m_.positions[t[2]]));
  }

  /// The key of flipping the edge opposite corner k of triangle f (Edit::key).
  std::array<std::uint32_t, 3> flip_key(std::uint32_t f, int k) const {
    const Tri& t = m_.triangles[f];
    return {0, std::min(t[(k + 1) % 3], t[(k + 2) % 3]), std::max(t[(k + 1) % 3], t[(k + 2) % 3])};
  }
  std::optional<Flip> plan_flip(std::uint32_t f, int k) const {
    const Tri t = m_.triangles[f];
    const std::uint32_t c = t[k], a = t[(k + 1) % 3], b = t[(k + 2) % 3];
    const std::optional<std::uint32_t> og = across(f, a, b);
    if (!og) return std::nullopt;
    const std::uint32_t g = *og;
    const Tri tg = m_.triangles[g];
    std::uint32_t d = tg[0];
    for (const std::uint32_t v : tg) {
      if (v != a && v != b) d = v;
    }
    if (d == c) return std::nullopt;
    // The surface moves by at most the old edge's midpoint from the new pair, and the new
    // edge's from the old pair.
    if (const double r = scale({a, b, c, d}); r > 0) {
      const Tri t1{a, d, c}, t2{d, b, c};
      const dvec3 old_mid = 0.5 * (m_.positions[a] + m_.positions[b]), new_mid = 0.5 * (m_.positions[c] + m_.positions[d]);
      if (std::min(distance_to(old_mid, t1), distance_to(old_mid, t2)) > o_.max_move * r ||
          std::min(distance_to(new_mid, t), distance_to(new_mid, tg)) > o_.max_move * r) {
        return std::nullopt;
      }
    }
    const std::vector<std::uint32_t> nc = neighbours(c);
    if (std::binary_search(nc.begin(), nc.end(), d)) return std::nullopt;
    Flip p{.g = g, .t1 = {a, d, c}, .t2 = {d, b, c}, .u1 = {}, .u2 = {}, .angle = 0, .key = flip_key(f, k)};
    const dvec3 was = m_.face_normal(t) + m_.face_normal(tg);
    if (!within(m_.face_normal(p.t1), was, cos_turn_) || !within(m_.face_normal(p.t2), was, cos_turn_)) return std::nullopt;
    p.angle = std::min(smallest_angle(m_, p.t1), smallest_angle(m_, p.t2));
    if (p.angle <= std::min(smallest_angle(m_, t), smallest_angle(m_, tg))) return std::nullopt;
    if (uvs_) {
      // Across a seam where the two sides differ by a translation (u's wrap), the new
      // triangles take f's side and the seam runs along g's other two edges. Across another
      // seam they take the side of the better-shaped triangle, the far vertex's UV given by
      // its map (extrapolate), and the seam runs along the other triangle's two edges.
      const glm::vec2 shift = uv(g, a) - uv(f, a), other = uv(g, b) - uv(f, b);
      std::uint32_t side = f;
      if (std::abs(shift.x - other.x) <= kUvTolerance && std::abs(shift.y - other.y) <= kUvTolerance) {
        p.u1 = {uv(f, a), uv(g, d) - shift, uv(f, c)};
      } else if (smallest_angle(m_, tg) >= smallest_angle(m_, t)) {
        side = g;
        const std::optional<glm::vec2> at_c = extrapolate(g, m_.positions[c]);
        if (!at_c) return std::nullopt;
        p.u1 = {uv(g, a), uv(g, d), *at_c};
      } else {
        const std::optional<glm::vec2> at_d = extrapolate(f, m_.positions[d]);
        if (!at_d) return std::nullopt;
        p.u1 = {uv(f, a), *at_d, uv(f, c)};
      }
      p.u2 = {p.u1[1], uv(side, b), p.u1[2]};
      if (!keeps_uv_side(m_.corner_uvs[side], p.u1) || !keeps_uv_side(m_.corner_uvs[side], p.u2)) return std::nullopt;
    }
    return p;
  }

  /// Flips the edge of sliver f that leaves the larger smallest angle, where that keeps the
  /// rules (slivers.h).
  bool try_flip(std::uint32_t f, Edit& e) {
    std::optional<Flip> best;
    for (int k = 0; k < 3; ++k) {
      if (forbidden_.contains(flip_key(f, k))) continue;
      if (std::optional<Flip> p = plan_flip(f, k); p && (!best || p->angle > best->angle)) best = std::move(p);
    }
    if (!best) return false;
    e.key = best->key;
    const std::uint32_t a = best->t1[0], d = best->t1[1], c = best->t1[2], b = best->t2[1];
    auto without = [](std::span<const std::uint32_t> in, std::uint32_t x) {
      std::vector<std::uint32_t> l(in.begin(), in.end());
      l.erase(std::remove(l.begin(), l.end(), x), l.end());
      return l;
    };
    auto with = [](std::span<const std::uint32_t> in, std::uint32_t x) {
      std::vector<std::uint32_t> l(in.begin(), in.end());
      l.push_back(x);
      return l;
    };
    set_faces(e, a, without(faces(a), best->g));
    set_faces(e, b, without(faces(b), f));
    set_faces(e, c, with(faces(c), best->g));
    set_faces(e, d, with(faces(d), f));
    set_triangle(e, f, best->t1, &best->u1);
    set_triangle(e, best->g, best->t2, &best->u2);
    return true;
  }

  /// A collapse of edge (v, w): v removed and its triangles joined to w, which stays or (with
  /// `midpoint`) moves to the edge's midpoint. The triangles it changes as they become, the
  /// smallest angle among them and the removed vertex's distance from its surface.
  struct Collapse {
    std::uint32_t v, w, t1, t2, x, y;
    dvec3 at;
    std::vector<std::tuple<std::uint32_t, Tri, CornerUvs>> changes;
    double angle = 0;
    double error = 0;
  };
  std::optional<Collapse> plan_collapse(std::uint32_t v, std::uint32_t w, bool midpoint, bool better = true) const {
    Collapse p{.v = v, .w = w, .t1 = 0, .t2 = 0, .x = 0, .y = 0, .at = m_.positions[w], .changes = {}};
    // The edge's two triangles t1 = (v, w, x) and t2 = (w, v, y), and no other.
    int on_edge = 0, found = 0;
    for (const std::uint32_t h : faces(v)) {
      const Tri& t = m_.triangles[h];
      const int k = corner_of(h, v);
      if (t[(k + 1) % 3] == w) {
        p.t1 = h, p.x = t[(k + 2) % 3], found |= 1, ++on_edge;
      } else if (t[(k + 2) % 3] == w) {
        p.t2 = h, p.y = t[(k + 1) % 3], found |= 2, ++on_edge;
      }
    }
    if (found != 3 || on_edge != 2 || p.x == p.y) return std::nullopt;
    // The removed vertex (and w, where it moves) stays within max_move of the new surface
    // (tested first: on twigs it refuses most collapses).
    if (const double r = scale({v, w}); r > 0) {
      const dvec3 w_was = m_.positions[w], v_at = m_.positions[v];
      const dvec3 mid = 0.5 * (v_at + w_was);
      const MovedVertex after{m_, w, midpoint ? (r_.grid > 0 ? snap_to_grid(mid, r_.grid) : mid) : w_was};
      double dv = INFINITY, dw = midpoint ? double(INFINITY) : 0.0;
      auto measure = [&](std::uint32_t h) {
        if (h == p.t1 || h == p.t2) return;
        Tri n = m_.triangles[h];
        for (std::uint32_t& x : n) x = x == v ? w : x;
        auto distance = [&](const dvec3& q) { return glm::length(q - closest_on_triangle(q, after(n[0]), after(n[1]), after(n[2]))); };
        dv = std::min(dv, distance(v_at));
        if (midpoint) dw = std::min(dw, distance(w_was));
      };
      for (const std::uint32_t h : faces(v)) measure(h);
      if (midpoint) {
        for (const std::uint32_t h : faces(w)) measure(h);
      }
      if (std::max(dv, dw) > o_.max_move * r) return std::nullopt;
    }
    // Link condition: v and w share exactly the neighbours x and y; both keep three or more.
    const std::vector<std::uint32_t> nv = neighbours(v), nw = neighbours(w);
    std::vector<std::uint32_t> common;
    std::set_intersection(nv.begin(), nv.end(), nw.begin(), nw.end(), std::back_inserter(common));
    if (common.size() != 2 || neighbours(p.x).size() < 4 || neighbours(p.y).size() < 4) return std::nullopt;
    std::vector<std::uint32_t> changed(faces(v).begin(), faces(v).end());
    if (midpoint) {
      const dvec3 mid = 0.5 * (m_.positions[v] + m_.positions[w]);
      p.at = r_.grid > 0 ? snap_to_grid(mid, r_.grid) : mid;
      std::vector<std::uint32_t> near;  // for coincidence: every neighbour of either
      std::set_union(nv.begin(), nv.end(), nw.begin(), nw.end(), std::back_inserter(near));
      for (const std::uint32_t n : near) {
        if (m_.positions[n] == p.at) return std::nullopt;
      }
      const std::span<const std::uint32_t> fw = faces(w);
      std::vector<std::uint32_t> both;
      std::set_union(changed.begin(), changed.end(), fw.begin(), fw.end(), std::back_inserter(both));
      changed = std::move(both);
    }
    double before = std::numbers::pi;
    for (const std::uint32_t h : changed) before = std::min(before, smallest_angle(m_, m_.triangles[h]));
    // The angles after first (positions only): most collapses tried on a twig's needles leave
    // no better triangles, and the UVs and normals below cost more.
    if (better) {
      const MovedVertex moved{m_, w, p.at};
      for (const std::uint32_t h : changed) {
        if (h == p.t1 || h == p.t2) continue;
        Tri n = m_.triangles[h];
        for (std::uint32_t& x : n) x = x == v ? w : x;
        if (smallest_angle(moved, n) <= before) return std::nullopt;
      }
    }
    // The UVs of the moved corners, carried around each moved vertex from the edge's triangles.
    auto target = [&](std::uint32_t h) { return midpoint ? 0.5f * (uv(h, v) + uv(h, w)) : uv(h, w); };
    bool mixed = false;  // charts that differ by more than a translation meet at v or w
    const auto at_v = carry(v, p.at, p.t1, p.t2, uvs_ ? target(p.t1) : glm::vec2(0), uvs_ ? target(p.t2) : glm::vec2(0), &mixed);
    if (!at_v) return std::nullopt;
    std::optional<std::vector<std::pair<std::uint32_t, glm::vec2>>> at_w;
    if (midpoint) {
      at_w = carry(w, p.at, p.t2, p.t1, uvs_ ? target(p.t2) : glm::vec2(0), uvs_ ? target(p.t1) : glm::vec2(0), &mixed);
      if (!at_w) return std::nullopt;
    }
    auto lookup = [](const std::vector<std::pair<std::uint32_t, glm::vec2>>& l, std::uint32_t h) {
      for (const auto& [g, u] : l) {
        if (g == h) return u;
      }
      return glm::vec2(0);
    };
    // The normals before of the changed triangles that are no slivers (all where each is), and
    // whether their texture had one side (it is kept only where it had).
    std::vector<dvec3> normals;
    int sides = 0;
    for (const bool all : {false, true}) {
      for (const std::uint32_t h : changed) {
        if (all || smallest_angle(m_, m_.triangles[h]) >= limit_) normals.push_back(m_.face_normal(m_.triangles[h]));
      }
      if (!normals.empty()) break;
    }
    if (uvs_) {
      for (const std::uint32_t h : changed) sides |= uv_sign(m_.corner_uvs[h]) > 0 ? 1 : (uv_sign(m_.corner_uvs[h]) < 0 ? 2 : 0);
    }
    const bool keep_side = !mixed && sides != 3;
    // An edge under a hundredth of the longest around v joins vertices that stand for one
    // point (a cut line through a vertex): the normals of the triangles it changes, at that
    // scale, are no measure of the surface, which moves by less than the edge.
    double around = 0;
    for (const std::uint32_t h : changed) {
      const Tri& t = m_.triangles[h];
      for (int i = 0; i < 3; ++i) around = std::max(around, glm::length(m_.positions[t[(i + 1) % 3]] - m_.positions[t[i]]));
    }
    const bool duplicate = glm::length(m_.positions[v] - m_.positions[w]) < kDuplicateEdge * around;
    // The changed triangles after: none turned over, each within max_turn of a normal before,
    // none flipped in UV where the texture had one side, the smallest angle larger than before.
    // (w's position is tried and put back)
    const MovedVertex after{m_, w, p.at};
    p.angle = std::numbers::pi;
    bool ok = true;
    for (const std::uint32_t h : changed) {
      if (h == p.t1 || h == p.t2) continue;
      const Tri was = m_.triangles[h];
      Tri n = was;
      CornerUvs u = uvs_ ? m_.corner_uvs[h] : CornerUvs{};
      for (int i = 0; i < 3; ++i) {
        if (n[i] == v) {
          n[i] = w;
          u[i] = lookup(*at_v, h);
        } else if (n[i] == w && midpoint) {
          u[i] = lookup(*at_w, h);
        }
      }
      const dvec3 normal_was = m_.face_normal(was);
      const bool uv_ok = !uvs_ || !keep_side || keeps_uv_side(m_.corner_uvs[h], u);
      const dvec3 normal = after.normal(n);
      ok = uv_ok && (duplicate || (within(normal, normal_was, 0.0) &&
           std::any_of(normals.begin(), normals.end(), [&](const dvec3& o) { return within(normal, o, cos_turn_); })));
      if (!ok) break;
      p.angle = std::min(p.angle, smallest_angle(after, n));
      p.changes.emplace_back(h, n, u);
    }
    if (!ok || (better && p.angle <= before)) return std::nullopt;
    p.error = o_.vertex_error.size() == m_.positions.size() ? o_.vertex_error[v] : 0.0;
    return p;
  }

  /// The collapse removing a vertex of sliver f that keeps the rules (slivers.h) and leaves
  /// the largest smallest angle: each of f's edges either way (the vertex kept stays where it
  /// is), else f's shortest edge onto its midpoint.
  /// Where several leave no sliver, the one removing the vertex farthest from its surface.
  std::optional<Collapse> best_collapse(std::uint32_t f) const {
    const Tri t = m_.triangles[f];
    double shortest = INFINITY;
    int k = 0;  // edge (t[k], t[k + 1]) is the shortest
    for (int i = 0; i < 3; ++i) {
      const double l = glm::length(m_.positions[t[(i + 1) % 3]] - m_.positions[t[i]]);
      if (l < shortest) {
        shortest = l;
        k = i;
      }
    }
    auto better = [&](const Collapse& p, const Collapse& q) {  // p before q
      const double sp = std::min(p.angle, limit_), sq = std::min(q.angle, limit_);
      if (sp != sq) return sp > sq;
      if (p.error != q.error) return p.error > q.error;
      return p.angle > q.angle;
    };
    std::optional<Collapse> best;
    for (const std::uint32_t v : t) {
      for (const std::uint32_t w : t) {
        if (w == v || forbidden_.contains({1, v, w})) continue;
        if (std::optional<Collapse> p = plan_collapse(v, w, false); p && (!best || better(*p, *best))) best = std::move(p);
      }
    }
    if (!best && !forbidden_.contains({2, t[k], t[(k + 1) % 3]})) best = plan_collapse(t[k], t[(k + 1) % 3], true);
    return best;
  }

  /// Applies collapse p (plan_collapse) as part of edit e.
  void apply(const Collapse& p, Edit& e) {
    e.collapse = true;
    e.key = {p.at != m_.positions[p.w] ? 2u : 1u, p.v, p.w};
    if (p.at != m_.positions[p.w]) {
      e.position = std::pair(p.w, m_.positions[p.w]);
      m_.positions[p.w] = p.at;
    }
    std::vector<std::uint32_t> fan;  // the triangles left at w
    {
      const std::span<const std::uint32_t> fv = faces(p.v), fw = faces(p.w);
      std::set_union(fv.begin(), fv.end(), fw.begin(), fw.end(), std::back_inserter(fan));
      std::erase_if(fan, [&](std::uint32_t h) { return h == p.t1 || h == p.t2; });
    }
    auto without = [](std::span<const std::uint32_t> in, std::uint32_t y) {
      std::vector<std::uint32_t> l(in.begin(), in.end());
      l.erase(std::remove(l.begin(), l.end(), y), l.end());
      return l;
    };
    set_faces(e, p.x, without(faces(p.x), p.t1));
    set_faces(e, p.y, without(faces(p.y), p.t2));
    set_faces(e, p.w, fan);
    set_faces(e, p.v, {});
    for (const auto& [h, n, u] : p.changes) set_triangle(e, h, n, &u);
    set_triangle(e, p.t1, {p.w, p.w, p.w}, nullptr);
    set_triangle(e, p.t2, {p.w, p.w, p.w}, nullptr);
  }

  /// Whether sliver f has a flip or a collapse that keeps the rules, or a vertex of three
  /// neighbours near it for try_collapse's two steps (not planned here: rare).
  bool has_edit(std::uint32_t f) const {
    const Tri& t = m_.triangles[f];
    if (collapsed(t)) return false;
    for (int k = 0; k < 3; ++k) {
      if (!forbidden_.contains(flip_key(f, k)) && plan_flip(f, k)) return true;
    }
    return best_collapse(f) || !threes_near(f).empty();
  }

  /// The vertices of three neighbours at or next to f's vertices, sorted (try_collapse).
  /// (On the closed manifold a vertex has as many neighbours as triangles.)
  std::vector<std::uint32_t> threes_near(std::uint32_t f) const {
    std::vector<std::uint32_t> threes;
    for (const std::uint32_t v : m_.triangles[f]) {
      if (faces(v).size() == 3) threes.push_back(v);
      for (const std::uint32_t z : neighbours(v)) {
        if (faces(z).size() == 3) threes.push_back(z);
      }
    }
    std::sort(threes.begin(), threes.end());
    threes.erase(std::unique(threes.begin(), threes.end()), threes.end());
    return threes;
  }

  /// Removes a vertex of sliver f by a collapse (best_collapse). Where none keeps the rules, a
  /// vertex of three neighbours at or next to f's vertices is collapsed first (whatever its
  /// angles), and then the slivers that step left are flipped or collapsed, where the two
  /// together make the smallest angle of the triangles they change larger: such a vertex
  /// inside a triangle of near-coincident or collinear vertices (a cut line passing close to a
  /// vertex) blocks every flip and collapse of their edges.
  bool try_collapse(std::uint32_t f, Edit& e) {
    if (std::optional<Collapse> p = best_collapse(f)) {
      apply(*p, e);
      return true;
    }
    for (const std::uint32_t z : threes_near(f)) {
      if (forbidden_.contains({3, z, f})) continue;
      std::optional<Collapse> first;
      for (const std::uint32_t w : neighbours(z)) {
        if (forbidden_.contains({1, z, w})) continue;
        if (std::optional<Collapse> p = plan_collapse(z, w, false, false); p && (!first || p->angle > first->angle)) first = std::move(p);
      }
      if (!first) continue;
      apply(*first, e);
      // The slivers the first step left among the triangles it changed, each flipped or
      // collapsed where it can be.
      std::vector<std::uint32_t> left;
      for (const auto& [g, old] : e.triangles) {
        if (!collapsed(m_.triangles[g]) && smallest_angle(m_, m_.triangles[g]) < limit_) left.push_back(g);
      }
      for (const std::uint32_t g : left) {
        if (collapsed(m_.triangles[g]) || smallest_angle(m_, m_.triangles[g]) >= limit_) continue;
        Edit next;
        if (!try_flip(g, next)) {
          const std::optional<Collapse> p = best_collapse(g);
          if (!p) continue;
          apply(*p, next);
        }
        if (next.position && e.position) {  // (an edit restores one position)
          undo(next);
          continue;
        }
        e.triangles.insert(e.triangles.end(), next.triangles.begin(), next.triangles.end());
        e.uvs.insert(e.uvs.end(), next.uvs.begin(), next.uvs.end());
        e.faces.insert(e.faces.end(), next.faces.begin(), next.faces.end());
        if (next.position) e.position = next.position;
      }
      double before = std::numbers::pi, after = std::numbers::pi;
      std::vector<std::uint32_t> seen;
      for (const auto& [g, old] : e.triangles) {
        if (std::find(seen.begin(), seen.end(), g) != seen.end()) continue;
        seen.push_back(g);
        if (!collapsed(old)) before = std::min(before, smallest_angle_was(e, old));
        if (!collapsed(m_.triangles[g])) after = std::min(after, smallest_angle(m_, m_.triangles[g]));
      }
      if (after > before) {
        e.key = {3, z, f};
        return true;
      }
      undo(e);
      e = Edit{};
    }
    return false;
  }
  /// The smallest angle triangle g had before edit e (its first recorded value `old`; the
  /// edit moved at most e.position's vertex).
  double smallest_angle_was(const Edit& e, const Tri& old) {
    if (!e.position) return smallest_angle(m_, old);
    const dvec3 now = m_.positions[e.position->first];
    m_.positions[e.position->first] = e.position->second;
    const double a = smallest_angle(m_, old);
    m_.positions[e.position->first] = now;
    return a;
  }

  MeshResult& r_;
  Mesh& m_;
  const SliverOptions& o_;
  const VertexCorners vc_;
  std::vector<std::uint32_t> base_faces_, first_face_;  // faces() before any edit
  const double cos_turn_;
  const bool uvs_;
  double limit_;  // the sliver angle of the phase running (radians)
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> faces_;  // lists changed by edits
  std::set<std::array<std::uint32_t, 3>> forbidden_;  // edits undone for their crossings (Edit::key)
};

}  // namespace

namespace {

/// Where vertex v's round cone (the skeleton edge that made it: Mesh::vertex_node and its
/// parent) is nearest it: the point on the axis and the radius there; none without one.
std::optional<std::pair<dvec3, double>> cone_at(const Mesh& mesh, const Skeleton& skeleton, std::size_t v) {
  if (mesh.vertex_node.size() != mesh.positions.size()) return std::nullopt;
  const NodeId n = mesh.vertex_node[v];
  if (!n.valid() || n.idx() >= skeleton.position.size()) return std::nullopt;
  const NodeId up = skeleton.parent[n.idx()];
  const dvec3 a = skeleton.position[n.idx()], b = up.valid() ? skeleton.position[up.idx()] : a;
  const double ra = skeleton.radius[n.idx()], rb = up.valid() ? skeleton.radius[up.idx()] : ra;
  const double t = segment_param(mesh.positions[v], a, b);
  return std::pair(a + t * (b - a), ra + t * (rb - ra));
}

}  // namespace

std::vector<double> cone_error(const Mesh& mesh, const Skeleton& skeleton) {
  std::vector<double> error(mesh.positions.size(), 0.0);
  for (std::size_t v = 0; v < error.size(); ++v) {
    if (const auto c = cone_at(mesh, skeleton, v); c && c->second > 0) {
      error[v] = std::abs(glm::length(mesh.positions[v] - c->first) - c->second) / c->second;
    }
  }
  return error;
}

std::vector<double> cone_radius(const Mesh& mesh, const Skeleton& skeleton) {
  std::vector<double> radius(mesh.positions.size(), 0.0);
  for (std::size_t v = 0; v < radius.size(); ++v) {
    if (const auto c = cone_at(mesh, skeleton, v)) radius[v] = c->second;
  }
  return radius;
}

SliverStats remove_slivers(MeshResult& mesh, const SliverOptions& options) {
  if (!(options.angle > 0) || mesh.mesh.triangles.empty()) return {};
  return SliverRemover(mesh, options).run();
}

}  // namespace sm
