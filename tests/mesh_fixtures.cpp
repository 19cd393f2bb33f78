#include "tests/mesh_fixtures.h"

#include <cmath>
#include <map>
#include <numbers>
#include <utility>

#include "core/math.h"

namespace sm::test {

namespace {

using glm::dvec3;

// Reverses t when its normal points towards `inside` (used to orient generated shells).
Mesh::Triangle outward(const Mesh& m, Mesh::Triangle t, const dvec3& inside) {
  const dvec3 n = glm::cross(m.positions[t[1]] - m.positions[t[0]], m.positions[t[2]] - m.positions[t[0]]);
  const dvec3 c = (m.positions[t[0]] + m.positions[t[1]] + m.positions[t[2]]) / 3.0;
  if (glm::dot(n, c - inside) < 0) std::swap(t[1], t[2]);
  return t;
}

}  // namespace

Mesh icosphere(int subdivisions, double radius, dvec3 centre) {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<dvec3> p = {{-1, g, 0},  {1, g, 0},  {-1, -g, 0}, {1, -g, 0}, {0, -1, g},  {0, 1, g},
                          {0, -1, -g}, {0, 1, -g}, {g, 0, -1},  {g, 0, 1},  {-g, 0, -1}, {-g, 0, 1}};
  std::vector<Mesh::Triangle> f = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                                   {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                                   {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (auto& q : p) q = glm::normalize(q);
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      p.push_back(glm::normalize(p[a] + p[b]));
      const auto id = static_cast<std::uint32_t>(p.size() - 1);
      mid.emplace(key, id);
      return id;
    };
    std::vector<Mesh::Triangle> next;
    for (const auto& t : f) {
      const std::uint32_t ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
      next.push_back({t[0], ab, ca});
      next.push_back({t[1], bc, ab});
      next.push_back({t[2], ca, bc});
      next.push_back({ab, bc, ca});
    }
    f = std::move(next);
  }
  Mesh m;
  for (const auto& q : p) m.positions.push_back(centre + radius * q);
  for (const auto& t : f) m.triangles.push_back(outward(m, t, centre));
  return m;
}

Mesh capped_tube(dvec3 a, dvec3 b, double radius, int segments, int rings, bool uvs, std::uint32_t upper_branch) {
  const dvec3 axis = b - a;
  const double length = glm::length(axis);
  const dvec3 e = axis / length;
  const dvec3 u = any_perpendicular(e);
  const dvec3 v = glm::cross(e, u);
  const auto n = static_cast<std::uint32_t>(segments);
  const auto rows = static_cast<std::uint32_t>(rings + 1);
  Mesh m;
  for (std::uint32_t i = 0; i < rows; ++i) {
    for (std::uint32_t j = 0; j < n; ++j) {
      const double th = 2.0 * std::numbers::pi * j / n;
      m.positions.push_back(a + axis * (double(i) / rings) + radius * (std::cos(th) * u + std::sin(th) * v));
    }
  }
  const std::uint32_t ca = rows * n, cb = ca + 1;
  m.positions.push_back(a);
  m.positions.push_back(b);
  auto id = [&](std::uint32_t i, std::uint32_t j) { return i * n + j % n; };
  auto side_uv = [&](std::uint32_t i, std::uint32_t j) {
    return glm::vec2(float(j) / float(n), float(length * i / rings));
  };
  auto cap_uv = [&](std::uint32_t j) {
    const double th = 2.0 * std::numbers::pi * j / n;
    return glm::vec2(float(0.5 + 0.5 * std::cos(th)), float(0.5 + 0.5 * std::sin(th)));
  };
  auto branch = [&](std::uint32_t row) { return row < rows / 2 ? 0u : upper_branch; };
  for (std::uint32_t i = 0; i + 1 < rows; ++i) {
    for (std::uint32_t j = 0; j < n; ++j) {
      m.triangles.push_back({id(i, j), id(i, j + 1), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i + 1, j)});
      m.corner_uvs.push_back({side_uv(i, j), side_uv(i, j + 1), side_uv(i + 1, j + 1)});
      m.corner_uvs.push_back({side_uv(i, j), side_uv(i + 1, j + 1), side_uv(i + 1, j)});
      m.triangle_branch.push_back(branch(i));
      m.triangle_branch.push_back(branch(i));
    }
  }
  for (std::uint32_t j = 0; j < n; ++j) {
    m.triangles.push_back({ca, id(0, j + 1), id(0, j)});
    m.corner_uvs.push_back({glm::vec2(0.5f), cap_uv(j + 1), cap_uv(j)});
    m.triangle_branch.push_back(0);
    m.triangles.push_back({cb, id(rows - 1, j), id(rows - 1, j + 1)});
    m.corner_uvs.push_back({glm::vec2(0.5f), cap_uv(j), cap_uv(j + 1)});
    m.triangle_branch.push_back(upper_branch);
  }
  if (!uvs) m.corner_uvs.clear();
  return m;
}

Mesh torus(double major, double minor, int nu, int nv) {
  Mesh m;
  const auto a = static_cast<std::uint32_t>(nu), b = static_cast<std::uint32_t>(nv);
  for (std::uint32_t i = 0; i < a; ++i) {
    const double th = 2.0 * std::numbers::pi * i / a;
    for (std::uint32_t j = 0; j < b; ++j) {
      const double ph = 2.0 * std::numbers::pi * j / b;
      m.positions.push_back({(major + minor * std::cos(ph)) * std::cos(th),
                             (major + minor * std::cos(ph)) * std::sin(th), minor * std::sin(ph)});
    }
  }
  auto id = [&](std::uint32_t i, std::uint32_t j) { return (i % a) * b + j % b; };
  for (std::uint32_t i = 0; i < a; ++i) {
    const double th = 2.0 * std::numbers::pi * (i + 0.5) / a;
    const dvec3 core(major * std::cos(th), major * std::sin(th), 0);
    for (std::uint32_t j = 0; j < b; ++j) {
      m.triangles.push_back(outward(m, {id(i, j), id(i + 1, j), id(i + 1, j + 1)}, core));
      m.triangles.push_back(outward(m, {id(i, j), id(i + 1, j + 1), id(i, j + 1)}, core));
    }
  }
  return m;
}

