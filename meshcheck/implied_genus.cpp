// The genus a skeleton implies (implied_genus.h): b1 of the nerve of its round cones, computed
// relative to the tree so that only crossing pairs and their triangles cost anything.
//
// Why relative to the tree. The cycles of the nerve's graph have a basis of fundamental cycles
// of a spanning tree; take as tree, at every node, its cones joined as a star to the first of
// them. Every other pair of cones at a node closes a cycle that bounds a triangle at that node
// (all of them hold the node's centre), so modulo those boundaries the crossing pairs (cones
// that meet without a shared node) are a basis, and every other triangle's boundary reduces
// to its crossing pairs: one, two or three of them. b1 = R - rank of those columns (R crossing
// pairs). Columns of one or two entries are the edges of a graph on the crossing pairs plus a
// ground node (one entry: joined to the ground); a graph's incidence matrix over Z2 has rank
// nodes - components, so b1 = (components not holding the ground) - (rank of the three-entry
// columns modulo that graph: a sparse elimination over the components). A triangle is tested
// only when its column would still raise the rank: most are skipped by a union-find lookup.
//
// Whether cones have a common point: a witness first (a shared node's centre or the point of
// its sphere nearest the third cone; the point between the closest axis points of a crossing
// pair), then the deep-cut ellipsoid method (Bland, Goldfarb and Todd, "The ellipsoid method: a
// survey", 1981) on F(x) = max of the cones' signed distances and the distances to their
// common bounding box: F is convex, so each cut keeps every point with F <= tolerance, and the
// search ends with such a point or a proof that the ellipsoid holds none.

#include "meshcheck/implied_genus.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include <CGAL/box_intersection_d.h>

#include "core/math.h"
#include <glm/glm.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/report.h"
#include "core/union_find.h"

