// Simplification by half-edge collapses, each checked against the whole mesh (see simplify.h).

#include "lod/simplify.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <queue>
#include <tuple>
#include <unordered_map>

#include "meshcheck/intersections.h"

namespace sm {

namespace {

using glm::dvec3;

/// The quadric of a set of planes (Garland-Heckbert), symmetric 4 x 4 in 10 numbers.
struct Quadric {
  double a[10] = {};
  void add_plane(const dvec3& n, double d, double w) {
    const double p[4] = {n.x, n.y, n.z, d};
    int k = 0;
    for (int i = 0; i < 4; ++i) {
      for (int j = i; j < 4; ++j) a[k++] += w * p[i] * p[j];
    }
  }
  Quadric& operator+=(const Quadric& o) {
    for (int k = 0; k < 10; ++k) a[k] += o.a[k];
    return *this;
  }
  /// Sum over the planes of w x (distance of p)^2.
  [[nodiscard]] double at(const dvec3& p) const {
    const double x[4] = {p.x, p.y, p.z, 1.0};
    double s = 0;
    int k = 0;
    for (int i = 0; i < 4; ++i) {
      for (int j = i; j < 4; ++j, ++k) s += (i == j ? 1.0 : 2.0) * a[k] * x[i] * x[j];
    }
    return std::max(s, 0.0);
  }
};

/// A uniform grid of triangle boxes. A triangle is entered in every cell its box touches when
/// it is entered; entries are never removed (a query filters by the current boxes).
class BoxGrid {
 public:
  BoxGrid(const dvec3& origin, double cell) : origin_(origin), cell_(cell) {}

  void insert(std::uint32_t t, const dvec3& lo, const dvec3& hi) {
    for_cells(lo, hi, [&](std::uint64_t key) { cells_[key].push_back(t); });
  }
  template <class F>
  void query(const dvec3& lo, const dvec3& hi, F&& visit) const {
    for_cells(lo, hi, [&](std::uint64_t key) {
      if (const auto it = cells_.find(key); it != cells_.end()) {
        for (const std::uint32_t t : it->second) visit(t);
      }
    });
  }

 private:
  template <class F>
  void for_cells(const dvec3& lo, const dvec3& hi, F&& f) const {
    const glm::i64vec3 a = index(lo), b = index(hi);
    for (std::int64_t x = a.x; x <= b.x; ++x) {
      for (std::int64_t y = a.y; y <= b.y; ++y) {
        for (std::int64_t z = a.z; z <= b.z; ++z) {
          f((std::uint64_t(x & 0x1FFFFF) << 42) | (std::uint64_t(y & 0x1FFFFF) << 21) | std::uint64_t(z & 0x1FFFFF));
        }
      }
    }
  }
  [[nodiscard]] glm::i64vec3 index(const dvec3& p) const {
    const dvec3 q = glm::floor((p - origin_) / cell_);
    return {std::int64_t(q.x), std::int64_t(q.y), std::int64_t(q.z)};
  }
  dvec3 origin_;
  double cell_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
};

class Simplifier {
 public:
  Simplifier(Mesh& mesh, const SimplifyParams& params, SimplifyStats& stats)
      : m_(mesh), p_(params), st_(stats), tests_(mesh), grid_(lower_corner(mesh), cell_size(mesh, params)) {
    const std::size_t nv = m_.positions.size(), nf = m_.triangles.size();
    around_.resize(nv);
    version_.assign(nv, 0);
    quadric_.resize(nv);
    weight_.assign(nv, 0.0);
    dead_.assign(nf, 0);
    seen_.assign(nf, 0);
    mark_.assign(nv, 0);
    cos_turn_ = std::cos(p_.max_normal_turn * M_PI / 180.0);
    for (std::uint32_t f = 0; f < nf; ++f) {
      const auto& t = m_.triangles[f];
      for (const std::uint32_t v : t) around_[v].push_back(f);
      const dvec3 n = m_.face_normal(t);
      const double len = glm::length(n);
      if (len > 0) {
        const dvec3 u = n / len;
        for (const std::uint32_t v : t) {
          quadric_[v].add_plane(u, -glm::dot(u, m_.positions[t[0]]), 0.5 * len);
          weight_[v] += 0.5 * len;
        }
      }
      const auto [lo, hi] = box(f);
      grid_.insert(f, lo, hi);
    }
    alive_ = nf;
  }

