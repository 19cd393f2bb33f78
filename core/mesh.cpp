#include "core/mesh.h"

#include <cmath>

namespace sm {

std::vector<glm::dvec3> angle_weighted_normals(const Mesh& mesh) {
  std::vector<glm::dvec3> n(mesh.positions.size(), glm::dvec3(0));
  for (const auto& t : mesh.triangles) {
    const glm::dvec3 p[3] = {mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]};
    const glm::dvec3 fn = glm::cross(p[1] - p[0], p[2] - p[0]);
    const double len = glm::length(fn);
    if (!(len > 0)) continue;
    const glm::dvec3 unit = fn / len;
    for (int k = 0; k < 3; ++k) {
      const glm::dvec3 a = p[(k + 1) % 3] - p[k];
      const glm::dvec3 b = p[(k + 2) % 3] - p[k];
      const double la = glm::length(a), lb = glm::length(b);
      if (!(la > 0) || !(lb > 0)) continue;
      const double angle = std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
      n[t[k]] += unit * angle;
    }
  }
  for (auto& v : n) {
    const double l = glm::length(v);
    v = l > 0 ? v / l : glm::dvec3(0, 0, 1);
  }
  return n;
}

}  // namespace sm
