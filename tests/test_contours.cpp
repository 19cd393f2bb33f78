// Contours stage: boundary selection on its own, and (with the real particle/strand stages)
// slicing and split detection on fixtures and samples.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>

#include "contours/contours.h"
#include "core/rng.h"

namespace sm {
namespace {

constexpr double kPi = std::numbers::pi;

double signed_area(const std::vector<dvec2>& p, const std::vector<std::uint32_t>& loop) {
  double a = 0;
  for (std::size_t k = 0; k < loop.size(); ++k) a += cross2(p[loop[k]], p[loop[(k + 1) % loop.size()]]);
  return 0.5 * a;
}

bool segments_cross(dvec2 a, dvec2 b, dvec2 c, dvec2 d) {
  const double d1 = cross2(b - a, c - a), d2 = cross2(b - a, d - a);
  const double d3 = cross2(d - c, a - c), d4 = cross2(d - c, b - c);
  return ((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0));
}

/// Simple (no two non-adjacent edges cross), counter-clockwise, no repeated vertex, and every
/// point inside or on it (winding number test).
void expect_valid_loop(const std::vector<dvec2>& p, const std::vector<std::uint32_t>& loop) {
  ASSERT_GE(loop.size(), 3u);
  EXPECT_GT(signed_area(p, loop), 0);
  EXPECT_EQ(std::set<std::uint32_t>(loop.begin(), loop.end()).size(), loop.size());
  const std::size_t m = loop.size();
  for (std::size_t i = 0; i < m; ++i) {
    for (std::size_t j = i + 2; j < m; ++j) {
      if (i == 0 && j == m - 1) continue;
      EXPECT_FALSE(segments_cross(p[loop[i]], p[loop[(i + 1) % m]], p[loop[j]], p[loop[(j + 1) % m]]))
          << "edges " << i << " and " << j << " cross";
    }
  }
  for (std::size_t q = 0; q < p.size(); ++q) {
    // Distance outside the loop: positive when outside all edges' inner half-planes in the
    // winding sense; use the winding number with a small tolerance band.
    double winding = 0;
    bool on_edge = false;
    for (std::size_t k = 0; k < m; ++k) {
      const dvec2 a = p[loop[k]] - p[q], b = p[loop[(k + 1) % m]] - p[q];
      if (glm::length(a) < 1e-9 || std::abs(cross2(a, b)) < 1e-12 * (glm::length(a) * glm::length(b) + 1e-30)) {
        if (glm::dot(a, b) <= 0) on_edge = true;
      }
      winding += std::atan2(cross2(a, b), glm::dot(a, b));
    }
    if (on_edge || std::abs(winding) > kPi) continue;
    // Outside: allowed only by a rounding-level distance (nearly collinear points are treated
    // as lying on the edge).
    double dist = 1e300;
    for (std::size_t k = 0; k < m; ++k) {
      const dvec2 a = p[loop[k]], b = p[loop[(k + 1) % m]];
      const double t = std::clamp(glm::dot(p[q] - a, b - a) / std::max(glm::dot(b - a, b - a), 1e-300), 0.0, 1.0);
      dist = std::min(dist, glm::length(p[q] - (a + t * (b - a))));
    }
    EXPECT_LT(dist, 1e-9) << "point " << q << " outside the loop";
  }
}

TEST(Boundary, CircleWithInteriorPoints) {
  std::vector<dvec2> p;
  for (int k = 0; k < 24; ++k) p.emplace_back(std::cos(2 * kPi * k / 24), std::sin(2 * kPi * k / 24));
  for (int k = 0; k < 30; ++k) p.emplace_back(0.5 * std::cos(k * 1.3), 0.5 * std::sin(k * 0.7));
  bool fallback = true;
  const auto loop = boundary_loop(p, 12.0, &fallback);
  EXPECT_FALSE(fallback);
  EXPECT_EQ(loop.size(), 24u);
  for (auto i : loop) EXPECT_LT(i, 24u);
  expect_valid_loop(p, loop);
}

TEST(Boundary, CollinearAndDuplicatePointsAreDropped) {
  // A square with points along its edges and duplicated corners.
  std::vector<dvec2> p{{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0.5, 0}, {1, 0.5}, {0.5, 1}, {0, 0.5}, {1, 1}, {0.5, 0.5}};
  const auto loop = boundary_loop(p, 12.0);
  EXPECT_EQ(loop.size(), 4u);
  expect_valid_loop(p, loop);
}

TEST(Boundary, NearlyCollinearPointsKeepTheRightSign) {
  // The seed's bug: acos-based angles flipped sign for nearly collinear points and kept
  // points far inside. Points a hair inside a long straight edge must not survive.
  std::vector<dvec2> p{{0, 0}, {10, 0}, {10, 1}, {0, 1}};
  for (int k = 1; k < 100; ++k) p.emplace_back(0.1 * k, 1e-13 * ((k % 3) - 1));
  for (int k = 0; k < 50; ++k) p.emplace_back(0.2 * k, 0.5);
  // As a convex hull (threshold 0) only the corners survive; with the default tolerance the
  // loop may dip to the row of points inside (there is nothing above them), but never zigzags
  // through the points a hair inside the bottom edge.
  const auto hull = boundary_loop(p, 0.0);
  expect_valid_loop(p, hull);
  for (auto i : hull) EXPECT_TRUE(p[i].y <= 0 || p[i].y == 1.0) << i;
  const auto loop = boundary_loop(p, 12.0);
  expect_valid_loop(p, loop);
  for (auto i : loop) EXPECT_TRUE(p[i].y <= 0 || p[i].y > 0.4) << i;
}

TEST(Boundary, UnionOfTwoBundlesFollowsTheWaist) {
  // Two touching discs of points: the loop is valid and dips into the waist (a concave loop,
  // not the convex hull).
  std::vector<dvec2> p;
  for (int side : {-1, 1}) {
    for (int r = 1; r <= 4; ++r) {
      const int n = 6 * r;
      for (int k = 0; k < n; ++k) {
        const double a = 2 * kPi * k / n;
        p.emplace_back(side * 1.0 + 0.25 * r * std::cos(a), 0.25 * r * std::sin(a));
      }
    }
  }
  bool fallback = true;
  const auto loop = boundary_loop(p, 60.0, &fallback);
  EXPECT_FALSE(fallback);  // star-shaped around the centroid: the walk's loop
  expect_valid_loop(p, loop);
  double min_abs_y_near_waist = 1e9;
  for (auto i : loop) {
    if (std::abs(p[i].x) < 0.3) min_abs_y_near_waist = std::min(min_abs_y_near_waist, std::abs(p[i].y));
  }
  EXPECT_LT(min_abs_y_near_waist, 0.95);  // the convex hull would stay at |y| = 1 there
}

double loop_area(const std::vector<dvec2>& p, const std::vector<std::uint32_t>& loop) {
  double a = 0;
  for (std::size_t k = 0; k < loop.size(); ++k) a += cross2(p[loop[k]], p[loop[(k + 1) % loop.size()]]);
  return 0.5 * a;
}

TEST(Boundary, NotStarShapedFallsBackToTheConcaveOutline) {
  // Evenly spread points (a jittered grid) in a thick ring arc, a "C": its centroid lies in
  // the hole, so no loop around every point is star-shaped around it, and the angular walk
  // would bridge the opening. The fallback follows the C instead, like the strands do.
  Rng rng(3);
  std::vector<dvec2> p;
  const double h = 0.06;
  for (double x = -1; x <= 1; x += h) {
    for (double y = -1; y <= 1; y += h) {
      const dvec2 q = dvec2(x, y) + 0.2 * h * dvec2(rng.uniform(-1, 1), rng.uniform(-1, 1));
      const double r = glm::length(q), a = std::atan2(q.y, q.x);
      if (r > 0.7 && r < 1 && std::abs(a) > 0.2 * kPi) p.push_back(q);
    }
  }
  bool fallback = false;
  const auto loop = boundary_loop(p, 12.0, &fallback);
  EXPECT_TRUE(fallback);
  expect_valid_loop(p, loop);
  const double c_area = 0.5 * (1.0 - 0.49) * 1.6 * kPi;  // the annulus sector: 1.28
  EXPECT_NEAR(loop_area(p, loop), c_area, 0.15 * c_area);
  // With the fallback off, the walk's star-shaped loop bridges the opening and covers the
  // hole (area above 2.5).
  const auto walked = boundary_loop(p, 12.0, nullptr, 0.0);
  expect_valid_loop(p, walked);
  EXPECT_GT(loop_area(p, walked), 2.5);
}

TEST(Boundary, SeparateBundlesStayBridged) {
  // Two bundles a gap apart whose centroid lies between them (a fused slice just below a
  // split): not star-shaped around the centroid, but not one connected shape either. The walk
  // bridges the gap, as branch fusion expects, instead of a thin neck between the two.
  std::vector<dvec2> p;
  for (int side : {-1, 1}) {
    for (int r = 0; r <= 3; ++r) {
      const int n = std::max(1, 6 * r);
      for (int k = 0; k < n; ++k) {
        const double a = 2 * kPi * k / n + 0.1 * side;
        p.emplace_back(side * 1.5 + 0.25 * r * std::cos(a), 0.25 * r * std::sin(a));
      }
    }
  }
  bool fallback = true;
  const auto loop = boundary_loop(p, 12.0, &fallback);
  EXPECT_FALSE(fallback);
  expect_valid_loop(p, loop);
  EXPECT_GT(loop_area(p, loop), 2 * 1.5 * 2 * 0.7);  // spans the gap at about full height
}

TEST(Boundary, ConcaveHullOfRandomShapesIsOneSimpleLoop) {
  // Evenly spread points (a jittered grid, like relaxed particles) in an L, a ring and two
  // separate discs: always one simple CCW loop around every point, never larger than the
  // convex hull, and close to the shape's own area (for the ring, of its outer circle).
  Rng rng(5);
  const double h = 0.08;
  for (int shape = 0; shape < 3; ++shape) {
    for (int trial = 0; trial < 10; ++trial) {
      std::vector<dvec2> p;
      for (double x = -1; x <= 1; x += h) {
        for (double y = -1; y <= 1; y += h) {
          const dvec2 q = dvec2(x, y) + 0.2 * h * dvec2(rng.uniform(-1, 1), rng.uniform(-1, 1));
          const bool in = shape == 0   ? (q.x < -0.4 || q.y < -0.4)
                          : shape == 1 ? (glm::length(q) < 1 && glm::length(q) > 0.6)
                                       : (glm::length(q - dvec2(0.5, 0)) < 0.4 || glm::length(q + dvec2(0.5, 0)) < 0.4);
          if (in) p.push_back(q);
        }
      }
      SCOPED_TRACE(shape * 100 + trial);
      const auto loop = concave_hull(p, 3.0);
      ASSERT_GE(loop.size(), 3u);
      expect_valid_loop(p, loop);
      const double area = loop_area(p, loop), hull = loop_area(p, boundary_loop(p, 0.0, nullptr, 0.0));
      EXPECT_GT(area, 0);
      EXPECT_LE(area, hull * (1 + 1e-12));
      if (shape == 0) {
        EXPECT_NEAR(area, 4 - 1.4 * 1.4, 0.15);  // the L (hull: about 3)
      } else if (shape == 1) {
        EXPECT_NEAR(area, kPi, 0.3);  // the ring: its outer circle (holes are not carved)
      }
    }
  }
  EXPECT_TRUE(concave_hull({{0, 0}, {1, 1}, {2, 2}}, 3.0).empty());
  EXPECT_TRUE(concave_hull({{0, 0}, {1, 1}}, 3.0).empty());
}

TEST(Boundary, RandomCloudsGiveValidLoops) {
  Rng rng(11);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<dvec2> p;
    const int n = 3 + int(rng.below(200));
    for (int k = 0; k < n; ++k) {
      const double r = std::sqrt(rng.uniform()), a = rng.uniform(0, 2 * kPi);
      p.emplace_back(r * std::cos(a) * (trial % 2 ? 3.0 : 1.0), r * std::sin(a));
    }
    SCOPED_TRACE(trial);
    expect_valid_loop(p, boundary_loop(p, double(trial % 40)));
  }
}

TEST(Boundary, DegenerateInputs) {
  EXPECT_EQ(boundary_loop({}, 10).size(), 0u);
  EXPECT_EQ(boundary_loop({{0, 0}, {1, 1}}, 10).size(), 2u);
  // All collinear: no valid loop, fewer than 3 vertices (the caller widens it).
  const auto line = boundary_loop({{0, 0}, {1, 1}, {2, 2}, {3, 3}}, 10);
  EXPECT_LT(line.size(), 3u);
}

}  // namespace
}  // namespace sm