  void run() {
    for (std::uint32_t v = 0; v < around_.size(); ++v) {
      for (const std::uint32_t w : neighbours(v)) push(v, w);
    }
    while (alive_ > p_.target_triangles && alive_ > 4 && !heap_.empty()) {
      const Entry e = heap_.top();
      heap_.pop();
      if (version_[e.from] != e.from_version || version_[e.to] != e.to_version) continue;  // stale
      collapse(e.from, e.to);
    }
  }

 private:
  struct Entry {
    double cost;
    std::uint32_t from, to, from_version, to_version;
    bool operator>(const Entry& o) const { return std::tie(cost, from, to) > std::tie(o.cost, o.from, o.to); }
  };

  static dvec3 lower_corner(const Mesh& m) {
    dvec3 lo(HUGE_VAL);
    for (const dvec3& p : m.positions) lo = glm::min(lo, p);
    return m.positions.empty() ? dvec3(0.0) : lo;
  }
  /// About the mean edge length of the result, so that a query looks at a few cells.
  static double cell_size(const Mesh& m, const SimplifyParams& p) {
    double sum = 0;
    for (const auto& t : m.triangles) sum += glm::distance(m.positions[t[0]], m.positions[t[1]]);
    const double mean = m.triangles.empty() ? 1.0 : sum / double(m.triangles.size());
    const double ratio = std::sqrt(double(m.triangles.size()) / double(std::max<std::size_t>(p.target_triangles, 1)));
    return std::max(mean * std::clamp(ratio, 1.0, 8.0), 1e-9);
  }

  [[nodiscard]] std::pair<dvec3, dvec3> box(std::uint32_t f) const {
    const auto& t = m_.triangles[f];
    const dvec3 &a = m_.positions[t[0]], &b = m_.positions[t[1]], &c = m_.positions[t[2]];
    return {glm::min(a, glm::min(b, c)), glm::max(a, glm::max(b, c))};
  }

  [[nodiscard]] std::vector<std::uint32_t> neighbours(std::uint32_t v) const {
    std::vector<std::uint32_t> n;
    for (const std::uint32_t f : around_[v]) {
      for (const std::uint32_t w : m_.triangles[f]) {
        if (w != v) n.push_back(w);
      }
    }
    std::sort(n.begin(), n.end());
    n.erase(std::unique(n.begin(), n.end()), n.end());
    return n;
  }

  void push(std::uint32_t from, std::uint32_t to) {
    Quadric q = quadric_[from];
    q += quadric_[to];
    const dvec3& target = m_.positions[to];
    const double w = std::max(weight_[from] + weight_[to], 1e-300);
    // Error per unit area (a squared distance), then the shorter edge where that ties (flat parts).
    const double cost = q.at(target) / w + 1e-3 * glm::dot(m_.positions[from] - target, m_.positions[from] - target);
    heap_.push({cost, from, to, version_[from], version_[to]});
  }

  /// The sine of the smallest angle of triangle (a, b, c), 0 when degenerate.
  static double min_sine(const dvec3& a, const dvec3& b, const dvec3& c) {
    const double cross = glm::length(glm::cross(b - a, c - a));
    double l[3] = {glm::distance(a, b), glm::distance(b, c), glm::distance(c, a)};
    std::sort(l, l + 3);
    return l[1] * l[2] > 0 ? cross / (l[1] * l[2]) : 0.0;
  }

