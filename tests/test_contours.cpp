// Contours stage: boundary selection on its own, and compute_contours called directly on
// skeletons built in code (tests/fixtures.h), after the real particle and strand stages.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>

#include "contours/contours.h"
#include "core/rng.h"
#include "tests/fixtures.h"
#include "tests/stage_fixtures.h"

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
      const double jy = rng.uniform(-1, 1), jx = rng.uniform(-1, 1);  // sequenced: the same points from any compiler
      const dvec2 q = dvec2(x, y) + 0.2 * h * dvec2(jx, jy);
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
          const double jy = rng.uniform(-1, 1), jx = rng.uniform(-1, 1);  // sequenced: the same points from any compiler
      const dvec2 q = dvec2(x, y) + 0.2 * h * dvec2(jx, jy);
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

// compute_contours on small skeletons built in code.

/// Signed area of loop l in its slice plane (positive: counter-clockwise seen from the tip
/// side, i.e. looking down the frame's tangent from above).
double loop_area(const ContourSet& c, std::uint32_t l) {
  dvec3 centroid(0);
  for (std::uint32_t v = c.loop_begin[l]; v < c.loop_begin[l + 1]; ++v) centroid += c.point[v];
  centroid /= double(c.loop_size(l));
  double a = 0;
  for (std::uint32_t v = c.loop_begin[l]; v < c.loop_begin[l + 1]; ++v) {
    const std::uint32_t w = v + 1 < c.loop_begin[l + 1] ? v + 1 : c.loop_begin[l];
    a += cross2(c.loop_frame[l].to_local(c.point[v] - centroid), c.loop_frame[l].to_local(c.point[w] - centroid));
  }
  return 0.5 * a;
}

