// Triangle quality (meshcheck/quality.h): angles and aspect ratios per triangle, dihedral
// angles per edge (edges found per vertex from its corners, so the pass is linear and runs
// in parallel), caps and junctions placed by the nearest skeleton edge, backward normals per
// corner.
//
// Why these figures: a close-up shows needles (small angles) as shading streaks and texture
// smears, ridges (large dihedral angles between neighbours) as visible kinks, and a normal
// facing away from its triangle as a black patch. Caps are left out of the dihedral angles:
// a dome over a five-strand twig tip is sharp by nature and not where anyone looks.

#include "meshcheck/quality.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/errors.h"
#include "meshcheck/regions.h"

namespace sm {
namespace {

using glm::dvec3;
constexpr double kDegrees = 180.0 / std::numbers::pi;

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const auto k = static_cast<std::size_t>(std::max(1.0, std::ceil(q * static_cast<double>(v.size())))) - 1;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

double angle_between(const dvec3& a, const dvec3& b) {
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b)) * kDegrees;
}

std::string percent(double share) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g %%", 100.0 * share);
  return buf;
}

}  // namespace

std::vector<std::string> TriangleQuality::failures(const QualityLimits& limits) const {
  std::vector<std::string> f;
  if (share_under_10() > limits.max_share_under_10) {
    f.push_back(percent(share_under_10()) + " of the triangles have an angle under 10 degrees (limit " +
                percent(limits.max_share_under_10) + ")");
  }
  if (under_1 > limits.max_under_1) {
    f.push_back(std::to_string(under_1) + " triangles have an angle under 1 degree (limit " +
                std::to_string(limits.max_under_1) + ")");
  }
  if (junction_edges > 0 && junction_dihedral_p99 > limits.max_junction_dihedral_p99) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "dihedral angle p99 at junctions %.3g degrees (limit %.3g)", junction_dihedral_p99,
                  limits.max_junction_dihedral_p99);
    f.push_back(buf);
  }
  if (backward_normals > limits.max_backward_normals) {
    f.push_back(std::to_string(backward_normals) + " vertices with a normal facing away from a triangle (limit " +
                std::to_string(limits.max_backward_normals) + ")");
  }
  return f;
}

