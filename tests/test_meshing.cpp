// Meshing stage: strips and branch fusion on loops built in code.

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>

#include "meshcheck/checks.h"
#include "meshing/meshing.h"
#include "mesh_fixtures.h"

namespace sm {
namespace {

constexpr double kPi = std::numbers::pi;

std::vector<std::uint32_t> ring(std::vector<glm::dvec3>& pos, int n, glm::dvec3 c, double r, double z, double phase = 0) {
  std::vector<std::uint32_t> ids;
  for (int k = 0; k < n; ++k) {
    const double a = phase + 2 * kPi * k / n;
    ids.push_back(static_cast<std::uint32_t>(pos.size()));
    pos.emplace_back(c.x + r * std::cos(a), c.y + r * std::sin(a), z);
  }
  return ids;
}

/// Directed edge counts: every interior edge once in each direction.
std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed_edges(const std::vector<Mesh::Triangle>& tris) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> e;
  for (const auto& t : tris)
    for (int k = 0; k < 3; ++k) ++e[{t[std::size_t(k)], t[std::size_t((k + 1) % 3)]}];
  return e;
}

TEST(Stitch, BandBetweenTwoRings) {
  std::vector<glm::dvec3> pos;
  const auto lower = ring(pos, 12, {0, 0, 0}, 1.0, 0.0);
  const auto upper = ring(pos, 7, {0, 0, 0}, 0.8, 0.5, 0.3);
  std::vector<Mesh::Triangle> tris;
  stitch_loops(lower, upper, pos, tris);
  EXPECT_EQ(tris.size(), 19u);
  const auto e = directed_edges(tris);
  for (const auto& [edge, count] : e) {
    EXPECT_EQ(count, 1);
    const bool lower_edge = edge.first < 12 && edge.second < 12;
    const bool upper_edge = edge.first >= 12 && edge.second >= 12;
    // Loop edges appear once (the band's boundary), diagonals in both directions.
    if (!lower_edge && !upper_edge) {
      EXPECT_EQ(e.count({edge.second, edge.first}), 1u);
    }
  }
  // Outward: every triangle's normal points away from the axis.
  for (const auto& t : tris) {
    const glm::dvec3 n = glm::cross(pos[t[1]] - pos[t[0]], pos[t[2]] - pos[t[0]]);
    const glm::dvec3 c = (pos[t[0]] + pos[t[1]] + pos[t[2]]) / 3.0;
    EXPECT_GT(glm::dot(n, glm::dvec3(c.x, c.y, 0)), 0);
  }
}

TEST(Stitch, NeverFansOneLoopRoundOneVertexOfTheOther) {
  // A small loop sitting next to one vertex of a large one (bug 72): every step from there is
  // shortest round that vertex, and a strip that fans the whole small loop round it uses the
  // edge from it to the small loop's start four times. The strip must still be a band: each
  // loop edge once, each other edge once in each direction, m + n triangles.
  for (int at : {0, 3, 11}) {
    for (bool small_upper : {true, false}) {
      std::vector<glm::dvec3> pos;
      const double a = 2 * kPi * at / 12;
      const glm::dvec3 near(0.95 * std::cos(a), 0.95 * std::sin(a), 0);
      const auto big = ring(pos, 12, {0, 0, 0}, 1.0, small_upper ? 0.0 : 0.2);
      const auto small = ring(pos, 6, near, 0.03, small_upper ? 0.2 : 0.0);
      const auto& lower = small_upper ? big : small;
      const auto& upper = small_upper ? small : big;
      std::vector<Mesh::Triangle> tris;
      stitch_loops(lower, upper, pos, tris);
      SCOPED_TRACE("at " + std::to_string(at) + (small_upper ? " small upper" : " small lower"));
      EXPECT_EQ(tris.size(), 18u);
      const auto e = directed_edges(tris);
      auto in_loop = [](const std::vector<std::uint32_t>& l, std::uint32_t u, std::uint32_t v) {
        for (std::size_t k = 0; k < l.size(); ++k) {
          if (l[k] == u && l[(k + 1) % l.size()] == v) return true;
        }
        return false;
      };
      for (const auto& [edge, count] : e) {
        EXPECT_EQ(count, 1) << edge.first << "->" << edge.second;
        const bool boundary = in_loop(lower, edge.first, edge.second) || in_loop(upper, edge.second, edge.first);
        EXPECT_EQ(e.count({edge.second, edge.first}), boundary ? 0u : 1u) << edge.first << "->" << edge.second;
      }
    }
  }
}

TEST(Fuse, PantsAreManifoldForTinyAndLargeLoops) {
  // Tiny loops are where a naive strip connects one lower vertex to both visits of a crotch
  // vertex; the pants must use every loop edge once and every new edge twice.
  for (int lower_n : {3, 4, 5, 8, 40}) {
    for (int upper_n : {3, 4, 12}) {
      std::vector<glm::dvec3> pos;
      const auto lower = ring(pos, lower_n, {0, 0, 0}, 1.0, 0.0);
      const auto a = ring(pos, upper_n, {-0.55, 0, 0}, 0.45, 0.3, 0.2);
      const auto b = ring(pos, upper_n, {0.6, 0.05, 0}, 0.35, 0.35, 1.0);
      std::vector<Mesh::Triangle> tris;
      fuse_loops(lower, a, b, pos, {0, 0, 1}, tris);
      const auto e = directed_edges(tris);
      SCOPED_TRACE("lower " + std::to_string(lower_n) + " upper " + std::to_string(upper_n));
      EXPECT_EQ(tris.size(), std::size_t(lower_n + 2 * upper_n + 2));
      for (const auto& [edge, count] : e) {
        EXPECT_EQ(count, 1);
        const auto in_loop = [&, edge = edge](const std::vector<std::uint32_t>& l) {
          for (std::size_t k = 0; k < l.size(); ++k) {
            if (l[k] == edge.first && l[(k + 1) % l.size()] == edge.second) return true;
          }
          return false;
        };
        // Lower loop edges are traversed forwards, upper loop edges backwards (they bound the
        // pants from below and above); every other edge appears in both directions.
        const bool boundary = in_loop(lower) || e.count({edge.second, edge.first}) == 0;
        if (!boundary) {
          EXPECT_EQ(e.count({edge.second, edge.first}), 1u);
        }
      }
      for (std::size_t k = 0; k < a.size(); ++k) EXPECT_EQ(e.count({a[(k + 1) % a.size()], a[k]}), 1u);
      for (std::size_t k = 0; k < b.size(); ++k) EXPECT_EQ(e.count({b[(k + 1) % b.size()], b[k]}), 1u);
      for (std::size_t k = 0; k < lower.size(); ++k) EXPECT_EQ(e.count({lower[k], lower[(k + 1) % lower.size()]}), 1u);
    }
  }
}

}  // namespace
}  // namespace sm