/// What holds for the contours of any tree: consistent arrays, every loop a counter-clockwise
/// polygon of distinct strands, every loop in exactly one tube, tubes linked by their
/// junctions, a tip loop at the end of every tube that does not end in a junction, and the
/// loops of one bundle (plain and tip loops) within their branch's round section. (A split
/// loop may still hold the rest of a fused section: stacked forks split one by one.)
void expect_well_formed(const test::UpToContours& u) {
  const Skeleton& s = u.skeleton;
  const ContourSet& c = u.contours;
  const std::size_t L = c.loop_count();
  ASSERT_GT(L, 0u);
  ASSERT_EQ(c.loop_begin.size(), L + 1);
  EXPECT_EQ(c.loop_begin.front(), 0u);
  ASSERT_EQ(c.loop_begin.back(), c.point.size());
  ASSERT_EQ(c.strand.size(), c.point.size());
  ASSERT_EQ(c.loop_node.size(), L);
  ASSERT_EQ(c.loop_t.size(), L);
  ASSERT_EQ(c.loop_distance.size(), L);
  ASSERT_EQ(c.loop_center.size(), L);
  ASSERT_EQ(c.loop_frame.size(), L);
  ASSERT_EQ(c.loop_radius.size(), L);
  EXPECT_EQ(c.stats.loops, L);
  EXPECT_EQ(c.stats.loop_vertices, c.point.size());

  std::size_t fused = 0;
  for (std::uint32_t l = 0; l < L; ++l) {
    SCOPED_TRACE("loop " + std::to_string(l));
    ASSERT_GE(c.loop_size(l), 3u);
    EXPECT_GT(loop_area(c, l), 0) << "not counter-clockwise seen from the tip side";
    std::set<std::uint32_t> strands;
    for (std::uint32_t v = c.loop_begin[l]; v < c.loop_begin[l + 1]; ++v) {
      ASSERT_TRUE(c.strand[v].valid());
      strands.insert(c.strand[v].value);
    }
    EXPECT_EQ(strands.size(), c.loop_size(l)) << "a strand twice in one loop";
    EXPECT_GE(c.loop_t[l], 0.0);
    EXPECT_LE(c.loop_t[l], 1.0);
    fused += c.loop_kind[l] == LoopKind::fused ? 1 : 0;
    if (c.loop_kind[l] != LoopKind::plain && c.loop_kind[l] != LoopKind::tip) continue;
    // Strand points lie in their node's particle disk, which reaches a little past the radius.
    for (std::uint32_t v = c.loop_begin[l]; v < c.loop_begin[l + 1]; ++v) {
      EXPECT_LT(glm::length(c.point[v] - c.loop_center[l]), 1.1 * c.loop_radius[l]) << "vertex " << v;
    }
  }
  EXPECT_EQ(fused, c.stats.fused_loops);

  // Tubes: every loop once, bottom to top; each junction ends one tube and starts two.
  ASSERT_EQ(c.tubes.size(), 1 + 2 * c.junctions.size());
  EXPECT_EQ(c.tubes[0].start_junction, UINT32_MAX);
  EXPECT_EQ(c.tubes[0].loops.front(), 0u) << "the root's loop";
  std::vector<int> seen(L, 0);
  std::size_t tip_tubes = 0;
  for (const Tube& t : c.tubes) {
    ASSERT_FALSE(t.loops.empty());
    for (std::size_t k = 0; k < t.loops.size(); ++k) {
      ++seen[t.loops[k]];
      if (k > 0) {
        EXPECT_GT(c.loop_distance[t.loops[k]], c.loop_distance[t.loops[k - 1]]);
      }
    }
    if (t.end_junction == UINT32_MAX) {
      ++tip_tubes;
      const std::uint32_t last = t.loops.back();
      EXPECT_EQ(c.loop_kind[last], LoopKind::tip);
      EXPECT_TRUE(s.is_tip(c.loop_node[last]));
      EXPECT_EQ(c.loop_t[last], 1.0);
    }
  }
  for (std::uint32_t l = 0; l < L; ++l) EXPECT_EQ(seen[l], 1) << "loop " << l << " in " << seen[l] << " tubes";
  std::size_t tips = 0;
  for (std::size_t i = 0; i < s.size(); ++i) tips += s.is_tip(NodeId(i)) ? 1 : 0;
  EXPECT_EQ(tip_tubes, tips);
  for (std::uint32_t ji = 0; ji < c.junctions.size(); ++ji) {
    SCOPED_TRACE("junction " + std::to_string(ji));
    const Junction& j = c.junctions[ji];
    EXPECT_TRUE(s.is_fork(j.fork));
    EXPECT_EQ(c.tubes[j.lower_tube].end_junction, ji);
    EXPECT_EQ(c.tubes[j.lower_tube].loops.back(), j.lower);
    ASSERT_EQ(j.lower_side.size(), c.loop_size(j.lower));
    bool main_side = false, lateral_side = false;
    for (const std::uint8_t side : j.lower_side) {
      EXPECT_LE(side, 2);
      main_side |= side == 0;
      lateral_side |= side == 1;
    }
    EXPECT_TRUE(main_side && lateral_side) << "the lower loop goes around both bundles";
    EXPECT_GT(j.split_distance, 0);
    for (int k = 0; k < 2; ++k) {
      const Tube& up = c.tubes[j.upper_tubes[std::size_t(k)]];
      EXPECT_EQ(up.start_junction, ji);
      EXPECT_EQ(up.loops.front(), j.upper[std::size_t(k)]);
      EXPECT_EQ(c.loop_kind[j.upper[std::size_t(k)]], LoopKind::split);
      EXPECT_GT(c.loop_distance[j.upper[std::size_t(k)]], c.loop_distance[j.lower]);
    }
  }
}