TriangleQuality measure_quality(const Mesh& mesh, const Skeleton* skeleton, const QualityParams& params) {
  const std::size_t nv = mesh.positions.size(), nf = mesh.triangles.size();
  for (std::size_t t = 0; t < nf; ++t) {
    for (const std::uint32_t v : mesh.triangles[t]) {
      if (v >= nv) {
        throw InvalidInputError("mesh: triangle " + std::to_string(t) + " references vertex " + std::to_string(v) +
                                " but the mesh has " + std::to_string(nv) + " vertices");
      }
    }
  }
  TriangleQuality q;
  q.triangles = nf;

  // ---- triangles: smallest angle, aspect ratio, unit normal
  std::vector<double> min_angle(nf), aspect(nf, -1.0);
  std::vector<dvec3> normal(nf);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf, 8192), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t f = r.begin(); f != r.end(); ++f) {
      const auto& t = mesh.triangles[f];
      const dvec3 p[3] = {mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]};
      const dvec3 n = glm::cross(p[1] - p[0], p[2] - p[0]);
      const double twice_area = glm::length(n);
      double smallest = 180, longest2 = 0;
      for (int k = 0; k < 3; ++k) {
        const dvec3 e1 = p[(k + 1) % 3] - p[k], e2 = p[(k + 2) % 3] - p[k];
        smallest = std::min(smallest, twice_area > 0 ? angle_between(e1, e2) : 0.0);
        longest2 = std::max(longest2, glm::dot(e1, e1));
      }
      min_angle[f] = smallest;
      if (twice_area > 0 && std::isfinite(twice_area)) {
        aspect[f] = longest2 * std::sqrt(3.0) / (2.0 * twice_area);
        normal[f] = n / twice_area;
      } else {
        normal[f] = dvec3(0);
      }
    }
  });
  q.min_angle = nf ? 180.0 : 0.0;
  std::vector<double> aspects;
  aspects.reserve(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    q.under_1 += min_angle[f] < 1;
    q.under_5 += min_angle[f] < 5;
    q.under_10 += min_angle[f] < 10;
    q.min_angle = std::min(q.min_angle, min_angle[f]);
    if (aspect[f] >= 0) aspects.push_back(aspect[f]);
  }
  q.aspect_p95 = percentile(aspects, 0.95);
  q.aspect_max = aspects.empty() ? 0.0 : *std::max_element(aspects.begin(), aspects.end());
  aspects = {};
  min_angle = {};

  // ---- caps and junctions (with a skeleton)
  std::vector<std::uint32_t> cap_end;
  std::vector<std::uint8_t> cap_triangle(nf, 0);
  std::unique_ptr<detail::ConeTree> forks;
  if (skeleton && skeleton->size() >= 2) {
    const Skeleton& s = *skeleton;
    q.caps_known = true;
    cap_end = detail::cap_ends(mesh, s);
    cap_triangle = detail::cap_triangles(mesh, cap_end);
    forks = detail::junction_balls(s, params.junction_radii);
  }

  // ---- edges: each once, from its lower vertex; dihedral angle where it has two triangles
  const VertexCorners vc = vertex_corners(mesh);
  struct Edge {
    std::uint32_t a, b;
    double angle;
    bool junction;
  };
  constexpr std::size_t kRange = 1 << 14;
  const std::size_t ranges = (nv + kRange - 1) / kRange;
  std::vector<std::vector<Edge>> found(ranges);
  std::vector<std::size_t> caps(ranges, 0);
  tbb::parallel_for(std::size_t{0}, ranges, [&](std::size_t ri) {
    std::vector<std::pair<std::uint32_t, std::uint32_t>> spokes;  // (other vertex, triangle)
    for (std::size_t a = ri * kRange; a < std::min(nv, (ri + 1) * kRange); ++a) {
      spokes.clear();
      for (std::uint32_t i = vc.begin[a]; i < vc.begin[a + 1]; ++i) {
        const std::uint32_t c = vc.corner[i], f = c / 3;
        for (const std::uint32_t b : {mesh.triangles[f][(c + 1) % 3], mesh.triangles[f][(c + 2) % 3]}) {
          if (b > a) spokes.emplace_back(b, f);
        }
      }
      std::sort(spokes.begin(), spokes.end());
      for (std::size_t i = 0; i < spokes.size();) {
        std::size_t j = i;
        while (j < spokes.size() && spokes[j].first == spokes[i].first) ++j;
        if (j - i == 2) {
          const std::uint32_t f = spokes[i].second, g = spokes[i + 1].second;
          const std::uint32_t b = spokes[i].first;
          if (cap_triangle[f] || cap_triangle[g]) {
            ++caps[ri];
          } else if (normal[f] != dvec3(0) && normal[g] != dvec3(0)) {
            const dvec3 mid = 0.5 * (mesh.positions[a] + mesh.positions[b]);
            const bool junction = forks && forks->nearest(mid).distance <= 0;
            found[ri].push_back({static_cast<std::uint32_t>(a), b, angle_between(normal[f], normal[g]), junction});
          }
        }
        i = j;
      }
    }
  });
  std::vector<double> all, at_junctions;
  std::vector<Edge> edges;
  for (std::size_t ri = 0; ri < ranges; ++ri) {
    q.cap_edges += caps[ri];
    for (const Edge& e : found[ri]) {
      all.push_back(e.angle);
      if (e.junction) at_junctions.push_back(e.angle);
    }
    edges.insert(edges.end(), found[ri].begin(), found[ri].end());
    found[ri] = {};
  }
  q.edges = all.size();
  q.junction_edges = at_junctions.size();
  q.dihedral_p99 = percentile(all, 0.99);
  q.dihedral_max = all.empty() ? 0.0 : *std::max_element(all.begin(), all.end());
  q.junction_dihedral_p99 = percentile(at_junctions, 0.99);
  q.junction_dihedral_max = at_junctions.empty() ? 0.0 : *std::max_element(at_junctions.begin(), at_junctions.end());
  const std::size_t shown = std::min(params.max_examples, edges.size());
  std::partial_sort(edges.begin(), edges.begin() + static_cast<std::ptrdiff_t>(shown), edges.end(),
                    [](const Edge& x, const Edge& y) {
                      return x.angle != y.angle ? x.angle > y.angle : (x.a != y.a ? x.a < y.a : x.b < y.b);
                    });
  for (std::size_t k = 0; k < shown; ++k) q.sharpest_edges.push_back({edges[k].a, edges[k].b});

  // ---- normals: each corner's (its vertex's, or its own where the mesh has corner normals)
  // against its triangle's
  std::vector<dvec3> computed;
  q.normals_per_corner = mesh.normals.size() == nv && mesh.corner_normals.size() == nf;
  if (mesh.normals.size() != nv) {
    q.normals_computed = true;
    computed = angle_weighted_normals(mesh, vc);
  }
  const std::vector<dvec3>& vertex_normal = q.normals_computed ? computed : mesh.normals;
  std::vector<std::uint8_t> backward(nv, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      for (std::uint32_t i = vc.begin[v]; i < vc.begin[v + 1]; ++i) {
        const std::uint32_t c = vc.corner[i];
        const dvec3 n = q.normals_per_corner ? dvec3(mesh.corner_normals[c / 3][c % 3]) : vertex_normal[v];
        if (glm::dot(n, normal[c / 3]) < 0) backward[v] = 1;
      }
    }
  });
  for (std::size_t v = 0; v < nv; ++v) {
    if (!backward[v]) continue;
    ++q.backward_normals;
    if (q.backward_normal_examples.size() < params.max_examples)
      q.backward_normal_examples.push_back(static_cast<std::uint32_t>(v));
  }
  return q;
}

}  // namespace sm
