// Quality measures of particle fields (see quality.h for the definitions).
//
// Nearest neighbours come from a nanoflann kd-tree per cloud. The largest empty circle is
// searched by sampling candidate centres on a square grid inside the confining disc (the
// distance to the nearest particle is 1-Lipschitz, so the best sample is within half a grid
// diagonal of the optimum) and refining the best samples by a shrinking pattern search.
// Per-node results are written by index and combined in node order, so the figures do not
// depend on the thread count.

#include "particles/quality.h"

#include <algorithm>
#include <cmath>
#include <span>

#include <nanoflann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace sm {
namespace {

struct CloudAdaptor {
  const dvec2* pts = nullptr;
  std::size_t n = 0;
  [[nodiscard]] std::size_t kdtree_get_point_count() const { return n; }
  [[nodiscard]] double kdtree_get_pt(std::size_t i, std::size_t dim) const { return dim == 0 ? pts[i].x : pts[i].y; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, CloudAdaptor>, CloudAdaptor, 2,
                                                   std::uint32_t>;

/// k nearest neighbours (excluding the point itself) of every point of `pts`, row-major
/// #n by k, sorted by distance (ties by index).
void knn_all(std::span<const dvec2> pts, std::uint32_t k, std::vector<std::uint32_t>& out, std::vector<double>* nearest) {
  const std::size_t n = pts.size();
  out.assign(n * k, 0);
  if (nearest) nearest->assign(n, std::numeric_limits<double>::infinity());
  if (n < 2 || k == 0) return;
  const CloudAdaptor adaptor{pts.data(), n};
  const KdTree tree(2, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  std::vector<std::uint32_t> idx(k + 1);
  std::vector<double> d2(k + 1);
  std::vector<std::pair<double, std::uint32_t>> found;
  for (std::size_t i = 0; i < n; ++i) {
    const double q[2] = {pts[i].x, pts[i].y};
    const std::size_t got = tree.knnSearch(q, k + 1, idx.data(), d2.data());
    found.clear();
    for (std::size_t a = 0; a < got; ++a) {
      if (idx[a] != i) found.emplace_back(d2[a], idx[a]);
    }
    std::sort(found.begin(), found.end());
    for (std::uint32_t a = 0; a < k; ++a) out[i * k + a] = a < found.size() ? found[a].second : std::uint32_t(i);
    if (nearest && !found.empty()) (*nearest)[i] = std::sqrt(found.front().first);
  }
}

double nearest_distance(const KdTree& tree, dvec2 q) {
  std::uint32_t idx = 0;
  double d2 = 0;
  const double p[2] = {q.x, q.y};
  tree.knnSearch(p, 1, &idx, &d2);
  return std::sqrt(d2);
}

/// Radius of the largest empty circle centred in the disc of radius `disc` (sampling + refinement).
double largest_empty_circle(std::span<const dvec2> pts, double disc, double step) {
  if (pts.empty()) return disc;
  const CloudAdaptor adaptor{pts.data(), pts.size()};
  const KdTree tree(2, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  const int side = std::max(1, int(std::ceil(disc / step)));
  std::vector<std::pair<double, dvec2>> best;  // a few best samples, kept sorted descending
  constexpr std::size_t keep = 6;
  for (int y = -side; y <= side; ++y) {
    for (int x = -side; x <= side; ++x) {
      dvec2 c(x * step, y * step);
      const double l = glm::length(c);
      if (l > disc) c *= disc / l;  // samples outside the disc move onto its rim
      const double d = nearest_distance(tree, c);
      if (best.size() < keep || d > best.back().first) {
        best.emplace_back(d, c);
        std::sort(best.begin(), best.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
        if (best.size() > keep) best.pop_back();
      }
    }
  }
  double result = 0;
  for (auto [d, c] : best) {
    double h = step * 0.5;
    for (int it = 0; it < 24; ++it) {
      bool moved = false;
      for (int k = 0; k < 8; ++k) {
        const double a = k * std::numbers::pi / 4;
        dvec2 q = c + h * dvec2(std::cos(a), std::sin(a));
        const double l = glm::length(q);
        if (l > disc) q *= disc / l;
        const double dq = nearest_distance(tree, q);
        if (dq > d) {
          d = dq;
          c = q;
          moved = true;
        }
      }
      if (!moved) h *= 0.5;
    }
    result = std::max(result, d);
  }
  return result;
}

}  // namespace

ParticleQuality measure_particles(const Skeleton& sk, const ParticleField& f, const QualityParams& params) {
  const std::size_t n = f.node_count();
  const double s = f.spacing;
  const std::uint32_t k_max = params.neighbours;
  ParticleQuality q;
  q.node_min_pair.assign(n, ParticleQuality::inf);
  q.node_hole.assign(n, 0.0);
  q.node_losses.assign(n, 0);
  std::vector<double> node_radius_ratio(n, 0.0);
  std::vector<std::uint32_t> node_events(n, 0);
  std::vector<double> nearest_all(f.position.size(), 0.0);
  std::vector<std::uint8_t> lost(f.position.size(), 0);  // per particle (n, j): lost on n's edge

  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 16), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<std::uint32_t> child_nn, parent_nn;
    std::vector<double> nearest;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const NodeId node(i);
      const std::uint32_t m = f.count(node), b = f.node_begin[i];
      const std::span<const dvec2> pts(f.position.data() + b, m);
      const double r = sk.radius[i];
      const double lambda = r / std::sqrt(double(std::max<std::uint32_t>(m, 1)));
      double rr = 0;
      for (const dvec2& p : pts) rr = std::max(rr, glm::length(p) / r);
      node_radius_ratio[i] = rr;
      const std::uint32_t k = m > 0 ? std::min(k_max, m - 1) : 0;
      knn_all(pts, k, child_nn, &nearest);
      double closest = ParticleQuality::inf;
      for (std::uint32_t j = 0; j < m; ++j) {
        closest = std::min(closest, nearest[j]);
        nearest_all[b + j] = nearest[j];
      }
      q.node_min_pair[i] = closest / std::min(s, lambda);
      if (params.holes) q.node_hole[i] = largest_empty_circle(pts, f.disc_radius[i], params.hole_sample * lambda) / s;
      // Neighbourhoods from n to its parent, among n's strands.
      const NodeId parent = sk.parent[i];
      if (!parent.valid() || k == 0) continue;
      const std::uint32_t off = parent_index(sk, f, node, 0);
      const std::span<const dvec2> block(f.position.data() + f.node_begin[parent.idx()] + off, m);
      knn_all(block, k, parent_nn, nullptr);
      std::uint32_t losses = 0;
      for (std::uint32_t j = 0; j < m; ++j) {
        std::uint32_t kept = 0;
        for (std::uint32_t a = 0; a < k; ++a) {
          for (std::uint32_t c = 0; c < k; ++c) kept += child_nn[j * k + a] == parent_nn[j * k + c];
        }
        if (2 * (k - kept) > k) {
          ++losses;
          lost[b + j] = 1;
        }
      }
      q.node_losses[i] = losses;
      node_events[i] = m;
    }
  });