TEST(Contours, RingEdgeSetsTheLoopsAndMatchedSlices) {
  // With a target edge length, loops keep about perimeter / edge of their boundary strands (at
  // least min_ring_vertices) and slices follow at the height of an equilateral triangle on the
  // edge of the round section: distance to the next slice sqrt(3)/2 x 2 pi r / N(r), N(r) =
  // max(min_ring_vertices, ceil(2 pi r / edge)), at least min_slice_step neighbour distances.
  ContourParams p;
  p.ring_edge = 6;
  p.max_slices_per_edge = 0;
  const auto u = test::up_to_contours(test::straight_branch(6), 1, p);
  expect_well_formed(u);
  const ContourSet& c = u.contours;
  const double d = u.particles.neighbour_distance, edge = 6 * d;
  ASSERT_GT(d, 0);
  ASSERT_EQ(c.tubes.size(), 1u);
  std::size_t kept = 0, marks = 0;
  for (std::uint32_t l = 0; l < c.loop_count(); ++l) {
    kept += c.loop_size(l);
    EXPECT_GE(c.loop_size(l), 3u) << "loop " << l;  // fewer than min_ring_vertices where the outline has fewer strands
    // Evenly spaced marks, plus the few vertices of the particles' uneven outline farther than
    // the tolerance from their chord.
    double perimeter = 0;
    for (std::uint32_t k = 0; k < c.loop_size(l); ++k) {
      const std::uint32_t a = c.loop_begin[l] + k, b = c.loop_begin[l] + (k + 1) % c.loop_size(l);
      perimeter += glm::length(c.point[b] - c.point[a]);
    }
    marks += std::max<std::size_t>(p.min_ring_vertices, std::size_t(std::ceil(perimeter / edge)));
  }
  EXPECT_LE(kept, marks + marks / 4) << "kept " << kept << ", marks " << marks;
  for (std::uint32_t l = 1; l + 1 < c.loop_count(); ++l) {
    const double r = c.loop_radius[l - 1], circumference = 2 * std::numbers::pi * r;
    const double n = std::max(double(p.min_ring_vertices), std::ceil(circumference / edge));
    const double step = std::max(std::sqrt(3.0) / 2 * circumference / n, p.min_slice_step * d);
    EXPECT_NEAR(c.loop_distance[l] - c.loop_distance[l - 1], step, 1e-9) << "loop " << l;
  }
  // resolution 2 halves the edge: more vertices, closer slices.
  p.resolution = 2;
  const auto fine = test::up_to_contours(test::straight_branch(6), 1, p);
  EXPECT_GT(fine.contours.loop_count(), c.loop_count());
  EXPECT_GT(fine.contours.point.size(), c.point.size());
}

TEST(Contours, SliceAspectStretchesThinBranchesWithinItsLimit) {
  // Rings finer than ring_edge asks (here every loop: a target of 40 neighbour distances) with
  // one slice per edge wanted: the slices stretch to max_slice_aspect x the loop's shortest
  // edge, no farther; with max_slice_aspect 0 they stay isotropic (more loops).
  ContourParams p;
  p.ring_edge = 40;
  p.max_slices_per_edge = 1;
  const auto u = test::up_to_contours(test::straight_branch(6), 1, p);
  expect_well_formed(u);
  const ContourSet& c = u.contours;
  ASSERT_EQ(c.tubes.size(), 1u);
  std::size_t stretched = 0;
  for (std::uint32_t l = 0; l + 2 < c.loop_count(); ++l) {  // (the tip's loop closes the last gap)
    double shortest = std::numeric_limits<double>::infinity(), perimeter = 0;
    for (std::uint32_t k = 0; k < c.loop_size(l); ++k) {
      const std::uint32_t a = c.loop_begin[l] + k, b = c.loop_begin[l] + (k + 1) % c.loop_size(l);
      shortest = std::min(shortest, glm::length(c.point[b] - c.point[a]));
      perimeter += glm::length(c.point[b] - c.point[a]);
    }
    ASSERT_LT(perimeter / c.loop_size(l), 0.7 * p.ring_edge * u.particles.neighbour_distance) << "loop " << l;
    const double gap = c.loop_distance[l + 1] - c.loop_distance[l];
    EXPECT_LE(gap, p.max_slice_aspect * shortest * (1 + 1e-9)) << "loop " << l;
    stretched += gap > 0.99 * p.max_slice_aspect * shortest;
  }
  EXPECT_GT(stretched, c.loop_count() / 2);
  p.max_slice_aspect = 0;
  const auto even = test::up_to_contours(test::straight_branch(6), 1, p);
  EXPECT_GT(even.contours.loop_count(), c.loop_count() + c.loop_count() / 2);
}