namespace sm {

namespace {

using glm::dvec3;
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

struct Cone {
  dvec3 a, b;              // end sphere centres: parent node, child node
  double ra = 0, rb = 0;   // end sphere radii
  std::uint32_t na = 0, nb = 0;  // the nodes: parent, child
};

bool share_node(const Cone& x, const Cone& y) {
  return x.na == y.na || x.na == y.nb || x.nb == y.na || x.nb == y.nb;
}

dvec3 box_lo(const Cone& c) { return glm::min(c.a - c.ra, c.b - c.rb); }
dvec3 box_hi(const Cone& c) { return glm::max(c.a + c.ra, c.b + c.rb); }
double min_radius(const Cone& c) { return std::min(c.ra, c.rb); }
double max_radius(const Cone& c) { return std::max(c.ra, c.rb); }

// Signed distance from p to a round cone, exact outside (inside: negative), and outside the
// unit normal of the cone at its nearest point (the gradient of the distance). As
// meshcheck/cone_tree.h cone_distance: in the half plane through the axis, the outline is two
// circles and their common tangent.
struct Probe {
  double d;
  dvec3 n;
};

Probe probe(const Cone& c, const dvec3& p) {
  const dvec3 axis = c.b - c.a;
  const double len = glm::length(axis);
  auto sphere = [&p](const dvec3& centre, double r, const dvec3& fallback) {
    const dvec3 v = p - centre;
    const double l = glm::length(v);
    return Probe{l - r, l > 0 ? v / l : fallback};
  };
  if (len <= std::abs(c.ra - c.rb)) {  // one sphere holds the other (or a zero-length edge)
    return c.ra >= c.rb ? sphere(c.a, c.ra, dvec3(0, 0, 1)) : sphere(c.b, c.rb, dvec3(0, 0, 1));
  }
  const dvec3 e = axis / len;
  const dvec3 w = p - c.a;
  const double y = glm::dot(w, e);
  const dvec3 radial = w - y * e;
  const double x = glm::length(radial);
  const double s = (c.ra - c.rb) / len;  // sine of the half angle
  const double co = std::sqrt(std::max(0.0, 1.0 - s * s));
  const double u = y * co - x * s;  // along the tangent, 0 at a's tangent point
  if (u <= 0) return sphere(c.a, c.ra, -e);
  if (u >= len * co) return sphere(c.b, c.rb, e);
  // On the axis (x = 0) the point is inside and the normal unused.
  return {y * s + x * co - c.ra, s * e + (x > 0 ? (co / x) * radial : dvec3(0))};
}

// The closest points of two cones' axes with the radii interpolated there: `gap` is their
// distance minus both radii (<= 0: the two balls meet, `witness` lies in both), `bound` a lower
// bound of the cones' distance.
struct AxisGap {
  double gap, bound;
  dvec3 witness;
};

AxisGap axis_gap(const Cone& x, const Cone& y) {
  double s = 0, t = 0;
  closest_segment_params(x.a, x.b, y.a, y.b, s, t);
  const dvec3 cx = x.a + s * (x.b - x.a), cy = y.a + t * (y.b - y.a);
  const double rx = x.ra + s * (x.rb - x.ra), ry = y.ra + t * (y.rb - y.ra);
  const double dist = glm::length(cy - cx);
  const double share = rx + ry > 0 ? rx / (rx + ry) : 0.5;
  return {dist - rx - ry, dist - max_radius(x) - max_radius(y), cx + share * (cy - cx)};
}

// Whether cones cs[0..k) have a point within `tol` (metres) of all of them: the deep-cut
// ellipsoid method on F = max(signed distances, distance outside the boxes' intersection),
// coordinates relative to that box's centre. Decides either way except within 2 tol of
// tangency (then "meet").
bool search_common_point(const Cone* const* cs, int k, double tol) {
  dvec3 lo(-std::numeric_limits<double>::infinity()), hi(std::numeric_limits<double>::infinity());
  for (int i = 0; i < k; ++i) {
    lo = glm::max(lo, box_lo(*cs[i]) - tol);
    hi = glm::min(hi, box_hi(*cs[i]) + tol);
  }
  if (lo.x > hi.x || lo.y > hi.y || lo.z > hi.z) return false;
  const dvec3 origin = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
  std::array<Cone, 3> local;
  for (int i = 0; i < k; ++i) {
    local[std::size_t(i)] = *cs[i];
    local[std::size_t(i)].a -= origin;
    local[std::size_t(i)].b -= origin;
  }
  dvec3 x(0);
  glm::dmat3 P(glm::dot(half, half) + tol * tol);  // the ball around the box
  double best = std::numeric_limits<double>::infinity();
  constexpr int kMaxIterations = 2000;
  for (int it = 0; it < kMaxIterations; ++it) {
    double v = -std::numeric_limits<double>::infinity();
    dvec3 g(0);
    for (int d = 0; d < 3; ++d) {
      if (x[d] - half[d] > v) {
        v = x[d] - half[d];
        g = dvec3(0);
        g[d] = 1;
      }
      if (-half[d] - x[d] > v) {
        v = -half[d] - x[d];
        g = dvec3(0);
        g[d] = -1;
      }
    }
    for (int i = 0; i < k; ++i) {
      const Probe pr = probe(local[std::size_t(i)], x);
      if (pr.d > v) {
        v = pr.d;
        g = pr.n;
      }
    }
    best = std::min(best, v);
    if (v <= tol) return true;
    const double width2 = P[0][0] + P[1][1] + P[2][2];  // >= the largest semi-axis squared
    const dvec3 Pg = P * g;
    const double gPg = glm::dot(g, Pg);
    // Every point with F <= tol is in the ellipsoid, within its width of x, and F is
    // 1-Lipschitz: once the width is below tol, F(x) > 2 tol proves there is none.
    if (width2 <= tol * tol || !(gPg > 0)) return v <= 2 * tol;
    const double sq = std::sqrt(gPg);
    const double alpha = (v - tol) / sq;  // depth of the cut g·(y - x) <= tol - F(x)
    if (alpha >= 1) return false;          // the ellipsoid lies wholly beyond it
    x -= ((1 + 3 * alpha) / (4 * sq)) * Pg;
    P = (9.0 * (1 - alpha * alpha) / 8.0) *
        (P - ((1 + 3 * alpha) / (2 * (1 + alpha) * gPg)) * glm::outerProduct(Pg, Pg));
  }
  return best <= 2 * tol;
}

enum class Verdict : std::uint8_t { empty, filled, undecided };

// The crossing pairs' rows reduced modulo the columns accepted so far: a union-find over the
// rows and a ground node (one- and two-entry columns), and the pivots of the three-entry ones
// (over the union-find's components, the ground's left out).
class Columns {
 public:
  explicit Columns(std::size_t rows) : uf_(rows + 1), ground_(static_cast<std::uint32_t>(rows)) {}

