#pragma once
/// Small geometric helpers shared by the stages (GLM, double precision).

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/glm.hpp>

namespace sm {

using glm::dvec2;
using glm::dvec3;

/// An orthonormal frame: `tangent` points along the branch (from the root towards the tips),
/// `normal` and `binormal` span the cross-section plane; (normal, binormal, tangent) is
/// right-handed, so 2D cross-section coordinates (x along normal, y along binormal) turn
/// counter-clockwise when seen from the tip side, looking against the tangent.
struct Frame {
  dvec3 tangent{0, 0, 1};
  dvec3 normal{1, 0, 0};
  dvec3 binormal{0, 1, 0};

  /// 3D offset of the 2D cross-section point p (metres) in this frame.
  [[nodiscard]] dvec3 to_world(dvec2 p) const { return p.x * normal + p.y * binormal; }
  /// 2D cross-section coordinates of the 3D offset v (projected onto the section plane).
  [[nodiscard]] dvec2 to_local(const dvec3& v) const { return {glm::dot(v, normal), glm::dot(v, binormal)}; }
};

/// A unit vector perpendicular to the unit vector `t` (deterministic choice).
dvec3 any_perpendicular(const dvec3& t);

/// The frame with tangent `t` (unit) obtained from `f` by the minimal rotation taking
/// f.tangent to t (one step of parallel transport, double reflection method of Wang et al.
/// 2008 reduced to a single rotation). The result is re-orthonormalized.
Frame transport_frame(const Frame& f, const dvec3& t);

/// Normalizes v; returns `fallback` when |v| is (close to) zero.
inline dvec3 normalize_or(const dvec3& v, const dvec3& fallback) {
  const double l = glm::length(v);
  return l > 1e-300 && std::isfinite(l) ? v / l : fallback;
}

/// Closest points between the segments [p0, p1] and [q0, q1]: their parameters s, t in
/// [0, 1] (clamped, Ericson, Real-Time Collision Detection §5.1.9; degenerate segments are
/// points).
void closest_segment_params(const dvec3& p0, const dvec3& p1, const dvec3& q0, const dvec3& q1, double& s, double& t);

/// The parameter t in [0, 1] of the point a + t (b - a) of segment [a, b] nearest to p (0 for
/// a degenerate segment).
inline double segment_param(const dvec3& p, const dvec3& a, const dvec3& b) {
  const dvec3 ab = b - a;
  const double l2 = glm::dot(ab, ab);
  return l2 > 0 ? std::clamp(glm::dot(p - a, ab) / l2, 0.0, 1.0) : 0.0;
}

/// The point of triangle (a, b, c) nearest to p (Ericson, Real-Time Collision Detection §5.1.5).
dvec3 closest_on_triangle(const dvec3& p, const dvec3& a, const dvec3& b, const dvec3& c);

/// The smallest angle of triangle (a, b, c) (radians; 0 where it is degenerate): the one
/// opposite the shortest edge.
inline double smallest_angle(const dvec3& a, const dvec3& b, const dvec3& c) {
  const dvec3 p[3] = {a, b, c};
  int k = 0;  // the corner opposite the shortest edge
  double shortest = INFINITY;
  for (int i = 0; i < 3; ++i) {
    const dvec3 e = p[(i + 2) % 3] - p[(i + 1) % 3];
    if (const double l = glm::dot(e, e); l < shortest) shortest = l, k = i;
  }
  const dvec3 u = p[(k + 1) % 3] - p[k], v = p[(k + 2) % 3] - p[k];
  const double s = glm::length(glm::cross(u, v));
  return s > 0 ? std::atan2(s, glm::dot(u, v)) : 0.0;
}

/// Barycentric coordinates of p, projected onto the plane of (a, b, c), in that triangle
/// (unclamped; (1, 0, 0) for a degenerate triangle).
dvec3 barycentric(const dvec3& a, const dvec3& b, const dvec3& c, const dvec3& p);

/// The solid angle (steradians, signed: positive when a, b, c run counter-clockwise seen from
/// the origin) that the triangle with corners a, b, c, relative to the point, spans there (Van
/// Oosterom and Strackee). Summed over a closed mesh and divided by 4 pi: the winding number.
inline double solid_angle(const dvec3& a, const dvec3& b, const dvec3& c) {
  const double la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
  const double det = glm::dot(a, glm::cross(b, c));
  const double div = la * lb * lc + glm::dot(a, b) * lc + glm::dot(a, c) * lb + glm::dot(b, c) * la;
  return 2.0 * std::atan2(det, div);
}

/// atan2(y, x) within 2e-6 radians, several times cheaper than std::atan2 (one division and
/// a degree-11 odd polynomial for atan on [0, 1], a minimax fit): for weights and angles that
/// need no more. 0 at the origin.
inline double fast_atan2(double y, double x) {
  const double ax = std::abs(x), ay = std::abs(y);
  if (!(ax > 0 || ay > 0)) return 0.0;
  // (Selects rather than branches: the octant is as good as random from one call to the next.)
  const double t = std::min(ax, ay) / std::max(ax, ay);  // in [0, 1]
  const double t2 = t * t;
  const double a =
      t *
      (0.99997726 + t2 * (-0.33262347 + t2 * (0.19354346 + t2 * (-0.11643287 + t2 * (0.05265332 + t2 * -0.01172120)))));
  const double b = ax < ay ? 0.5 * std::numbers::pi - a : a;
  const double c = x < 0 ? std::numbers::pi - b : b;
  return y < 0 ? -c : c;
}

/// 2D cross product (z of the 3D cross product): > 0 when b is counter-clockwise of a.
inline double cross2(const dvec2& a, const dvec2& b) {
  return a.x * b.y - a.y * b.x;
}

}  // namespace sm