  void collapse(std::uint32_t v0, std::uint32_t v1) {
    // The two triangles of the edge, one with v0 -> v1 and one with v1 -> v0.
    std::uint32_t removed[2], count = 0;
    bool forward = false, backward = false;
    for (const std::uint32_t f : around_[v0]) {
      const auto& t = m_.triangles[f];
      for (int k = 0; k < 3; ++k) {
        if (t[k] != v0) continue;
        if (t[(k + 1) % 3] == v1) forward = true, removed[count < 2 ? count : 1] = f, ++count;
        if (t[(k + 2) % 3] == v1) backward = true, removed[count < 2 ? count : 1] = f, ++count;
      }
    }
    if (count != 2 || !forward || !backward) {
      ++st_.refused_topology;
      return;
    }
    // Link condition: the ends share exactly the two opposite vertices.
    const std::vector<std::uint32_t> n0 = neighbours(v0), n1 = neighbours(v1);
    std::vector<std::uint32_t> common;
    std::set_intersection(n0.begin(), n0.end(), n1.begin(), n1.end(), std::back_inserter(common));
    if (common.size() != 2) {
      ++st_.refused_topology;
      return;
    }
    // The triangles that move, before and after.
    std::vector<std::uint32_t> fan;
    for (const std::uint32_t f : around_[v0]) {
      if (f != removed[0] && f != removed[1]) fan.push_back(f);
    }
    std::vector<Mesh::Triangle> old(fan.size());
    for (std::size_t i = 0; i < fan.size(); ++i) {
      old[i] = m_.triangles[fan[i]];
      Mesh::Triangle t = old[i];
      for (auto& v : t) v = v == v0 ? v1 : v;
      const dvec3 before = m_.face_normal(old[i]), after = m_.face_normal(t);
      const dvec3 &a = m_.positions[t[0]], &b = m_.positions[t[1]], &c = m_.positions[t[2]];
      if (glm::dot(before, after) <= cos_turn_ * glm::length(before) * glm::length(after) ||
          min_sine(a, b, c) < p_.min_sine) {
        ++st_.refused_shape;
        return;
      }
    }
    // Tentatively made: every moved triangle against every other near it, and the moved ones
    // against each other (the grid has them at their old boxes).
    for (std::size_t i = 0; i < fan.size(); ++i) {
      for (auto& v : m_.triangles[fan[i]]) v = v == v0 ? v1 : v;
    }
    dead_[removed[0]] = dead_[removed[1]] = 1;
    bool crossing = false;
    for (std::size_t i = 0; i < fan.size() && !crossing; ++i) {
      for (std::size_t j = i + 1; j < fan.size() && !crossing; ++j) crossing = tests_.intersect(fan[i], fan[j]);
    }
    for (std::size_t i = 0; i < fan.size() && !crossing; ++i) {
      ++stamp_;
      for (const std::uint32_t f : fan) seen_[f] = stamp_;
      const std::pair<dvec3, dvec3> fan_box = box(fan[i]);  // not a structured binding: clang 14 (sanitizer build) cannot capture one
      const dvec3 lo = fan_box.first, hi = fan_box.second;
      grid_.query(lo, hi, [&](std::uint32_t g) {
        if (crossing || dead_[g] || seen_[g] == stamp_) return;
        seen_[g] = stamp_;
        const auto [glo, ghi] = box(g);
        if (glm::any(glm::lessThan(ghi, lo)) || glm::any(glm::greaterThan(glo, hi))) return;
        crossing = tests_.intersect(fan[i], g);
      });
    }
    if (crossing) {
      for (std::size_t i = 0; i < fan.size(); ++i) m_.triangles[fan[i]] = old[i];
      dead_[removed[0]] = dead_[removed[1]] = 0;
      ++st_.refused_intersection;
      return;
    }
    // Made: UVs, adjacency, quadric, grid, queue.
    if (m_.corner_uvs.size() == m_.triangles.size()) {
      for (std::size_t i = 0; i < fan.size(); ++i) {
        const std::uint32_t f = fan[i];
        const int c = int(std::find(old[i].begin(), old[i].end(), v0) - old[i].begin());
        auto uv_of = [&](std::uint32_t g, std::uint32_t v) {
          const auto& t = m_.triangles[g];
          return m_.corner_uvs[g][std::size_t(std::find(t.begin(), t.end(), v) - t.begin())];
        };
        const glm::vec2 here = m_.corner_uvs[f][c];
        const std::uint32_t d = glm::distance(uv_of(removed[0], v0), here) <= glm::distance(uv_of(removed[1], v0), here)
                                    ? removed[0]
                                    : removed[1];
        m_.corner_uvs[f][c] = here + (uv_of(d, v1) - uv_of(d, v0));
      }
    }
    for (const std::uint32_t r : removed) {
      for (const std::uint32_t v : m_.triangles[r]) {
        auto& a = around_[v];
        a.erase(std::remove(a.begin(), a.end(), r), a.end());
      }
    }
    for (const std::uint32_t f : fan) {
      around_[v1].push_back(f);
      const auto [lo, hi] = box(f);
      grid_.insert(f, lo, hi);
    }
    around_[v0].clear();
    quadric_[v1] += quadric_[v0];
    weight_[v1] += weight_[v0];
    alive_ -= 2;
    ++st_.collapses;
    ++version_[v0];
    // Every edge at v1 or its neighbours is judged again (their rings changed).
    std::vector<std::uint32_t> changed = neighbours(v1);
    changed.push_back(v1);
    for (const std::uint32_t v : changed) {
      ++version_[v];
      mark_[v] = 1;
    }
    for (const std::uint32_t v : changed) {
      for (const std::uint32_t w : neighbours(v)) {
        push(v, w);
        if (!mark_[w]) push(w, v);
      }
    }
    for (const std::uint32_t v : changed) mark_[v] = 0;
  }