Mesh box(dvec3 lo, dvec3 hi) {
  Mesh m;
  for (int i = 0; i < 8; ++i) m.positions.push_back({i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z});
  const dvec3 centre = 0.5 * (lo + hi);
  // Each face: the four corners with bit `axis` equal to `side`, in quad order.
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      const int bit = 1 << axis, o1 = 1 << ((axis + 1) % 3), o2 = 1 << ((axis + 2) % 3);
      const int base = side ? bit : 0;
      const auto q0 = std::uint32_t(base), q1 = std::uint32_t(base | o1), q2 = std::uint32_t(base | o1 | o2),
                 q3 = std::uint32_t(base | o2);
      m.triangles.push_back(outward(m, {q0, q1, q2}, centre));
      m.triangles.push_back(outward(m, {q0, q2, q3}, centre));
    }
  }
  return m;
}

Mesh wedge(double apex_degrees) {
  const double w = std::tan(0.5 * apex_degrees * std::numbers::pi / 180.0);
  Mesh m;
  m.positions = {{-w, 0, 0}, {w, 0, 0}, {0, 1, 0}, {-w, 0, 1}, {w, 0, 1}, {0, 1, 1}};
  m.triangles = {{0, 2, 1}, {3, 4, 5}, {0, 1, 4}, {0, 4, 3}, {1, 2, 5}, {1, 5, 4}, {2, 0, 3}, {2, 3, 5}};
  return m;
}

Mesh merged(const Mesh& a, const Mesh& b) {
  Mesh m = a;
  const auto off = static_cast<std::uint32_t>(a.positions.size());
  m.positions.insert(m.positions.end(), b.positions.begin(), b.positions.end());
  for (auto t : b.triangles) m.triangles.push_back({t[0] + off, t[1] + off, t[2] + off});
  auto both = [&](auto& dst, const auto& src, std::size_t na, std::size_t nb) {
    if (dst.size() == na && src.size() == nb && na > 0 && nb > 0) {
      dst.insert(dst.end(), src.begin(), src.end());
    } else {
      dst.clear();
    }
  };
  both(m.normals, b.normals, a.positions.size(), b.positions.size());
  both(m.corner_uvs, b.corner_uvs, a.triangles.size(), b.triangles.size());
  both(m.corner_normals, b.corner_normals, a.triangles.size(), b.triangles.size());
  both(m.triangle_branch, b.triangle_branch, a.triangles.size(), b.triangles.size());
  m.vertex_strand.clear();
  m.vertex_node.clear();
  return m;
}

Mesh translated(Mesh m, dvec3 offset) {
  for (auto& p : m.positions) p += offset;
  return m;
}

Mesh two_spheres() {
  return merged(icosphere(1, 1.0, {-2, 0, 0}), icosphere(1, 1.0, {2, 0, 0}));
}

Mesh box_with_flipped_triangle() {
  Mesh m = box();
  std::swap(m.triangles[0][1], m.triangles[0][2]);
  return m;
}

Mesh box_with_missing_triangle() {
  Mesh m = box();
  m.triangles.pop_back();
  return m;
}

Mesh interpenetrating_boxes() {
  return merged(box(dvec3(0), dvec3(1)), box(dvec3(0.5), dvec3(1.5)));
}

Mesh box_with_degenerate_triangle() {
  // Triangle (a, b, c) becomes (a, m, c) and (m, b, c) with m the midpoint of ab; the
  // neighbour across ab keeps edge ab, closed by the zero-area triangle (a, b, m).
  Mesh m = box();
  const Mesh::Triangle t = m.triangles[0];
  const std::uint32_t a = t[0], b = t[1], c = t[2];
  m.positions.push_back(0.5 * (m.positions[a] + m.positions[b]));
  const auto mid = static_cast<std::uint32_t>(m.positions.size() - 1);
  m.triangles[0] = {a, mid, c};
  m.triangles.push_back({mid, b, c});
  m.triangles.push_back({a, b, mid});
  return m;
}

Mesh box_with_fin() {
  // The edge from vertex 0 (0,0,0) to vertex 1 (1,0,0) gets a third triangle pointing away
  // from the box (towards -y, -z), so nothing crosses.
  Mesh m = box();
  m.positions.push_back({0.5, -1, -1});
  m.triangles.push_back({0, 1, 8});
  return m;
}

Mesh tetrahedra_sharing_vertex() {
  auto tetra = [](dvec3 o, double s) {
    Mesh m;
    m.positions = {o, o + dvec3(s, 0, 0), o + dvec3(0, s, 0), o + dvec3(0, 0, s)};
    const dvec3 c = o + dvec3(s / 4);
    for (const Mesh::Triangle t : {Mesh::Triangle{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}})
      m.triangles.push_back(outward(m, t, c));
    return m;
  };
  // Mirror images through the origin, touching only there.
  Mesh a = tetra(dvec3(0), 1.0), b = tetra(dvec3(0), -1.0);
  Mesh m = merged(a, b);
  // Weld b's vertex 0 (index 4) onto a's vertex 0 (index 4 stays as an unused vertex).
  for (auto& t : m.triangles) {
    for (auto& v : t) {
      if (v == 4) v = 0;
    }
  }
  return m;
}

}  // namespace sm::test
