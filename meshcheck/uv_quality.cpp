// UV quality (meshcheck/uv_quality.h): seams per edge, the stretch of each triangle's map to
// UV from its singular values.
//
// Why these figures: on a close-up a texture shows every place where its UVs jump (a seam
// edge), and a sheared or squeezed map as checks turned to diamonds or stripes. A branch
// needs one seam where u wraps around it; anything else is a defect to be counted. The
// density against the tree's median says whether the bark's grain keeps one size on thick
// and thin branches.

#include "meshcheck/uv_quality.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "meshcheck/regions.h"

namespace sm {
namespace {

using glm::dvec2;
using glm::dvec3;

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const auto k = static_cast<std::size_t>(std::max(1.0, std::ceil(q * static_cast<double>(v.size())))) - 1;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

/// The map of one triangle from its plane to UV: singular values and the sign of its
/// determinant (0 for a triangle of zero area in 3D).
struct TriangleMap {
  double s1 = 0, s2 = 0;
  int sign = 0;
};

TriangleMap triangle_map(const dvec3 p[3], const dvec2 q[3]) {
  const dvec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
  const dvec3 n = glm::cross(e1, e2);
  const double l1 = glm::length(e1), twice_area = glm::length(n);
  if (!(l1 > 0) || !(twice_area > 0) || !std::isfinite(twice_area)) return {};
  const dvec3 x = e1 / l1, y = glm::cross(n / twice_area, x);
  // P: the edges in the plane's basis (columns), Q: the same edges in UV. J = Q P^-1.
  const double p11 = l1, p12 = glm::dot(e2, x), p22 = glm::dot(e2, y);  // p21 = 0
  const dvec2 q1 = q[1] - q[0], q2 = q[2] - q[0];
  // P^-1 = [[1/p11, -p12/(p11 p22)], [0, 1/p22]]
  const double a = q1.x / p11, c = q1.y / p11;
  const double b = (q2.x - q1.x * p12 / p11) / p22, d = (q2.y - q1.y * p12 / p11) / p22;
  const double det = a * d - b * c;
  const double e = a * a + b * b + c * c + d * d;
  const double root = std::sqrt(std::max(0.0, e * e - 4.0 * det * det));
  TriangleMap m;
  m.s1 = std::sqrt(std::max(0.0, 0.5 * (e + root)));
  m.s2 = m.s1 > 0 ? std::abs(det) / m.s1 : 0.0;
  m.sign = det > 0 ? 1 : (det < 0 ? -1 : 0);
  if (m.sign == 0) m.sign = 2;  // zero area in UV (but not in 3D)
  return m;
}

}  // namespace

UvQuality measure_uv_quality(const Mesh& mesh, const Skeleton* skeleton, const QualityParams& params) {
  UvQuality q;
  const std::size_t nv = mesh.positions.size(), nf = mesh.triangles.size();
  if (mesh.corner_uvs.size() != nf || nf == 0) return q;

  // ---- caps and junctions
  std::vector<std::uint8_t> cap(nf, 0);
  std::unique_ptr<detail::ConeTree> forks;
  if (skeleton && skeleton->size() >= 2) {
    q.caps_known = true;
    cap = detail::cap_triangles(mesh, detail::cap_ends(mesh, *skeleton));
    forks = detail::junction_balls(*skeleton, params.junction_radii);
  }
  auto at_junction = [&](const dvec3& p) { return forks && forks->nearest(p).distance <= 0; };

  // ---- triangles: the map's singular values
  std::vector<TriangleMap> map(nf);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf, 8192), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t f = r.begin(); f != r.end(); ++f) {
      const auto& t = mesh.triangles[f];
      const dvec3 p[3] = {mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]};
      const dvec2 uv[3] = {dvec2(mesh.corner_uvs[f][0]), dvec2(mesh.corner_uvs[f][1]), dvec2(mesh.corner_uvs[f][2])};
      map[f] = triangle_map(p, uv);
    }
  });
  std::vector<std::uint8_t> junction(nf, 0);
  if (forks) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t f = r.begin(); f != r.end(); ++f) {
        const auto& t = mesh.triangles[f];
        junction[f] = at_junction((mesh.positions[t[0]] + mesh.positions[t[1]] + mesh.positions[t[2]]) / 3.0);
      }
    });
  }
  std::size_t positive = 0, negative = 0;
  std::vector<double> density, anisotropy, junction_density, junction_anisotropy;
  for (std::size_t f = 0; f < nf; ++f) {
    const TriangleMap& m = map[f];
    if (m.sign == 0 || cap[f]) continue;
    ++q.triangles;
    q.junction_triangles += junction[f];
    if (m.sign == 2 || !(m.s2 > 1e-9 * m.s1)) {
      ++q.collapsed;
      continue;
    }
    (m.sign > 0 ? positive : negative) += 1;
  }
  const int majority = positive >= negative ? 1 : -1;
  q.flipped = majority > 0 ? negative : positive;
  for (std::size_t f = 0; f < nf; ++f) {
    const TriangleMap& m = map[f];
    if (m.sign == 0 || m.sign == 2 || cap[f] || !(m.s2 > 1e-9 * m.s1)) continue;
    density.push_back(std::sqrt(m.s1 * m.s2));
    anisotropy.push_back(m.s1 / m.s2);
    if (junction[f]) junction_anisotropy.push_back(m.s1 / m.s2);
  }
  q.density_median = percentile(density, 0.5);
  q.anisotropy_p95 = percentile(anisotropy, 0.95);
  q.anisotropy_max = anisotropy.empty() ? 0.0 : *std::max_element(anisotropy.begin(), anisotropy.end());
  q.junction_anisotropy_p95 = percentile(junction_anisotropy, 0.95);
  if (q.density_median > 0) {
    const double med = q.density_median;
    std::vector<double> ratio, junction_ratio;
    for (std::size_t f = 0; f < nf; ++f) {
      const TriangleMap& m = map[f];
      if (m.sign == 0 || m.sign == 2 || cap[f] || !(m.s2 > 1e-9 * m.s1)) continue;
      const double d = std::sqrt(m.s1 * m.s2) / med;
      const double r = std::max(d, 1.0 / d);
      ratio.push_back(r);
      if (junction[f]) junction_ratio.push_back(r);
    }
    q.density_p95 = percentile(ratio, 0.95);
    q.junction_density_p95 = percentile(junction_ratio, 0.95);
  }

  // ---- edges: each once, from its lower vertex, where it has two triangles
  const VertexCorners vc = vertex_corners(mesh);
  auto corner_uv = [&](std::uint32_t f, std::uint32_t v) {
    const auto& t = mesh.triangles[f];
    return dvec2(mesh.corner_uvs[f][t[0] == v ? 0 : (t[1] == v ? 1 : 2)]);
  };
  struct Counts {
    std::size_t seams = 0, around = 0, other = 0, junction_around = 0, junction_other = 0;
    std::vector<std::array<std::uint32_t, 2>> examples;
  };
  constexpr std::size_t kRange = 1 << 14;
  const std::size_t ranges = (nv + kRange - 1) / kRange;
  std::vector<Counts> counts(ranges);
  tbb::parallel_for(std::size_t{0}, ranges, [&](std::size_t ri) {
    std::vector<std::pair<std::uint32_t, std::uint32_t>> spokes;  // (other vertex, triangle)
    Counts& c = counts[ri];
    for (std::size_t a = ri * kRange; a < std::min(nv, (ri + 1) * kRange); ++a) {
      spokes.clear();
      for (std::uint32_t i = vc.begin[a]; i < vc.begin[a + 1]; ++i) {
        const std::uint32_t corner = vc.corner[i], f = corner / 3;
        for (const std::uint32_t b : {mesh.triangles[f][(corner + 1) % 3], mesh.triangles[f][(corner + 2) % 3]}) {
          if (b > a) spokes.emplace_back(b, f);
        }
      }
      std::sort(spokes.begin(), spokes.end());
      for (std::size_t i = 0; i < spokes.size();) {
        std::size_t j = i;
        while (j < spokes.size() && spokes[j].first == spokes[i].first) ++j;
        if (j - i != 2) {
          i = j;
          continue;
        }
        const std::uint32_t f = spokes[i].second, g = spokes[i + 1].second, b = spokes[i].first;
        i = j;
        const auto va = static_cast<std::uint32_t>(a);
        const dvec2 jump[2] = {corner_uv(f, va) - corner_uv(g, va), corner_uv(f, b) - corner_uv(g, b)};
        if (jump[0] == dvec2(0) && jump[1] == dvec2(0)) continue;
        ++c.seams;
        // Around: a jump in u only, the same way and about as far at both ends (one end only
        // at a cap's pole).
        const bool poles = cap[f] && cap[g];
        bool around = true;
        int direction = 0;
        double lo = std::numeric_limits<double>::infinity(), hi = 0;
        for (const dvec2& d : jump) {
          if (d == dvec2(0)) {
            if (!poles) around = false;
            continue;
          }
          const int s = d.x > 0 ? 1 : -1;
          if (!(std::abs(d.y) <= 1e-3 * std::abs(d.x)) || (direction != 0 && s != direction)) around = false;
          direction = s;
          lo = std::min(lo, std::abs(d.x));
          hi = std::max(hi, std::abs(d.x));
        }
        if (around && hi > 1.5 * lo) around = false;
        const dvec3 mid = 0.5 * (mesh.positions[a] + mesh.positions[b]);
        (around ? c.around : c.other) += 1;
        if (!around && c.examples.size() < params.max_examples) c.examples.push_back({va, b});
        if (forks && at_junction(mid)) (around ? c.junction_around : c.junction_other) += 1;
      }
    }
  });
  for (const Counts& c : counts) {
    q.seam_edges += c.seams;
    q.around_seams += c.around;
    q.other_seams += c.other;
    q.junction_around_seams += c.junction_around;
    q.junction_other_seams += c.junction_other;
    for (const auto& e : c.examples) {
      if (q.other_seam_examples.size() < params.max_examples) q.other_seam_examples.push_back(e);
    }
  }
  return q;
}

}  // namespace sm