  [[nodiscard]] bool grounded(std::uint32_t r) { return uf_.find(r) == uf_.find(ground_); }
  [[nodiscard]] bool joined(std::uint32_t r, std::uint32_t s) { return uf_.find(r) == uf_.find(s); }
  void ground(std::uint32_t r) { uf_.unite(r, ground_); }
  void join(std::uint32_t r, std::uint32_t s) { uf_.unite(r, s); }

  // A column reduced modulo the graph and the pivots; empty when dependent.
  std::vector<std::uint32_t> reduce(std::span<const std::uint32_t> rows) {
    std::vector<std::uint32_t> col;
    const std::uint32_t g = uf_.find(ground_);
    for (const std::uint32_t r : rows) {
      const std::uint32_t c = uf_.find(r);
      if (c != g) col.push_back(c);
    }
    cancel(col);
    while (!col.empty()) {
      const auto it = pivots_.find(col.back());
      if (it == pivots_.end()) break;
      std::vector<std::uint32_t> sum;
      std::set_symmetric_difference(col.begin(), col.end(), it->second.begin(), it->second.end(),
                                    std::back_inserter(sum));
      col = std::move(sum);
    }
    return col;
  }
  void add(std::vector<std::uint32_t> col) {
    if (col.empty()) return;
    const std::uint32_t p = col.back();
    pivots_.emplace(p, std::move(col));
  }
  // One row per handle, up to `max`: the roots of the components neither grounded nor a pivot.
  std::vector<std::uint32_t> handles(std::size_t max) {
    std::vector<std::uint32_t> out;
    const std::uint32_t g = uf_.find(ground_);
    for (std::uint32_t r = 0; r < ground_ && out.size() < max; ++r) {
      if (uf_.find(r) == r && r != g && !pivots_.contains(r)) out.push_back(r);
    }
    return out;
  }
  // b1: components other than the ground's, less the independent three-entry columns.
  std::int64_t betti1() {
    std::int64_t roots = 0;
    for (std::uint32_t r = 0; r <= ground_; ++r) roots += uf_.find(r) == r;
    return roots - 1 - static_cast<std::int64_t>(pivots_.size());
  }

 private:
  static void cancel(std::vector<std::uint32_t>& col) {  // sort, and drop pairs (mod 2)
    std::sort(col.begin(), col.end());
    std::vector<std::uint32_t> out;
    for (std::size_t i = 0; i < col.size();) {
      std::size_t j = i;
      while (j < col.size() && col[j] == col[i]) ++j;
      if ((j - i) % 2 == 1) out.push_back(col[i]);
      i = j;
    }
    col = std::move(out);
  }
  UnionFind uf_;
  std::uint32_t ground_;
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> pivots_;
};

class Solver {
 public:
  // Radii scaled by `scale` (the robust genus compares the unions at two scales).
  Solver(const Skeleton& skel, const ImpliedGenusParams& params, double scale = 1.0)
      : skel_(skel), params_(params), scale_(scale) {
    cone_of_child_.assign(skel.size(), kNone);
    for (std::size_t i = 0; i < skel.size(); ++i) {
      const NodeId p = skel.parent[i];
      if (!p.valid()) continue;
      cone_of_child_[i] = static_cast<std::uint32_t>(cones_.size());
      cones_.push_back({skel.position[p.idx()], skel.position[i], scale * skel.radius[p.idx()], scale * skel.radius[i],
                        static_cast<std::uint32_t>(p.idx()), static_cast<std::uint32_t>(i)});
    }
  }