  std::vector<std::uint8_t> strand_lost(f.strand_count(), 0);
  for (std::size_t i = 0; i < n; ++i) {
    const NodeId node(i);
    q.max_radius_ratio = std::max(q.max_radius_ratio, node_radius_ratio[i]);
    if (q.node_min_pair[i] < q.min_pair) {
      q.min_pair = q.node_min_pair[i];
      q.min_pair_node = node;
    }
    const double lambda = sk.radius[i] / std::sqrt(double(std::max<std::uint32_t>(f.count(node), 1)));
    if (lambda >= s) q.min_pair_s = std::min(q.min_pair_s, q.node_min_pair[i] * std::min(s, lambda) / s);
    if (q.node_hole[i] > q.max_hole) {
      q.max_hole = q.node_hole[i];
      q.max_hole_node = node;
    }
    q.neighbour_events += node_events[i];
    q.neighbour_losses += q.node_losses[i];
    const NodeId parent = sk.parent[i];
    if (parent.valid() && sk.is_fork(parent)) {
      q.fork_events += node_events[i];
      q.fork_losses += q.node_losses[i];
    }
    for (std::uint32_t j = f.node_begin[i]; j < f.node_begin[i + 1]; ++j) {
      if (lost[j]) strand_lost[f.strand[j].idx()] = 1;
    }
  }
  for (std::uint8_t l : strand_lost) q.strands_with_loss += l;
  if (!nearest_all.empty()) {
    std::vector<double> sorted = nearest_all;
    const auto mid = sorted.begin() + std::ptrdiff_t(sorted.size() / 2);
    std::nth_element(sorted.begin(), mid, sorted.end());
    q.median_nearest = *mid / s;
  }
  return q;
}

}  // namespace sm
