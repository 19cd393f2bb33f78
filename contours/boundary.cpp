// Boundary selection: the angular walk around the centroid, made robust.
//
// The plain walk sorts the points by angle around their centroid and walks them like a Graham
// scan, dropping points where the contour turns inwards by more than a threshold. Measuring
// turns with acos and a sign taken separately flips the sign for nearly collinear points, so
// points far inside are kept. Here the side of every turn
// comes from a cross product (the signed distance of the middle point from the chord), exact
// up to rounding for any configuration, and only the size of a concave turn is compared with
// the threshold, as dot(u, v) < cos(threshold) |u| |v| (no trigonometry); collinear and
// duplicate points are dropped (a turn of exactly zero counts as concave), which also keeps
// degenerate triangles out of the mesh.
//
// Because the kept points are visited in strictly increasing angle around the centroid, the
// loop is simple and star-shaped around it whenever every angular gap between consecutive
// loop vertices is below pi. That, and every input point lying inside (or on) the loop, is
// verified afterwards. Slices that are not star-shaped around their centroid get the concave
// outline of their points (concave_hull.cpp: a Delaunay triangulation with its long boundary
// edges removed): when the verification fails, and when the walk's loop bridges a long gap
// across a connected shape that hides a real part of itself from the centroid (a "C"). The
// convex hull remains only for points too degenerate to triangulate.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <numeric>

#include "contours/contours.h"