  Mesh& m_;
  const SimplifyParams& p_;
  SimplifyStats& st_;
  TriangleIntersections tests_;
  BoxGrid grid_;
  std::vector<std::vector<std::uint32_t>> around_;  // #V triangles at each vertex
  std::vector<std::uint32_t> version_;              // #V, bumped when a vertex's ring changes
  std::vector<Quadric> quadric_;
  std::vector<double> weight_;    // #V area of the planes in the quadric
  std::vector<std::uint8_t> dead_, mark_;
  std::vector<std::uint32_t> seen_;
  std::uint32_t stamp_ = 0;
  std::size_t alive_ = 0;
  double cos_turn_ = 0.5;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> heap_;

 public:
  [[nodiscard]] const std::vector<std::uint8_t>& dead() const { return dead_; }
};

/// `mesh` without the triangles marked dead and the vertices no triangle uses, in order.
Mesh compact(const Mesh& m, const std::vector<std::uint8_t>& dead) {
  Mesh out;
  const std::size_t nv = m.positions.size();
  std::vector<std::uint32_t> renumber(nv, UINT32_MAX);
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    if (dead[f]) continue;
    for (const std::uint32_t v : m.triangles[f]) renumber[v] = 0;
  }
  const bool nodes = m.vertex_node.size() == nv, strands = m.vertex_strand.size() == nv;
  std::uint32_t used = 0;
  for (std::size_t v = 0; v < nv; ++v) {
    if (renumber[v] == UINT32_MAX) continue;
    renumber[v] = used++;
    out.positions.push_back(m.positions[v]);
    if (nodes) out.vertex_node.push_back(m.vertex_node[v]);
    if (strands) out.vertex_strand.push_back(m.vertex_strand[v]);
  }
  const bool uvs = m.corner_uvs.size() == m.triangles.size(), branches = m.triangle_branch.size() == m.triangles.size();
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    if (dead[f]) continue;
    Mesh::Triangle t = m.triangles[f];
    for (auto& v : t) v = renumber[v];
    out.triangles.push_back(t);
    if (uvs) out.corner_uvs.push_back(m.corner_uvs[f]);
    if (branches) out.triangle_branch.push_back(m.triangle_branch[f]);
  }
  if (m.normals.size() == nv) out.normals = angle_weighted_normals(out);
  return out;
}

}  // namespace

Mesh simplify_mesh(const Mesh& mesh, const SimplifyParams& params, SimplifyStats* stats) {
  SimplifyStats st;
  st.triangles_before = mesh.triangles.size();
  Mesh work = mesh;
  std::vector<std::uint8_t> dead;
  {
    Simplifier s(work, params, st);
    s.run();
    dead = s.dead();
  }
  Mesh out = compact(work, dead);
  st.triangles_after = out.triangles.size();
  std::vector<std::uint32_t> all(out.triangles.size());
  std::iota(all.begin(), all.end(), 0u);
  st.pairs_after = TriangleIntersections(out).pairs(all).size();
  if (stats != nullptr) *stats = st;
  return out;
}

}  // namespace sm
