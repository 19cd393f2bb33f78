// Sliver removal (see slivers.h): flips and collapses checked locally for shape, turn and
// texture seams, then, per round, for crossings with the triangles near them (exact tests).

#include "repair/slivers.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "meshcheck/intersections.h"

namespace sm {
namespace {

using glm::dvec3;
using Tri = Mesh::Triangle;
using CornerUvs = std::array<glm::vec2, 3>;
constexpr double kRadians = std::numbers::pi / 180.0;
/// Two sides of a seam differ by one translation where their shifts agree within this (UV units).
constexpr float kUvTolerance = 1e-5f;

/// The smallest angle of triangle t (radians; 0 where it is degenerate).
double smallest_angle(const Mesh& m, const Tri& t) {
  double best = std::numbers::pi;
  for (int k = 0; k < 3; ++k) {
    const dvec3 a = m.positions[t[(k + 1) % 3]] - m.positions[t[k]], b = m.positions[t[(k + 2) % 3]] - m.positions[t[k]];
    const double c = glm::length(glm::cross(a, b));
    if (!(c > 0)) return 0;
    best = std::min(best, std::atan2(c, glm::dot(a, b)));
  }
  return best;
}

bool collapsed(const Tri& t) { return t[0] == t[1] && t[1] == t[2]; }

/// Whether the angle between u and v is at most the one whose cosine is `cos_max` (false where
/// either is zero).
bool within(const dvec3& u, const dvec3& v, double cos_max) {
  const double lu = glm::length(u), lv = glm::length(v);
  return lu > 0 && lv > 0 && glm::dot(u, v) >= cos_max * lu * lv;
}

/// One edit's previous values, to undo it.
struct Edit {
  std::vector<std::pair<std::uint32_t, Tri>> triangles;
  std::vector<std::pair<std::uint32_t, CornerUvs>> uvs;
  std::vector<std::pair<std::uint32_t, std::optional<std::vector<std::uint32_t>>>> faces;
  std::optional<std::pair<std::uint32_t, dvec3>> position;
  bool collapse = false;
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
  /// Bins triangle f where it lies now (after an edit).
  void add(std::uint32_t f) {
    if (collapsed(m_.triangles[f])) return;
    int level = 0;
    while (level + 1 < kLevels && cell_ * std::ldexp(1.0, level) < extent(f)) ++level;
    levels_[level].push_back(f);
    const auto [lo, hi] = cells(f, level);
    for (auto z = lo.z; z <= hi.z; ++z)
      for (auto y = lo.y; y <= hi.y; ++y)
        for (auto x = lo.x; x <= hi.x; ++x) bins_[key(level, x, y, z)].push_back(f);
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
              if (const auto it = bins_.find(key(level, x, y, z)); it != bins_.end()) {
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
  static std::uint64_t key(int level, std::int64_t x, std::int64_t y, std::int64_t z) {
    const auto h = [](std::int64_t v) { return static_cast<std::uint64_t>(v) * 0x9E3779B97F4A7C15ull; };
    return h(x) ^ (h(y) >> 21 | h(y) << 43) ^ (h(z) >> 42 | h(z) << 22) ^ (static_cast<std::uint64_t>(level) << 58);
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
        uvs_(m_.corner_uvs.size() == m_.triangles.size()) {}

  SliverStats run() {
    SliverStats st;
    const double limit = o_.angle * kRadians;
    const TriangleIntersections intersections(m_);
    LocalCrossings crossings(m_, intersections);
    std::vector<std::uint32_t> all(m_.triangles.size());
    for (std::uint32_t f = 0; f < all.size(); ++f) all[f] = f;
    // The mesh's crossing pairs, found once and kept up to date: an edit may not take part in
    // more of them than its triangles did before it.
    std::vector<std::array<std::uint32_t, 2>> known;
    if (!o_.known_clean) known = intersections.pairs(all);
    // Round 0 looks at every triangle; later rounds only at the slivers left and the
    // triangles the kept edits changed (nothing else moved).
    std::vector<std::uint32_t> look = all;
    std::vector<std::uint8_t> refused(m_.triangles.size(), 0);
    for (int round = 0; round < o_.max_rounds; ++round) {
      std::vector<std::uint32_t> slivers = find(look, limit);
      if (round == 0) st.found = slivers.size();
      if (slivers.empty()) break;
      ++st.rounds;
      const PairsAt before(known);

      std::vector<std::uint8_t> locked(m_.positions.size(), 0);
      std::vector<Edit> edits;
      std::vector<std::uint32_t> origin;  // the sliver each edit is for
      for (const std::uint32_t f : slivers) {
        const Tri t = m_.triangles[f];
        if (refused[f] || collapsed(t) || locked[t[0]] || locked[t[1]] || locked[t[2]]) continue;
        Edit e;
        if (!try_flip(f, e) && !try_collapse(f, e)) continue;
        // Edits of one round touch disjoint vertices (so that any of them can be undone
        // alone): one reaching a vertex an earlier edit of the round touched goes back.
        bool clash = false;
        for (const auto& [g, old] : e.triangles) {
          for (const std::uint32_t v : old) clash = clash || locked[v];
          for (const std::uint32_t v : m_.triangles[g]) clash = clash || locked[v];
        }
        if (clash) {
          undo(e);
          continue;
        }
        for (const auto& [g, old] : e.triangles) {
          for (const std::uint32_t v : old) locked[v] = 1;
          for (const std::uint32_t v : m_.triangles[g]) locked[v] = 1;
        }
        edits.push_back(std::move(e));
        origin.push_back(f);
      }
      // Edits whose triangles cross more than before are undone, until none does; their
      // slivers are not tried again. `now` holds the pairs of the triangles `changed` as the
      // mesh is now: after an undo only the restored triangles' pairs are found again.
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
          active[i] = 0;
          refused[origin[i]] = 1;
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
      look = slivers;
      for (std::size_t i = 0; i < edits.size(); ++i) {
        if (!active[i]) continue;
        kept_any = true;
        ++(edits[i].collapse ? st.collapses : st.flips);
        for (const auto& [g, old] : edits[i].triangles) look.push_back(g);
      }
      std::sort(look.begin(), look.end());
      look.erase(std::unique(look.begin(), look.end()), look.end());
      if (!kept_any) break;
    }
    st.left = find(all, limit).size();
    return st;
  }

 private:
  /// The triangles at vertex v, in increasing order.
  std::vector<std::uint32_t> faces(std::uint32_t v) const {
    if (const auto it = faces_.find(v); it != faces_.end()) return it->second;
    std::vector<std::uint32_t> out;
    for (std::uint32_t k = vc_.begin[v]; k < vc_.begin[v + 1]; ++k) out.push_back(vc_.corner[k] / 3);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }
  std::vector<std::uint32_t> neighbours(std::uint32_t v) const {
    std::vector<std::uint32_t> out;
    for (const std::uint32_t f : faces(v)) {
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
  glm::vec2 uv(std::uint32_t f, std::uint32_t v) const {
    const Tri& t = m_.triangles[f];
    return m_.corner_uvs[f][t[0] == v ? 0 : (t[1] == v ? 1 : 2)];
  }
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

  /// Flips the longest edge of sliver f where that keeps the rules (slivers.h).
  bool try_flip(std::uint32_t f, Edit& e) {
    const Tri t = m_.triangles[f];
    int k = 0;  // the corner of the largest angle, opposite the longest edge
    double longest = -1;
    for (int i = 0; i < 3; ++i) {
      const double l = glm::length(m_.positions[t[(i + 2) % 3]] - m_.positions[t[(i + 1) % 3]]);
      if (l > longest) {
        longest = l;
        k = i;
      }
    }
    const std::uint32_t c = t[k], a = t[(k + 1) % 3], b = t[(k + 2) % 3];
    const std::optional<std::uint32_t> og = across(f, a, b);
    if (!og) return false;
    const std::uint32_t g = *og;
    const Tri tg = m_.triangles[g];
    std::uint32_t d = tg[0];
    for (const std::uint32_t v : tg) {
      if (v != a && v != b) d = v;
    }
    if (d == c) return false;
    const std::vector<std::uint32_t> nc = neighbours(c);
    if (std::binary_search(nc.begin(), nc.end(), d)) return false;  // the edge c-d exists already
    // Across a texture seam the new triangles take f's side, where the two sides differ by a
    // translation (u's wrap): the seam then runs along g's other two edges.
    glm::vec2 shift(0);
    if (uvs_) {
      shift = uv(g, a) - uv(f, a);
      const glm::vec2 other = uv(g, b) - uv(f, b);
      if (std::abs(shift.x - other.x) > kUvTolerance || std::abs(shift.y - other.y) > kUvTolerance) return false;
    }
    const Tri t1{a, d, c}, t2{d, b, c};
    const dvec3 was = m_.face_normal(t) + m_.face_normal(tg);
    if (!within(m_.face_normal(t1), was, cos_turn_) || !within(m_.face_normal(t2), was, cos_turn_)) return false;
    if (std::min(smallest_angle(m_, t1), smallest_angle(m_, t2)) <= std::min(smallest_angle(m_, t), smallest_angle(m_, tg)))
      return false;
    const CornerUvs u1{uvs_ ? uv(f, a) : glm::vec2(0), uvs_ ? uv(g, d) - shift : glm::vec2(0), uvs_ ? uv(f, c) : glm::vec2(0)};
    const CornerUvs u2{u1[1], uvs_ ? uv(f, b) : glm::vec2(0), u1[2]};
    auto without = [](std::vector<std::uint32_t> l, std::uint32_t x) {
      l.erase(std::remove(l.begin(), l.end(), x), l.end());
      return l;
    };
    auto with = [](std::vector<std::uint32_t> l, std::uint32_t x) {
      l.push_back(x);
      return l;
    };
    set_faces(e, a, without(faces(a), g));
    set_faces(e, b, without(faces(b), f));
    set_faces(e, c, with(faces(c), g));
    set_faces(e, d, with(faces(d), f));
    set_triangle(e, f, t1, &u1);
    set_triangle(e, g, t2, &u2);
    return true;
  }

  /// Collapses the shortest edge of sliver f where that keeps the rules (slivers.h).
  bool try_collapse(std::uint32_t f, Edit& e) {
    const Tri t = m_.triangles[f];
    int k = 0;  // edge (t[k], t[k + 1]) is the shortest
    double shortest = INFINITY;
    for (int i = 0; i < 3; ++i) {
      const double l = glm::length(m_.positions[t[(i + 1) % 3]] - m_.positions[t[i]]);
      if (l < shortest) {
        shortest = l;
        k = i;
      }
    }
    const std::uint32_t a = t[k], b = t[(k + 1) % 3], c = t[(k + 2) % 3];
    const std::optional<std::uint32_t> og = across(f, a, b);
    if (!og) return false;
    const std::uint32_t g = *og;
    std::uint32_t d = c;
    for (const std::uint32_t v : m_.triangles[g]) {
      if (v != a && v != b) d = v;
    }
    if (d == c) return false;
    // Link condition: a and b share exactly the neighbours c and d; both keep three or more.
    const std::vector<std::uint32_t> na = neighbours(a), nb = neighbours(b);
    std::vector<std::uint32_t> common;
    std::set_intersection(na.begin(), na.end(), nb.begin(), nb.end(), std::back_inserter(common));
    if (common.size() != 2 || neighbours(c).size() < 4 || neighbours(d).size() < 4) return false;
    const std::vector<std::uint32_t> fa = faces(a), fb = faces(b);
    std::vector<std::uint32_t> fan;  // the triangles left at the merged vertex
    std::set_union(fa.begin(), fa.end(), fb.begin(), fb.end(), std::back_inserter(fan));
    double worst_before = std::numbers::pi;
    for (const std::uint32_t h : fan) worst_before = std::min(worst_before, smallest_angle(m_, m_.triangles[h]));
    fan.erase(std::remove_if(fan.begin(), fan.end(), [&](std::uint32_t h) { return h == f || h == g; }), fan.end());
    std::vector<dvec3> was;  // the fan's normals before
    for (const std::uint32_t h : fan) was.push_back(m_.face_normal(m_.triangles[h]));
    const glm::vec2 ua = uvs_ ? uv(f, a) : glm::vec2(0), ub = uvs_ ? uv(f, b) : glm::vec2(0);
    const dvec3 pa = m_.positions[a], pb = m_.positions[b];
    const dvec3 mid = r_.grid > 0 ? snap_to_grid(0.5 * (pa + pb), r_.grid) : 0.5 * (pa + pb);
    struct Target {
      std::uint32_t keep, drop;
      dvec3 at;
      glm::vec2 uv;
    };
    // The ends first (the vertex that stays is where it was), the one nearer the surface first.
    const bool b_first = o_.vertex_error.size() == m_.positions.size() && o_.vertex_error[b] < o_.vertex_error[a];
    const Target targets[] = {b_first ? Target{b, a, pb, ub} : Target{a, b, pa, ua},
                              b_first ? Target{a, b, pa, ua} : Target{b, a, pb, ub}, {a, b, mid, 0.5f * (ua + ub)}};
    std::vector<std::uint32_t> near;  // for coincidence: every neighbour of either
    std::set_union(na.begin(), na.end(), nb.begin(), nb.end(), std::back_inserter(near));
    for (const Target& x : targets) {
      if (x.at != pa && x.at != pb) {
        bool coincident = false;
        for (const std::uint32_t w : near) coincident = coincident || m_.positions[w] == x.at;
        if (coincident) continue;
      }
      // The fan's triangles after the collapse: none turned too far, none worse than before.
      bool ok = true;
      double worst_after = std::numbers::pi;
      const dvec3 keep_at = m_.positions[x.keep];
      m_.positions[x.keep] = x.at;
      for (std::size_t i = 0; i < fan.size() && ok; ++i) {
        Tri n = m_.triangles[fan[i]];
        for (std::uint32_t& v : n) {
          if (v == x.drop) v = x.keep;
        }
        ok = within(m_.face_normal(n), was[i], cos_turn_);
        worst_after = std::min(worst_after, smallest_angle(m_, n));
      }
      m_.positions[x.keep] = keep_at;
      if (!ok || worst_after <= worst_before) continue;
      // Apply.
      e.collapse = true;
      e.position = std::pair(x.keep, keep_at);
      m_.positions[x.keep] = x.at;
      for (const std::uint32_t h : fan) {
        Tri n = m_.triangles[h];
        CornerUvs u = uvs_ ? m_.corner_uvs[h] : CornerUvs{};
        for (int i = 0; i < 3; ++i) {
          // Each corner moves in UV as its vertex does on f (across a seam of u's wrap, the
          // same translation); the vertex that stays keeps its UVs where it does not move.
          if (uvs_ && n[i] == x.drop) u[i] += x.uv - uv(f, x.drop);
          if (uvs_ && n[i] == x.keep && x.at != keep_at) u[i] += x.uv - uv(f, x.keep);
          if (n[i] == x.drop) n[i] = x.keep;
        }
        set_triangle(e, h, n, &u);
      }
      set_triangle(e, f, {x.keep, x.keep, x.keep}, nullptr);  // (after the fan: uv(f, .) read above)
      set_triangle(e, g, {x.keep, x.keep, x.keep}, nullptr);
      set_faces(e, x.keep, fan);
      set_faces(e, x.drop, {});
      auto without = [](std::vector<std::uint32_t> l, std::uint32_t y) {
        l.erase(std::remove(l.begin(), l.end(), y), l.end());
        return l;
      };
      set_faces(e, c, without(faces(c), f));
      set_faces(e, d, without(faces(d), g));
      return true;
    }
    return false;
  }

  MeshResult& r_;
  Mesh& m_;
  const SliverOptions& o_;
  const VertexCorners vc_;
  const double cos_turn_;
  const bool uvs_;
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> faces_;  // lists changed by edits
};

}  // namespace

std::vector<double> cone_error(const Mesh& mesh, const Skeleton& skeleton) {
  std::vector<double> error(mesh.positions.size(), 0.0);
  if (mesh.vertex_node.size() != mesh.positions.size()) return error;
  for (std::size_t v = 0; v < error.size(); ++v) {
    const NodeId n = mesh.vertex_node[v];
    if (!n.valid() || n.idx() >= skeleton.position.size()) continue;
    const NodeId up = skeleton.parent[n.idx()];
    const dvec3 a = skeleton.position[n.idx()], b = up.valid() ? skeleton.position[up.idx()] : a;
    const double ra = skeleton.radius[n.idx()], rb = up.valid() ? skeleton.radius[up.idx()] : ra;
    const double t = segment_param(mesh.positions[v], a, b);
    const double r = ra + t * (rb - ra);
    if (r > 0) error[v] = std::abs(glm::length(mesh.positions[v] - (a + t * (b - a))) - r) / r;
  }
  return error;
}

SliverStats remove_slivers(MeshResult& mesh, const SliverOptions& options) {
  if (!(options.angle > 0) || mesh.mesh.triangles.empty()) return {};
  return SliverRemover(mesh, options).run();
}

}  // namespace sm