  // The rank of H1(inner's union) -> H1(this union), inner's cones inside these (smaller
  // radii): the handles of `inner` that survive here. Each crossing pair of inner stands for its
  // fundamental cycle, which it is here too; the rank is that of their classes modulo this
  // union's filled triangles. Consumes this solver's reduction.
  std::int64_t image_rank(const Solver& inner) {
    if (!upper_ || inner.pairs_.empty()) return 0;
    std::int64_t rank = 0;
    for (const auto& p : inner.pairs_) {
      const auto it = std::lower_bound(pairs_.begin(), pairs_.end(), p);
      if (it == pairs_.end() || *it != p) continue;  // (cannot happen: larger cones still meet)
      const std::uint32_t row = static_cast<std::uint32_t>(it - pairs_.begin());
      std::vector<std::uint32_t> col = upper_->reduce(std::span<const std::uint32_t>(&row, 1));
      if (col.empty()) continue;
      upper_->add(std::move(col));
      ++rank;
    }
    return rank;
  }

  ImpliedGenus run() {
    ImpliedGenus out;
    out.cones = cones_.size();
    if (cones_.size() < 2) return out;
    find_crossing_pairs(out);
    const std::size_t rows = pairs_.size();
    if (rows == 0 || !out.complete) return out;
    build_adjacency();
    upper_.emplace(rows);
    Columns& upper = *upper_;
    Columns lower(rows);  // triangles proven filled, and those left undecided too
    // Triangle candidates listed (a cap: dense tangles of crossing pairs grow with the square of
    // their crossing degrees); past it, triangles left out make the lower end 0.
    std::size_t listed = 0;
    bool cut = false;
    // One- and two-entry columns: each triangle from its lowest crossing pair.
    for (std::uint32_t e = 0; e < rows && !cut; ++e) {
      const std::uint32_t x = pairs_[e][0], y = pairs_[e][1];
      listed += 4 + (begin_[x + 1] - begin_[x]) + (begin_[y + 1] - begin_[y]);
      cut = listed > params_.max_listed;
      for (const std::uint32_t u : {cones_[x].na, cones_[x].nb}) {
        for (const std::uint32_t w : {cones_[y].na, cones_[y].nb}) {
          std::uint32_t z = kNone;
          if (skel_.parent[w].valid() && skel_.parent[w].idx() == u) z = cone_of_child_[w];
          if (skel_.parent[u].valid() && skel_.parent[u].idx() == w) z = cone_of_child_[u];
          if (z == kNone || upper.grounded(e)) continue;
          const Verdict v = triangle(x, y, z, out);
          if (v != Verdict::empty) lower.ground(e);
          if (v == Verdict::filled) upper.ground(e);
        }
      }
      // z crossing one of x, y and sharing a node with the other.
      for (int side = 0; side < 2; ++side) {
        const std::uint32_t near = side == 0 ? y : x, other = side == 0 ? x : y;
        for (std::uint32_t k = begin_[near]; k < begin_[near + 1]; ++k) {
          const std::uint32_t z = adj_[k], f = edge_[k];
          if (f <= e || z == other || !share_node(cones_[z], cones_[other]) || upper.joined(e, f)) continue;
          const Verdict v = triangle(x, y, z, out);
          if (v != Verdict::empty) lower.join(e, f);
          if (v == Verdict::filled) upper.join(e, f);
        }
      }
    }
    // Three-entry columns, modulo the graph above.
    for (std::uint32_t e = 0; e < rows && !cut; ++e) {
      const std::uint32_t x = pairs_[e][0], y = pairs_[e][1];
      listed += (begin_[x + 1] - begin_[x]) + (begin_[y + 1] - begin_[y]);
      cut = listed > params_.max_listed;
      std::uint32_t i = begin_[x], j = begin_[y];
      while (i < begin_[x + 1] && j < begin_[y + 1]) {
        if (adj_[i] < adj_[j]) {
          ++i;
        } else if (adj_[j] < adj_[i]) {
          ++j;
        } else {
          const std::uint32_t z = adj_[i], f = edge_[i], g = edge_[j];
          ++i;
          ++j;
          if (f <= e || g <= e) continue;
          const std::array<std::uint32_t, 3> rows3 = {e, f, g};
          std::vector<std::uint32_t> col = upper.reduce(rows3);
          if (col.empty()) continue;
          const Verdict v = triangle(x, y, z, out);
          if (v == Verdict::filled) upper.add(std::move(col));
          if (v != Verdict::empty) lower.add(lower.reduce(rows3));
        }
      }
    }
    out.genus = upper.betti1();
    for (const std::uint32_t e : upper.handles(params_.max_examples)) {
      std::array<std::uint32_t, 2> nodes = {cones_[pairs_[e][0]].nb, cones_[pairs_[e][1]].nb};
      std::sort(nodes.begin(), nodes.end());
      out.handle_examples.push_back(nodes);
    }
    out.genus_min = cut ? 0 : lower.betti1();
    return out;
  }

