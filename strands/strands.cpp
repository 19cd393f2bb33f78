// Strands stage: one curve per strand through its particles (Interactive Invigoration, Li et al.).
//
// We use Catmull-Rom splines rather than the paper's B-splines because they
// interpolate the particle positions; we take the centripetal variant (alpha = 0.5, Yuksel,
// Schaefer and Keyser 2011), which has no cusps or self-intersections within a segment, so a
// strand never loops between two cross-sections. Each segment is stored in Hermite form: its
// two end points are particle points and its two end tangents come from the Barry-Goldman
// formulation with the knot spacings |P_{i+1} - P_i|^alpha, rescaled from knot units to the
// segment parameter t in [0, 1]. At the ends of a strand (its start node, the root) the
// missing neighbour is mirrored, which gives the natural end condition. The tangents are
// computed from the points where a segment is evaluated (StrandSet::tangents).
//
// Everything is computed per particle from finished particle data, so the parallel loop over
// nodes writes by index and the result does not depend on the thread count.

#include "strands/strands.h"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/errors.h"

namespace sm {
namespace {

/// Knot spacing |b - a|^alpha (the centripetal default, alpha = 1/2, is a square root; pow is
/// several times slower).
double knot(const dvec3& a, const dvec3& b, double alpha) {
  const double l = glm::length(b - a);
  return alpha == 0.5 ? std::sqrt(l) : std::pow(l, alpha);
}

/// Whether the segment P1 -> P2 is a single point (within rounding of its coordinates).
bool coincide(const dvec3& p1, const dvec3& p2, double& eps) {
  eps = 1e-12 * (glm::length(p1) + glm::length(p2) + 1.0);
  return !(glm::length(p2 - p1) > eps);
}

/// Hermite tangents (per unit t of the segment P1 -> P2) of the Catmull-Rom curve through
/// P0, P1, P2, P3 with knot exponent alpha. Degenerate neighbours (coincident with the
/// segment's ends) are replaced by mirror images.
SegmentTangents segment_tangents(dvec3 p0, const dvec3& p1, const dvec3& p2, dvec3 p3, double alpha) {
  SegmentTangents out;
  double eps = 0;
  out.degenerate = coincide(p1, p2, eps);
  if (out.degenerate) return out;
  if (!(glm::length(p1 - p0) > eps)) p0 = 2.0 * p1 - p2;
  if (!(glm::length(p3 - p2) > eps)) p3 = 2.0 * p2 - p1;
  const double t01 = knot(p0, p1, alpha), t12 = knot(p1, p2, alpha), t23 = knot(p2, p3, alpha);
  const dvec3 d1 = (p1 - p0) / t01 - (p2 - p0) / (t01 + t12) + (p2 - p1) / t12;
  const dvec3 d2 = (p2 - p1) / t12 - (p3 - p1) / (t12 + t23) + (p3 - p2) / t23;
  out.at_parent = d1 * t12;
  out.at_node = d2 * t12;
  return out;
}

/// The segment of local particle j of node n on n's edge: its end points (P1 at the parent,
/// P2 at n) and their tangents.
struct Segment {
  dvec3 p1, p2;
  SegmentTangents m;
};

Segment segment_of(const StrandSet& st, const Skeleton& s, const ParticleField& f, NodeId n, std::uint32_t j) {
  const std::size_t i = n.idx();
  const NodeId parent = s.parent[i];
  const NodeId grand = s.parent[parent.idx()];
  const std::uint32_t pj = parent_index(s, f, n, j);
  const dvec3& p2 = st.point[f.global(n, j)];
  const dvec3& p1 = st.point[f.global(parent, pj)];
  // The strand's neighbouring points: at the grandparent, and in the child it comes from
  // (mirrored where the strand ends: the root's edge, its start node).
  const dvec3 p0 = grand.valid() ? st.point[f.global(grand, parent_index(s, f, parent, pj))] : 2.0 * p1 - p2;
  dvec3 p3 = 2.0 * p2 - p1;
  if (j < f.new_begin[i]) {
    const NodeId c0 = s.children[i][0], c1 = s.children[i][1];
    const std::uint32_t n0 = c0.valid() ? f.count(c0) : 0;
    p3 = j < n0 ? st.point[f.global(c0, j)] : st.point[f.global(c1, j - n0)];
  }
  return {p1, p2, segment_tangents(p0, p1, p2, p3, st.alpha)};
}

}  // namespace

SegmentTangents StrandSet::tangents(const Skeleton& s, const ParticleField& f, NodeId n, std::uint32_t j) const {
  return segment_of(*this, s, f, n, j).m;
}

dvec3 StrandSet::evaluate(const Skeleton& s, const ParticleField& f, NodeId n, std::uint32_t j, double t) const {
  const auto [p1, p2, m] = segment_of(*this, s, f, n, j);
  const double t2 = t * t, t3 = t2 * t;
  return (2 * t3 - 3 * t2 + 1) * p1 + (t3 - 2 * t2 + t) * m.at_parent + (-2 * t3 + 3 * t2) * p2 + (t3 - t2) * m.at_node;
}

dvec3 StrandSet::derivative(const Skeleton& s, const ParticleField& f, NodeId n, std::uint32_t j, double t) const {
  const auto [p1, p2, m] = segment_of(*this, s, f, n, j);
  const double t2 = t * t;
  return (6 * t2 - 6 * t) * p1 + (3 * t2 - 4 * t + 1) * m.at_parent + (-6 * t2 + 6 * t) * p2 +
         (3 * t2 - 2 * t) * m.at_node;
}

StrandSet build_strands(const Skeleton& sk, const ParticleField& f, const StrandParams& params) {
  check_params(params);
  SM_CHECK(f.node_count() == sk.size(), "build_strands: particle field and skeleton differ in node count");
  Stopwatch watch;
  StrandSet out;
  out.alpha = params.alpha;
  const std::size_t n = sk.size();
  const std::size_t total = f.position.size();
  out.point.resize(total);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 64), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Frame& fr = sk.frame[i];
      for (std::uint32_t g = f.node_begin[i]; g < f.node_begin[i + 1]; ++g) {
        out.point[g] = sk.position[i] + fr.to_world(f.position[g]);
      }
    }
  });
  out.stats.timings.add("points", watch.lap());

  // Segments whose two end points coincide (their curves are a point, their tangents zero).
  std::vector<std::uint8_t> degenerate(n, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(1, std::max<std::size_t>(n, 1), 64),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        const NodeId node(i), parent = sk.parent[i];
                        for (std::uint32_t j = 0; j < f.count(node) && !degenerate[i]; ++j) {
                          double eps = 0;
                          const dvec3& p1 = out.point[f.global(parent, parent_index(sk, f, node, j))];
                          if (coincide(p1, out.point[f.global(node, j)], eps)) degenerate[i] = 1;
                        }
                      }
                    });
  out.stats.timings.add("segments", watch.lap());
  out.stats.strands = f.strand_count();
  out.stats.segments = total - (n > 0 ? f.count(Skeleton::root()) : 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (degenerate[i]) {
      out.stats.warnings.add("degenerate_segment",
                             "strand points coincide at both ends of an edge: the segment is a single point",
                             sk.describe(NodeId(i)));
    }
  }
  return out;
}