namespace sm {
namespace {

constexpr double kPi = std::numbers::pi;
/// A connected point set whose outline turns backwards around the centroid by more than this
/// (radians) hides a real part of itself from the centroid: it is not star-shaped around it.
/// Below, the backward turns are the notches of a concave union, which the walk bridges.
constexpr double kHiddenTurn = kPi / 2;
/// Only gaps bridged by a walk edge longer than this, relative to the slice's extent (its
/// largest distance from the centroid), are examined, and only when there is exactly one: on
/// the large grown tree, triangulating at every long edge added 45 % to the contours stage.
constexpr double kLongBridge = 0.5;

/// Andrew's monotone chain; strictly convex (collinear points dropped), CCW.
std::vector<std::uint32_t> convex_hull(const std::vector<dvec2>& p) {
  std::vector<std::uint32_t> idx(p.size());
  std::iota(idx.begin(), idx.end(), 0u);
  std::sort(idx.begin(), idx.end(), [&](std::uint32_t a, std::uint32_t b) {
    return p[a].x != p[b].x ? p[a].x < p[b].x : (p[a].y != p[b].y ? p[a].y < p[b].y : a < b);
  });
  std::vector<std::uint32_t> h(2 * idx.size() + 1);
  std::size_t k = 0;
  for (std::size_t i = 0; i < idx.size(); ++i) {
    while (k >= 2 && cross2(p[h[k - 1]] - p[h[k - 2]], p[idx[i]] - p[h[k - 2]]) <= 0) --k;
    h[k++] = idx[i];
  }
  for (std::size_t i = idx.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross2(p[h[k - 1]] - p[h[k - 2]], p[idx[i]] - p[h[k - 2]]) <= 0) --k;
    h[k++] = idx[i];
  }
  h.resize(k > 1 ? k - 1 : k);
  return h;
}

/// A monotone stand-in for the angle of (x, y) in [0, 4) (a "diamond angle"): sorts like
/// atan2 at a fraction of its cost.
double pseudo_angle(double x, double y) {
  const double s = std::abs(x) + std::abs(y);
  if (s == 0) return 0;
  const double r = y / s;
  return x >= 0 ? (y >= 0 ? r : 4 + r) : 2 - r;
}

/// Reused buffers of one thread's boundary selections: most slices are small (three in four
/// of the large grown tree's 165 k have under 16 points), and allocating these per call cost
/// more than the walk.
struct Scratch {
  std::vector<double> dist2, key, smax2, lk, edge_length;
  std::vector<std::uint32_t> order, stack, bucket_begin, bucket_first, sector_of;
  struct Entry {
    double key, dist2;
    std::uint32_t i;
    /// By angle; on equal angles the nearer point first, so the farther one survives the scan.
    bool operator<(const Entry& o) const {
      return key != o.key ? key < o.key : (dist2 != o.dist2 ? dist2 < o.dist2 : i < o.i);
    }
  };
  std::vector<Entry> entries, bucketed;
};

/// True when the loop (vertices in increasing `key` around c, the first at key 0) turns
/// less than pi between consecutive vertices as seen from c (so it is simple and star-shaped
/// around c) and every point lies inside it or within `tol` of it. `sorted`, when not null,
/// holds every point but the loop's first vertex in increasing key: each point's sector of the
/// loop is then found by one sweep, O(n). Otherwise `sector_of` holds each point's angular
/// bucket (of `buckets`, monotone in the key): the points farther from c than the loop's
/// nearest edge line (those nearer are inside it) start from the last loop vertex of an
/// earlier bucket and step on (a binary search per point was a sixth of the selection's time).
bool star_loop_valid(const std::vector<dvec2>& p, const std::vector<double>& key, const std::vector<double>& dist2,
                     const dvec2& c, const std::vector<std::uint32_t>& loop, double tol,
                     const std::vector<std::uint32_t>* sorted, const std::vector<std::uint32_t>& sector_of,
                     std::size_t buckets, Scratch& scratch) {
  const std::size_t m = loop.size();
  if (m < 3) return false;
  std::vector<double>& lk = scratch.lk;
  std::vector<double>& edge_length = scratch.edge_length;
  lk.resize(m);
  edge_length.resize(m);
  for (std::size_t k = 0; k < m; ++k) {
    lk[k] = key[loop[k]];
    if (k > 0 && !(lk[k] > lk[k - 1])) return false;
    if (!(cross2(p[loop[k]] - c, p[loop[(k + 1) % m]] - c) > 0)) return false;
    edge_length[k] = glm::length(p[loop[(k + 1) % m]] - p[loop[k]]);
  }
  // Sector k spans [lk[k], lk[k+1]) (the last one wraps around).
  auto inside = [&](std::uint32_t i, std::size_t k) {
    const dvec2& a = p[loop[k]];
    const dvec2 e = p[loop[(k + 1) % m]] - a;
    const double len = edge_length[k];
    return !(len > 0 && cross2(e, p[i] - a) < -tol * len);
  };
  if (sorted) {
    std::size_t k = 0;
    for (const std::uint32_t i : *sorted) {
      while (k + 1 < m && lk[k + 1] <= key[i]) ++k;
      if (!inside(i, k)) return false;
    }
    return inside(loop[0], 0);
  }
  // Every edge line passes at least `inner` from c (c is inside each, the loop being
  // star-shaped around it), so a point nearer to c than inner - tol lies inside every edge's
  // line by more than tol: the test below would pass it whatever its sector.
  double inner = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < m; ++k) {
    const double len = edge_length[k];
    if (len > 0) inner = std::min(inner, cross2(p[loop[(k + 1) % m]] - p[loop[k]], c - p[loop[k]]) / len);
  }
  inner -= tol;
  const double inner2 = inner > 0 ? inner * inner : -1.0;  // (no shortcut when inner <= 0)
  // first[b]: the last loop vertex in a bucket before b (0 if none). A point of bucket b has a
  // larger key than every loop vertex of an earlier bucket, so its loop sector starts there.
  std::vector<std::uint32_t>& first = scratch.bucket_first;
  first.resize(buckets);
  for (std::size_t b = 0, k = 0; b < buckets; ++b) {
    while (k + 1 < m && sector_of[loop[k + 1]] < b) ++k;
    first[b] = static_cast<std::uint32_t>(k);
  }
  for (std::uint32_t i = 0; i < p.size(); ++i) {
    if (dist2[i] < inner2) continue;
    std::size_t k = first[sector_of[i]];
    while (k + 1 < m && lk[k + 1] <= key[i]) ++k;
    if (!inside(i, k)) return false;
  }
  return true;
}

/// True when exactly one edge of the loop (of at least 4; `len` its edge lengths, as
/// star_loop_valid left them) is longer than both `relative` x its median edge and
/// kLongBridge x `extent`: clusters a gap apart need two or more such bridges (one on each
/// side of every gap), so a single one spans a concavity of one connected shape. No
/// allocation unless some edge is longer than kLongBridge x extent (the common case).
bool single_bridge(const std::vector<double>& len, double relative, double extent) {
  const std::size_t m = len.size();
  if (m < 4) return false;
  if (std::none_of(len.begin(), len.end(), [&](double l) { return l > kLongBridge * extent; })) return false;
  std::vector<double> sorted = len;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(m / 2), sorted.end());
  const double long_edge = std::max(relative * sorted[m / 2], kLongBridge * extent);
  return std::count_if(len.begin(), len.end(), [&](double l) { return l > long_edge; }) == 1;
}

/// How far the loop turns backwards around c (radians, summed over its edges): 0 when it is
/// star-shaped around c.
double backward_turn(const std::vector<dvec2>& p, const dvec2& c, const std::vector<std::uint32_t>& loop) {
  double back = 0;
  for (std::size_t k = 0; k < loop.size(); ++k) {
    const dvec2 a = p[loop[k]] - c, b = p[loop[(k + 1) % loop.size()]] - c;
    const double t = std::atan2(cross2(a, b), glm::dot(a, b));
    if (t < 0) back -= t;
  }
  return back;
}

}  // namespace