 private:
  // Candidate pairs by box intersection (cones without a shared node), then each tested.
  void find_crossing_pairs(ImpliedGenus& out) {
    using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, std::uint32_t,
                                                          CGAL::Box_intersection_d::ID_FROM_BOX_ADDRESS>;
    std::vector<Box> boxes;
    boxes.reserve(cones_.size());
    for (std::uint32_t c = 0; c < cones_.size(); ++c) {
      // Widened by the tolerance: a pair within it of each other still overlaps.
      const double pad = params_.contact_tolerance * max_radius(cones_[c]);
      const dvec3 lo = box_lo(cones_[c]) - pad, hi = box_hi(cones_[c]) + pad;
      double l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
      boxes.emplace_back(l, h, c);
    }
    // By address (CGAL's box search works on copies of what it is given: pointers keep the ids).
    std::vector<const Box*> ptrs;
    ptrs.reserve(boxes.size());
    for (const Box& b : boxes) ptrs.push_back(&b);
    std::vector<std::array<std::uint32_t, 2>> candidates;
    auto callback = [&](const Box* a, const Box* b) {
      const std::uint32_t i = a->info(), j = b->info();
      if (share_node(cones_[i], cones_[j])) return;
      if (candidates.size() < params_.max_candidates) {
        candidates.push_back({std::min(i, j), std::max(i, j)});
      } else {
        out.complete = false;
      }
    };
    constexpr std::ptrdiff_t kCutoff = 1000;  // as meshcheck/checks_cgal.cpp: the scan beats splitting below it
    CGAL::box_self_intersection_d<CGAL::Sequential_tag>(ptrs.begin(), ptrs.end(), callback, kCutoff);
    ptrs = {};
    boxes = {};
    if (!out.complete) return;
    std::sort(candidates.begin(), candidates.end());
    out.candidate_pairs = candidates.size();
    // 1: meet, 2: searched (bits), tested in parallel, gathered by index.
    std::vector<std::uint8_t> result(candidates.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, candidates.size(), 4096),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t k = range.begin(); k != range.end(); ++k) {
                          const Cone& x = cones_[candidates[k][0]];
                          const Cone& y = cones_[candidates[k][1]];
                          const double tol = tolerance(x, y, y);
                          const AxisGap g = axis_gap(x, y);
                          if (g.gap <= tol) {
                            result[k] = 1;
                          } else if (g.bound <= tol) {
                            const Cone* cs[2] = {&x, &y};
                            result[k] = std::uint8_t(2 | (search_common_point(cs, 2, tol) ? 1 : 0));
                          }
                        }
                      });
    for (std::size_t k = 0; k < candidates.size(); ++k) {
      if (result[k] & 1) pairs_.push_back(candidates[k]);
      out.searches += (result[k] & 2) != 0;
    }
    out.crossing_pairs = pairs_.size();
  }

  // Crossing neighbours of every cone, ascending, with the pair's index.
  void build_adjacency() {
    begin_.assign(cones_.size() + 1, 0);
    for (const auto& p : pairs_) {
      ++begin_[p[0] + 1];
      ++begin_[p[1] + 1];
    }
    for (std::size_t c = 0; c < cones_.size(); ++c) begin_[c + 1] += begin_[c];
    adj_.resize(2 * pairs_.size());
    edge_.resize(2 * pairs_.size());
    std::vector<std::uint32_t> fill(begin_.begin(), begin_.end() - 1);
    // Lower neighbours first, then higher ones: each list comes out sorted.
    for (std::uint32_t e = 0; e < pairs_.size(); ++e) {
      const std::uint32_t k = fill[pairs_[e][1]]++;
      adj_[k] = pairs_[e][0];
      edge_[k] = e;
    }
    for (std::uint32_t e = 0; e < pairs_.size(); ++e) {
      const std::uint32_t k = fill[pairs_[e][0]]++;
      adj_[k] = pairs_[e][1];
      edge_[k] = e;
    }
  }

  double tolerance(const Cone& x, const Cone& y, const Cone& z) const {
    return params_.contact_tolerance * std::min({min_radius(x), min_radius(y), min_radius(z)});
  }

  // Whether cones x, y, z (pairwise meeting) have a common point.
  Verdict triangle(std::uint32_t xi, std::uint32_t yi, std::uint32_t zi, ImpliedGenus& out) {
    ++out.triangles_tested;
    const std::array<const Cone*, 3> c = {&cones_[xi], &cones_[yi], &cones_[zi]};
    const double tol = tolerance(*c[0], *c[1], *c[2]);
    auto inside = [&](const dvec3& p) {
      return probe(*c[0], p).d <= tol && probe(*c[1], p).d <= tol && probe(*c[2], p).d <= tol;
    };
    for (int k = 0; k < 3; ++k) {
      const Cone& i = *c[std::size_t((k + 1) % 3)];
      const Cone& j = *c[std::size_t((k + 2) % 3)];
      const Cone& third = *c[std::size_t(k)];
      std::uint32_t shared = kNone;
      for (const std::uint32_t n : {i.na, i.nb}) {
        if (n == j.na || n == j.nb) shared = n;
      }
      if (shared != kNone) {
        // The shared node's sphere lies in both: its point nearest the third cone.
        const dvec3 centre = skel_.position[shared];
        const double r = scale_ * skel_.radius[shared];
        const Probe pr = probe(third, centre);
        if (pr.d <= tol) return Verdict::filled;
        if (pr.d <= r && inside(centre - pr.d * pr.n)) return Verdict::filled;
      } else {
        const AxisGap g = axis_gap(i, j);
        if (g.gap <= tol && inside(g.witness)) return Verdict::filled;
      }
    }
    if (searches_left_ == 0) {
      ++out.undecided;
      return Verdict::undecided;
    }
    --searches_left_;
    ++out.searches;
    return search_common_point(c.data(), 3, tol) ? Verdict::filled : Verdict::empty;
  }

  const Skeleton& skel_;
  const ImpliedGenusParams& params_;
  double scale_;
  std::optional<Columns> upper_;  // after run(): the rows reduced modulo the filled triangles
  std::vector<Cone> cones_;
  std::vector<std::uint32_t> cone_of_child_;  // #N: the cone ending at the node, kNone at the root
  std::vector<std::array<std::uint32_t, 2>> pairs_;  // crossing pairs (x < y), ascending
  std::vector<std::uint32_t> begin_, adj_, edge_;    // crossing neighbours (CSR) and pair index
  std::size_t searches_left_ = params_.max_searches;
};

}  // namespace

ImpliedGenus implied_genus(const Skeleton& skeleton, const ImpliedGenusParams& params) {
  Stopwatch watch;
  ImpliedGenus out = Solver(skeleton, params).run();
  out.robust_genus = out.genus;
  // (It is at most the genus: the map factors through this union.)
  if (params.robust_margin > 0 && out.genus > 0 && out.complete) {
    Solver outer(skeleton, params, 1 + params.robust_margin);
    if (outer.run().genus == 0) {
      out.robust_genus = 0;  // no handle to survive into
    } else {
      Solver inner(skeleton, params, 1 - params.robust_margin);
      inner.run();
      out.robust_genus = outer.image_rank(inner);
    }
  }
  out.seconds = watch.elapsed();
  return out;
}

}  // namespace sm