StrandPath strand_path(const Skeleton& sk, const ParticleField& f, StrandId strand) {
  SM_CHECK(strand.idx() < f.strand_count(), "strand_path: strand id out of range");
  StrandPath path;
  NodeId n = f.strand_start[strand.idx()];
  std::uint32_t j = f.start_local(strand);
  for (;;) {
    path.nodes.push_back(n);
    path.local.push_back(j);
    const NodeId p = sk.parent[n.idx()];
    if (!p.valid()) break;
    j = parent_index(sk, f, n, j);
    n = p;
  }
  return path;
}

StrandPolyline sample_strand(const Skeleton& sk, const ParticleField& f, const StrandSet& strands, StrandId strand,
                             int samples_per_edge) {
  SM_CHECK(samples_per_edge >= 1, "sample_strand: samples_per_edge must be >= 1");
  const StrandPath path = strand_path(sk, f, strand);
  StrandPolyline out;
  out.points.reserve(path.nodes.size() * std::size_t(samples_per_edge) + 1);
  for (std::size_t k = 0; k + 1 < path.nodes.size(); ++k) {
    for (int q = 0; q < samples_per_edge; ++q) {
      const double t = 1.0 - double(q) / samples_per_edge;  // tip to root: t from 1 down to 0
      out.points.push_back(strands.evaluate(sk, f, path.nodes[k], path.local[k], t));
    }
  }
  out.points.push_back(strands.point[f.global(path.nodes.back(), path.local.back())]);
  out.arc_length.resize(out.points.size(), 0.0);
  for (std::size_t i = 1; i < out.points.size(); ++i) {
    out.arc_length[i] = out.arc_length[i - 1] + glm::length(out.points[i] - out.points[i - 1]);
  }
  return out;
}

dvec3 point_at_arc_length(const StrandPolyline& polyline, double s) {
  SM_CHECK(!polyline.points.empty(), "point_at_arc_length: empty polyline");
  const auto& a = polyline.arc_length;
  if (!(s > 0)) return polyline.points.front();
  if (s >= a.back()) return polyline.points.back();
  const std::size_t i = std::size_t(std::upper_bound(a.begin(), a.end(), s) - a.begin());  // a[i-1] <= s < a[i]
  const double len = a[i] - a[i - 1];
  const double u = len > 0 ? (s - a[i - 1]) / len : 0.0;
  return polyline.points[i - 1] + u * (polyline.points[i] - polyline.points[i - 1]);
}

}  // namespace sm