std::vector<std::uint32_t> boundary_loop(const std::vector<dvec2>& p, double concave_turn_degrees, bool* fallback,
                                         double fallback_max_edge) {
  std::vector<std::uint32_t> loop;
  boundary_loop(p, concave_turn_degrees, loop, fallback, fallback_max_edge);
  return loop;
}

void boundary_loop(const std::vector<dvec2>& p, double concave_turn_degrees, std::vector<std::uint32_t>& out,
                   bool* fallback, double fallback_max_edge) {
  if (fallback) *fallback = false;
  const std::size_t n = p.size();
  if (n < 3) {
    out.resize(n);
    std::iota(out.begin(), out.end(), 0u);
    return;
  }
  thread_local Scratch scratch;
  dvec2 c(0);
  for (const auto& q : p) c += q;
  c /= double(n);
  // Squared distances from the centroid (only compared; one square root for the extent).
  std::vector<double>& dist2 = scratch.dist2;
  dist2.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) dist2[i] = glm::dot(p[i] - c, p[i] - c);
  // Scale for tolerances.
  const double extent = std::sqrt(*std::max_element(dist2.begin(), dist2.end()));
  const double tol = 1e-9 * std::max(extent, 1e-300);

  // Start at the lowest point (ties: leftmost): it is a vertex of the convex hull, so it is
  // on the loop for any threshold.
  std::uint32_t start = 0;
  for (std::uint32_t i = 1; i < n; ++i) {
    if (p[i].y < p[start].y || (p[i].y == p[start].y && p[i].x < p[start].x)) start = i;
  }
  const double a0 = pseudo_angle(p[start].x - c.x, p[start].y - c.y);
  std::vector<double>& key = scratch.key;
  key.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    double a = pseudo_angle(p[i].x - c.x, p[i].y - c.y) - a0;
    if (a < 0) a += 4;
    if (a >= 4) a -= 4;
    key[i] = i == start ? 0.0 : a;
  }
  // Every point but the start, by angle; on equal angles the nearer point first, so the
  // farther one survives the scan. Large clouds: only points near the outside of their angular
  // sector can be on the loop; walk those (the result is verified against every point below,
  // and redone without the filter if a dropped point turns out to be outside). The filtered
  // points are sorted sector by sector (a counting sort by sector, then small sorts): the same
  // order as one sort, in a fraction of its time on the trunk's thousands of points.
  const std::size_t sectors = std::clamp<std::size_t>(n / 8, 16, 512);
  auto candidates = [&](bool filter) -> const std::vector<std::uint32_t>& {
    std::vector<Scratch::Entry>& entries = scratch.entries;
    entries.clear();
    if (!filter) {
      for (std::uint32_t i = 0; i < n; ++i) {
        if (i != start) entries.push_back({key[i], dist2[i], i});
      }
      std::sort(entries.begin(), entries.end());
    } else {
      // Each point's sector, once (key in [0, 4): key x sectors / 4 below 512, so an int
      // conversion, a single instruction where the unsigned one is not).
      std::vector<std::uint32_t>& sector_of = scratch.sector_of;
      sector_of.resize(n);
      const double per_key = double(sectors) / 4.0;
      const auto last = static_cast<std::uint32_t>(sectors - 1);
      for (std::uint32_t i = 0; i < n; ++i)
        sector_of[i] = std::min(last, static_cast<std::uint32_t>(static_cast<int>(key[i] * per_key)));
      auto sector = [&](std::uint32_t i) { return sector_of[i]; };
      std::vector<double>& smax2 = scratch.smax2;
      smax2.assign(sectors, 0.0);
      for (std::uint32_t i = 0; i < n; ++i) smax2[sector(i)] = std::max(smax2[sector(i)], dist2[i]);
      std::vector<std::uint32_t>& begin = scratch.bucket_begin;
      begin.assign(sectors + 1, 0);
      for (std::uint32_t i = 0; i < n; ++i) {
        if (i != start && dist2[i] >= 0.36 * smax2[sector(i)]) {  // within 40 % of the farthest
          entries.push_back({key[i], dist2[i], i});
          ++begin[sector(i) + 1];
        }
      }
      for (std::size_t k = 0; k < sectors; ++k) begin[k + 1] += begin[k];
      std::vector<Scratch::Entry>& bucketed = scratch.bucketed;
      bucketed.resize(entries.size());
      for (const Scratch::Entry& e : entries) bucketed[begin[sector(e.i)]++] = e;
      // (begin[k] is now where bucket k ends.)
      std::size_t from = 0;
      for (std::size_t k = 0; k < sectors; ++k) {
        std::sort(bucketed.begin() + std::ptrdiff_t(from), bucketed.begin() + std::ptrdiff_t(begin[k]));
        from = begin[k];
      }
      entries.swap(bucketed);
    }
    std::vector<std::uint32_t>& order = scratch.order;
    order.resize(entries.size());
    for (std::size_t k = 0; k < entries.size(); ++k) order[k] = entries[k].i;
    return order;
  };
  const double max_concave = concave_turn_degrees * kPi / 180.0;
  const double cos_max_concave = std::cos(max_concave), cos2_max_concave = cos_max_concave * cos_max_concave;
  // A turn counts as concave (drop the middle point) when it turns right by more than the
  // threshold, or is straight / degenerate.
  // (Compared in squares where that saves a square root or a division: the walk runs over
  // every candidate of every slice.)
  const double tol2 = tol * tol;
  auto drop = [&](std::uint32_t a, std::uint32_t b, std::uint32_t q) {
    const dvec2 w = p[q] - p[a];
    const double wl2 = glm::dot(w, w);
    if (wl2 <= tol2) return true;  // a and q coincide: b is a spike or a duplicate
    // |w| x the signed distance of b from the chord a -> q, positive inwards (to the left).
    const double inward = cross2(w, p[b] - p[a]);
    if (inward < -1e-7 * wl2) return false;  // a convex vertex
    if (inward <= 1e-7 * wl2) return true;   // (nearly) collinear or duplicate: drop
    if (max_concave <= 0) return true;
    // Concave (b left of the chord, a right turn at b): keep only turns gentler than the
    // threshold, i.e. edges a->b and b->q at an angle below it: u . v >= cos |u| |v|, compared
    // in squares (no square root: this is the walk's most frequent test).
    const dvec2 u = p[b] - p[a], v = p[q] - p[b];
    const double uv = glm::dot(u, v), uuvv = glm::dot(u, u) * glm::dot(v, v);
    return cos_max_concave >= 0 ? !(uv > 0 && uv * uv >= cos2_max_concave * uuvv)
                                : uv < 0 && uv * uv > cos2_max_concave * uuvv;
  };
  auto walk = [&](const std::vector<std::uint32_t>& order) -> const std::vector<std::uint32_t>& {
    std::vector<std::uint32_t>& stack = scratch.stack;
    stack.clear();
    stack.push_back(start);
    for (std::uint32_t q : order) {
      while (stack.size() >= 2 && drop(stack[stack.size() - 2], stack.back(), q)) stack.pop_back();
      stack.push_back(q);
    }
    // Close the loop back to the start.
    while (stack.size() >= 3 && drop(stack[stack.size() - 2], stack.back(), start)) stack.pop_back();
    return stack;
  };
  const double valid_tol = tol + 1e-6 * extent;
  for (const bool filter : {true, false}) {
    if (filter && n <= 64) continue;
    const std::vector<std::uint32_t>& order = candidates(filter);
    const std::vector<std::uint32_t>& loop = walk(order);
    if (loop.size() < 3 || !star_loop_valid(p, key, dist2, c, loop, valid_tol, filter ? nullptr : &order,
                                            scratch.sector_of, sectors, scratch))
      continue;
    // The walk gives a star-shaped loop around every point. Where it bridges one gap much
    // wider than the spacing of its vertices and half as wide as the slice, the points may
    // not be star-shaped around the centroid (a "C"). When they are one connected shape at the
    // spacing of the points (the concave outline needs no long edge) and that outline turns
    // back around the centroid by more than kHiddenTurn, the outline is the true outer loop.
    // Kept with the walk: separate clusters (bundles a gap apart, which branch fusion wants
    // bridged) and the notches of a concave union (carving them into the loop was measured to
    // add self-intersections at forks: boutdenoylum2 879 -> 1262 pairs, small_pine 4695 ->
    // 5864). star_loop_valid left the loop's edge lengths in scratch.edge_length.
    if (fallback_max_edge > 0 && max_concave > 0 && single_bridge(scratch.edge_length, fallback_max_edge, extent)) {
      bool connected = false;
      std::vector<std::uint32_t> outline = concave_hull(p, fallback_max_edge, &connected);
      if (outline.size() >= 3 && connected && backward_turn(p, c, outline) > kHiddenTurn) {
        if (fallback) *fallback = true;
        out = std::move(outline);
        return;
      }
    }
    out.assign(loop.begin(), loop.end());
    return;
  }
  if (fallback) *fallback = true;
  if (fallback_max_edge > 0) {
    out = concave_hull(p, fallback_max_edge);
    if (out.size() >= 3) return;
  }
  out = convex_hull(p);
}

}  // namespace sm
