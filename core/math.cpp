#include "core/math.h"

#include <algorithm>

namespace sm {

dvec3 any_perpendicular(const dvec3& t) {
  // Cross with the world axis least aligned with t.
  const dvec3 a = std::abs(t.x) <= std::abs(t.y) && std::abs(t.x) <= std::abs(t.z) ? dvec3(1, 0, 0)
                  : std::abs(t.y) <= std::abs(t.z)                                 ? dvec3(0, 1, 0)
                                                                                   : dvec3(0, 0, 1);
  return glm::normalize(glm::cross(t, a));
}

Frame transport_frame(const Frame& f, const dvec3& t) {
  // Rotate f.normal by the rotation about (f.tangent × t) taking f.tangent to t
  // (Rodrigues' formula written without trigonometry).
  const dvec3& t0 = f.tangent;
  const dvec3 axis = glm::cross(t0, t);
  const double c = glm::dot(t0, t);
  dvec3 n = f.normal;
  if (c > -1.0 + 1e-12) {
    n = n * c + glm::cross(axis, n) + axis * (glm::dot(axis, n) / (1.0 + c));
  } else {
    // Opposite tangents: the rotation axis is undetermined; rotate by pi about f.normal,
    // which keeps the normal and flips the binormal.
  }
  Frame out;
  out.tangent = t;
  // Gram–Schmidt to remove drift.
  n = n - t * glm::dot(n, t);
  out.normal = normalize_or(n, any_perpendicular(t));
  out.binormal = glm::cross(t, out.normal);
  return out;
}

dvec3 barycentric(const dvec3& a, const dvec3& b, const dvec3& c, const dvec3& p) {
  const dvec3 v0 = b - a, v1 = c - a, v2 = p - a;
  const double d00 = glm::dot(v0, v0), d01 = glm::dot(v0, v1), d11 = glm::dot(v1, v1);
  const double d20 = glm::dot(v2, v0), d21 = glm::dot(v2, v1);
  const double den = d00 * d11 - d01 * d01;
  if (!(std::abs(den) > 0)) return {1.0, 0.0, 0.0};
  const double v = (d11 * d20 - d01 * d21) / den, w = (d00 * d21 - d01 * d20) / den;
  return {1.0 - v - w, v, w};
}

dvec3 closest_on_triangle(const dvec3& p, const dvec3& a, const dvec3& b, const dvec3& c) {
  const dvec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const dvec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const dvec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double den = 1.0 / (va + vb + vc);
  return a + ab * (vb * den) + ac * (vc * den);
}

void closest_segment_params(const dvec3& p0, const dvec3& p1, const dvec3& q0, const dvec3& q1, double& s, double& t) {
  const dvec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = glm::dot(d1, d1), e = glm::dot(d2, d2), f = glm::dot(d2, r);
  if (a <= 1e-300 && e <= 1e-300) {
    s = t = 0;
    return;
  }
  if (a <= 1e-300) {
    s = 0;
    t = std::clamp(f / e, 0.0, 1.0);
    return;
  }
  const double c = glm::dot(d1, r);
  if (e <= 1e-300) {
    t = 0;
    s = std::clamp(-c / a, 0.0, 1.0);
    return;
  }
  const double b = glm::dot(d1, d2), denom = a * e - b * b;
  s = denom > 1e-300 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  t = (b * s + f) / e;
  if (t < 0) {
    t = 0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1) {
    t = 1;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
}

}  // namespace sm
