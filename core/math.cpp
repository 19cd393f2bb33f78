#include "core/math.h"

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

}  // namespace sm