TEST(Contours, StraightBranchIsOneTubeOfEvenSlices) {
  // The legacy rings (ring_edge 0): edges of 0.4 m at radii 0.1 to 0.05 m: the step (0.4 x
  // radius) would give 5 to 10 slices per edge, capped at max_slices_per_edge; with the root's
  // loop and the tip's, 2 + 5 x cap.
  for (const std::uint32_t cap : {4u, 2u, 1u}) {
    SCOPED_TRACE("max_slices_per_edge " + std::to_string(cap));
    ContourParams p;
    p.ring_edge = 0;
    p.max_slices_per_edge = cap;
    const auto u = test::up_to_contours(test::straight_branch(6), 1, p);
    expect_well_formed(u);
    const ContourSet& c = u.contours;
    EXPECT_EQ(c.loop_count(), 2 + 5 * cap);
    ASSERT_EQ(c.tubes.size(), 1u);
    EXPECT_EQ(c.junctions.size(), 0u);
    EXPECT_EQ(c.tubes[0].loops.size(), c.loop_count());
    EXPECT_EQ(c.stats.fused_loops, 0u);
    EXPECT_EQ(c.stats.forced_splits, 0u);
    EXPECT_EQ(c.stats.boundary_fallbacks, 0u);
    for (std::uint32_t n = 1; n < 6; ++n) {
      const auto on_edge = std::count(c.loop_node.begin(), c.loop_node.end(), NodeId(n));
      EXPECT_EQ(on_edge, n == 5 ? cap + 1 : cap) << "edge of node " << n;  // node 5 also has the tip loop
    }
    // Evenly spaced along the branch, the root's loop at 0 and the tip's at 2 m.
    EXPECT_EQ(c.loop_distance.front(), 0.0);
    EXPECT_NEAR(c.loop_distance.back(), 2.0, 1e-12);
    for (std::uint32_t l = 2; l + 1 < c.loop_count(); ++l) {
      EXPECT_NEAR(c.loop_distance[l] - c.loop_distance[l - 1], 0.4 / cap, 1e-9) << "loop " << l;
    }
    // Every loop is a section of the vertical branch: its plane horizontal, its centre on the axis.
    for (std::uint32_t l = 0; l < c.loop_count(); ++l) {
      EXPECT_NEAR(c.loop_frame[l].tangent.z, 1.0, 1e-12);
      EXPECT_NEAR(glm::length(dvec2(c.loop_center[l])), 0.0, 1e-12);
      for (std::uint32_t v = c.loop_begin[l]; v < c.loop_begin[l + 1]; ++v) {
        EXPECT_NEAR(c.point[v].z, c.loop_center[l].z, 1e-12);
      }
    }
  }
}

TEST(Contours, YForkSplitsIntoTwoTubesAboveItsFork) {
  const auto u = test::up_to_contours(test::y_fork(35.0));
  expect_well_formed(u);
  const Skeleton& s = u.skeleton;
  const ContourSet& c = u.contours;
  ASSERT_EQ(c.junctions.size(), 1u);
  ASSERT_EQ(c.tubes.size(), 3u);
  const Junction& j = c.junctions[0];
  // The fork is input node 2 (a collar node may be inserted at the lateral's base).
  EXPECT_EQ(s.source_id[j.fork.idx()], 2);
  EXPECT_FALSE(j.forced);
  EXPECT_EQ(c.stats.forced_splits, 0u);
  EXPECT_EQ(c.stats.nested_splits, 0u);
  EXPECT_EQ(c.loop_kind[j.lower], LoopKind::fused);
  EXPECT_GE(c.stats.fused_loops, 1u);
  // The bundles part within the children's first edges (0.5 m long).
  EXPECT_LT(j.split_distance, 0.5);
  // The trunk's tube ends in the junction; the children's tubes end at the two tips.
  EXPECT_EQ(c.tubes[0].end_junction, 0u);
  EXPECT_EQ(j.lower_tube, 0u);
  for (int k = 0; k < 2; ++k) {
    const Tube& t = c.tubes[j.upper_tubes[std::size_t(k)]];
    EXPECT_EQ(t.end_junction, UINT32_MAX);
    EXPECT_EQ(s.source_id[c.loop_node[t.loops.back()].idx()], k == 0 ? 4 : 6);
  }
}

TEST(Contours, SixChildrenGiveFiveJunctionsAndSixTips) {
  // The hub is binarized into a chain of five forks a tiny step apart; each splits once.
  const auto u = test::up_to_contours(test::six_children());
  expect_well_formed(u);
  EXPECT_EQ(u.contours.junctions.size(), 5u);
  EXPECT_EQ(u.contours.tubes.size(), 11u);
}

TEST(Contours, SameInputSameContours) {
  const auto a = test::up_to_contours(test::trifurcation()), b = test::up_to_contours(test::trifurcation());
  expect_well_formed(a);
  EXPECT_EQ(a.contours.loop_begin, b.contours.loop_begin);
  EXPECT_EQ(a.contours.point, b.contours.point);
  EXPECT_EQ(a.contours.strand, b.contours.strand);
  EXPECT_EQ(a.contours.junctions.size(), 2u);
}

}  // namespace
}  // namespace sm
