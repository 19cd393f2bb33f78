// Meshing stage: strips and branch fusion on loops built in code.

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>

#include "meshing/fold_repair.h"
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
        const auto in_loop = [&](const std::vector<std::uint32_t>& l) {
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

TEST(FoldRepair, StopsAtItsBudgetOfTests) {
  // A sphere with one vertex dragged across its neighbour w, as far beyond w as it was
  // before it: its fan folds over the triangles around w. The repair untangles it; held to a
  // budget of a few triangle tests it stops (out_of_tests), the mesh still closed (it only
  // flips, moves, collapses and refills).
  Mesh folded = test::icosphere(2);
  const std::uint32_t w = folded.triangles[0][1], v = folded.triangles[0][0];
  folded.positions[v] = 2.0 * folded.positions[w] - folded.positions[v];
  auto closed = [](const Mesh& m) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> e;
    for (const auto& t : m.triangles) {
      if (t[0] == t[1] && t[1] == t[2]) continue;  // removed by a collapse or refill
      for (int k = 0; k < 3; ++k) ++e[{t[std::size_t(k)], t[std::size_t((k + 1) % 3)]}];
    }
    for (const auto& [edge, n] : e) {
      if (n != 1 || !e.count({edge.second, edge.first})) return false;
    }
    return true;
  };
  const std::vector<std::uint8_t> suspect(folded.triangles.size(), 1);
  const std::vector<double> max_move(folded.positions.size(), 0.3);
  Mesh full = folded;
  FoldRepairUndo undo;
  const FoldRepairStats done = repair_folds(full, suspect, max_move, {}, &undo);
  // The undo log takes the mesh back to where it was, and a second swap redoes the repair.
  const Mesh repaired = full;
  undo.swap_with(full);
  EXPECT_EQ(full.positions, folded.positions);
  EXPECT_EQ(full.triangles, folded.triangles);
  undo.swap_with(full);
  EXPECT_EQ(full.positions, repaired.positions);
  EXPECT_EQ(full.triangles, repaired.triangles);
  EXPECT_GT(done.found, 0u);
  EXPECT_FALSE(done.out_of_tests);
  EXPECT_GT(done.flips + done.moves + done.collapses + done.refills, 0u);
  EXPECT_TRUE(closed(full));
  FoldRepairOptions tight;
  tight.max_tests_per_triangle = 0;
  tight.min_tests = 10;
  Mesh held = folded;
  const FoldRepairStats stopped = repair_folds(held, suspect, max_move, tight);
  EXPECT_EQ(stopped.found, done.found);
  EXPECT_TRUE(stopped.out_of_tests);
  EXPECT_LT(stopped.flips + stopped.moves + stopped.collapses + stopped.refills,
            done.flips + done.moves + done.collapses + done.refills);
  EXPECT_TRUE(closed(held));
}

}  // namespace
}  // namespace sm
