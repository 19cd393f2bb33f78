#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#define GLM_ENABLE_EXPERIMENTAL
#include <glm/gtx/quaternion.hpp>

#include "core/errors.h"
#include "core/file_io.h"
#include "skeleton/build.h"
#include "skeleton/frames.h"
#include "grow/random_grower.h"
#include "skeleton/io.h"
#include "skeleton/separate.h"
#include "tests/fixtures.h"

namespace sm {
namespace {

using test::built;

std::size_t count_forks(const Skeleton& s) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < s.size(); ++i) n += s.is_fork(NodeId(i));
  return n;
}
std::size_t count_tips(const Skeleton& s) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < s.size(); ++i) n += s.is_tip(NodeId(i));
  return n;
}

/// Largest twist (radians) between consecutive frames: the angle about the node's tangent
/// between its normal and the parent's normal carried over by the minimal rotation between
/// the two tangents (computed independently of the code under test, with a GLM quaternion).
double max_twist(const Skeleton& s) {
  double worst = 0;
  for (std::size_t i = 1; i < s.size(); ++i) {
    const Frame& f = s.frame[i];
    const Frame& p = s.frame[s.parent[i].idx()];
    if (glm::dot(p.tangent, f.tangent) < -0.999) continue;  // reversal: minimal rotation undefined
    const dvec3 carried = glm::rotation(p.tangent, f.tangent) * p.normal;
    const double a = std::atan2(glm::dot(glm::cross(carried, f.normal), f.tangent), glm::dot(carried, f.normal));
    worst = std::max(worst, std::abs(a));
  }
  return worst;
}

void expect_valid(const Skeleton& s) {
  EXPECT_NO_THROW(validate_binary_skeleton(s));
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto& c = s.children[i];
    if (c[1].valid()) {
      // Main child: carries more, the larger of its subtree's sum of tip radius² and its own
      // radius² (recomputed here). A lateral's own radius is read below the nodes the
      // refinements insert at its base (collars, upturned bases: inserted, one child), which
      // are wider than the lateral they start.
      auto weight = [&](NodeId root) {
        double w = 0;
        std::vector<NodeId> stack{root};
        while (!stack.empty()) {
          const NodeId v = stack.back();
          stack.pop_back();
          if (s.is_tip(v)) w += s.radius[v.idx()] * s.radius[v.idx()];
          for (NodeId k : s.children[v.idx()])
            if (k.valid()) stack.push_back(k);
        }
        NodeId own = root;
        while (s.source_id[own.idx()] < 0 && s.child_count(own) == 1) own = s.children[own.idx()][0];
        return std::max(w, s.radius[own.idx()] * s.radius[own.idx()]);
      };
      EXPECT_GE(weight(c[0]), weight(c[1]) * (1 - 1e-12)) << s.describe(NodeId(i));
    }
  }
}

TEST(Skeleton, StraightBranch) {
  const auto r = build_skeleton(test::straight_branch(6));
  expect_valid(r.skeleton);
  EXPECT_EQ(r.skeleton.size(), 6u);
  EXPECT_EQ(count_tips(r.skeleton), 1u);
  EXPECT_EQ(r.report.warnings.total(), 0u);
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_NEAR(glm::length(r.skeleton.frame[i].tangent - dvec3(0, 0, 1)), 0, 1e-12);
    EXPECT_NEAR(glm::length(r.skeleton.frame[i].normal - dvec3(1, 0, 0)), 0, 1e-12);
  }
}

TEST(Skeleton, YForkMainChildIsThicker) {
  const Skeleton s = built(test::y_fork(), {.collar_ratio = 0});
  expect_valid(s);
  ASSERT_EQ(s.size(), 7u);
  const NodeId fork(2u);
  ASSERT_TRUE(s.is_fork(fork));
  // Input node 3 (radius 0.07 branch, tip 0.06) is thicker than node 5 (tip 0.045).
  EXPECT_EQ(s.source_id[s.children[2][0].idx()], 3);
  EXPECT_EQ(s.source_id[s.children[2][1].idx()], 5);
  // Depth-first main-first numbering: the main chain is contiguous.
  EXPECT_EQ(s.children[2][0], NodeId(3u));
}

TEST(Skeleton, MainChildTieBrokenByInputOrder) {
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.1);
  raw.add(1, 0, dvec3(0, 0, 1), 0.1);
  raw.add(7, 1, dvec3(0.5, 0, 1.5), 0.05);
  raw.add(3, 1, dvec3(-0.5, 0, 1.5), 0.05);
  const Skeleton s = built(raw);
  EXPECT_EQ(s.source_id[s.children[1][0].idx()], 7);  // first in input order wins the tie
}

TEST(Skeleton, PrunedStubIsNotTheMainChild) {
  // A bare stub (r 0.017, its own only tip) beside the branch's continuation (r 0.022), which
  // runs on and ends in two twigs (r 0.003): the twigs' radius² sum is far below the stub's,
  // but the continuation itself is thicker. It is the main child, in a whorl's chain too (as
  // at sapling_small_pine's input node 40, where the stub being main folded the crotch).
  for (const bool whorl : {false, true}) {
    SCOPED_TRACE(whorl ? "whorl" : "fork");
    RawSkeleton raw;
    raw.add(0, -1, dvec3(0), 0.026);
    raw.add(1, 0, dvec3(0, 0, 0.3), 0.026);
    raw.add(2, 1, dvec3(0.1, 0, 0.35), 0.017);  // the stub, 11 cm
    raw.add(3, 1, dvec3(0, 0, 0.6), 0.022);     // the continuation
    raw.add(4, 3, dvec3(0.1, 0, 0.8), 0.003);
    raw.add(5, 3, dvec3(-0.1, 0, 0.8), 0.003);
    if (whorl) raw.add(6, 1, dvec3(-0.1, 0.05, 0.35), 0.012);  // a third child: a whorl
    const Skeleton s = built(raw, {.collar_ratio = 0, .max_lateral_angle = 0});
    expect_valid(s);
    // From node 1 along the main children to the first input node: the continuation.
    NodeId n = s.children[1][0];
    while (s.source_id[n.idx()] < 0) n = s.children[n.idx()][0];
    EXPECT_EQ(s.source_id[n.idx()], 3);
  }
}

TEST(Skeleton, TrifurcationIsBinarized) {
  const auto r = build_skeleton(test::trifurcation(), {.collar_ratio = 0});
  expect_valid(r.skeleton);
  EXPECT_EQ(r.report.binarized_nodes, 1u);
  EXPECT_EQ(r.report.inserted_nodes, 1u);
  EXPECT_EQ(r.skeleton.size(), 6u);
  EXPECT_EQ(count_forks(r.skeleton), 2u);
  EXPECT_EQ(count_tips(r.skeleton), 3u);
  EXPECT_EQ(r.report.warnings.count("binarized"), 1u);
}

TEST(Skeleton, SixChildrenBecomeAChainOfForks) {
  const auto r = build_skeleton(test::six_children(), {.collar_ratio = 0});
  const Skeleton& s = r.skeleton;
  expect_valid(s);
  EXPECT_EQ(r.report.inserted_nodes, 4u);
  EXPECT_EQ(count_forks(s), 5u);
  EXPECT_EQ(count_tips(s), 6u);
  // Geometry kept: every input node is still there at its position.
  const RawSkeleton raw = test::six_children();
  for (std::size_t i = 0; i < raw.size(); ++i) {
    bool found = false;
    for (std::size_t k = 0; k < s.size(); ++k) {
      if (s.source_id[k] == raw.id[i]) {
        found = true;
        EXPECT_LT(glm::length(s.position[k] - raw.position[i]), 1e-12);
      }
    }
    EXPECT_TRUE(found) << raw.id[i];
  }
  // Inserted nodes sit a tiny step apart (much less than the radius).
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (s.source_id[k] < 0) {
      EXPECT_LT(s.edge_length(NodeId(k)), 0.5 * s.radius[k]);
    }
  }
}

TEST(Skeleton, ZeroLengthEdgesMergedZeroRadiusRaised) {
  const auto r = build_skeleton(test::zero_length_edges(), {.collar_ratio = 0});
  expect_valid(r.skeleton);
  EXPECT_EQ(r.report.merged_edges, 2u);
  EXPECT_EQ(r.report.raised_radii, 1u);
  EXPECT_EQ(r.skeleton.size(), 4u);
  EXPECT_EQ(count_forks(r.skeleton), 1u);
}

TEST(Skeleton, CollarsAtThinLaterals) {
  // The y fork's lateral (radius 0.055) is thinner than 0.7 x its fork (0.09): a collar node
  // at 0.7 fork radii along it (just inside the fork's surface), with about the lateral's
  // radius, keeps the lateral's round cone from flaring from the fork's full radius.
  const SkeletonParams collars{.collar_ratio = 0.7};
  const auto r = build_skeleton(test::y_fork(), collars);
  EXPECT_EQ(r.report.collars, 1u);
  ASSERT_EQ(r.skeleton.size(), 8u);
  const Skeleton& s = r.skeleton;
  const NodeId collar = s.children[2][1];
  EXPECT_EQ(s.source_id[collar.idx()], -1);
  EXPECT_NEAR(s.edge_length(collar), 0.7 * 0.09, 1e-12);
  EXPECT_NEAR(s.radius[collar.idx()], 0.055 + 0.25 * (0.09 - 0.055), 1e-12);
  EXPECT_EQ(r.report.warnings.total(), 0u);  // a refinement, not a repair
  // Sanitizing the result again changes nothing.
  EXPECT_EQ(build_skeleton(parse_skeleton_json(skeleton_to_json(s)), collars).skeleton.size(), 8u);
}

TEST(Skeleton, ShortStubsGetCollarsToo) {
  // A pruned stub 0.15 m long and 0.04 m thick on a trunk of radius 0.0875 (as on
  // boutdenoylum2): a collar just inside the trunk's surface (0.7 x 0.0875 from the fork)
  // keeps its cone from flaring from the trunk's full radius. One only 0.08 m long (0.019 m,
  // less than 0.75 of its radius, beyond the collar's place) keeps its cone.
  for (const auto& [length, collars] : {std::pair{0.15, 1u}, std::pair{0.08, 0u}}) {
    RawSkeleton raw;
    raw.add(0, -1, dvec3(0, 0, 0), 0.0875);
    raw.add(1, 0, dvec3(0, 0, 0.5), 0.0875);
    raw.add(2, 1, dvec3(0, 0, 1.0), 0.08);
    raw.add(3, 1, dvec3(0, 0, 0.5) + length * dvec3(std::cos(0.3), 0, std::sin(0.3)), 0.04);
    const auto r = build_skeleton(raw, {.collar_ratio = 0.7});
    EXPECT_EQ(r.report.collars, collars) << length;
  }
}

TEST(Skeleton, SteepLateralsGetAnUpturnedBase) {
  // A trunk with a horizontal lateral and a drooping one (90 and 115 degrees from the trunk):
  // each gets a base node where it has cleared the trunk, its first stretch at 60 degrees,
  // and (with room) a second node halving the bend; the tips stay where they were.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.1);
  raw.add(1, 0, dvec3(0, 0, 1), 0.1);
  raw.add(2, 1, dvec3(0, 0, 2), 0.09);
  raw.add(3, 1, dvec3(1, 0, 1), 0.03);  // horizontal
  raw.add(4, 2, dvec3(0, 0, 3), 0.08);
  raw.add(5, 2, dvec3(0, std::sin(115.0 * std::numbers::pi / 180), 2 + std::cos(115.0 * std::numbers::pi / 180)),
          0.03);                            // drooping
  raw.add(6, 4, dvec3(0.3, 0, 3.5), 0.05);  // 31 degrees: as it is
  raw.add(7, 4, dvec3(0, 0, 4), 0.06);
  const auto r = build_skeleton(raw, {.collar_ratio = 0, .max_lateral_angle = 60});
  EXPECT_EQ(r.report.raised_laterals, 2u);
  EXPECT_EQ(r.report.warnings.total(), 0u);  // a refinement, not a repair
  const Skeleton& s = r.skeleton;
  expect_valid(s);
  std::size_t checked = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const NodeId n(i);
    if (!s.is_fork(n)) continue;
    const NodeId lateral = s.children[i][1];
    const dvec3 up = glm::normalize(s.position[i] - s.position[s.parent[i].idx()]);
    const dvec3 dir = glm::normalize(s.position[lateral.idx()] - s.position[i]);
    const double degrees = std::acos(std::clamp(glm::dot(up, dir), -1.0, 1.0)) * 180.0 / std::numbers::pi;
    EXPECT_LE(degrees, 60.0 + 1e-9) << "fork " << i;
    if (s.source_id[lateral.idx()] == -1) {
      ++checked;
      EXPECT_NEAR(degrees, 60.0, 1e-9);
      EXPECT_DOUBLE_EQ(s.radius[lateral.idx()], 0.03);
      EXPECT_GT(s.edge_length(lateral), s.radius[i]);  // outside the trunk
    }
  }
  EXPECT_EQ(checked, 2u);
  for (const std::int64_t tip : {3, 5, 6, 7}) {
    const auto it = std::find(s.source_id.begin(), s.source_id.end(), tip);
    ASSERT_NE(it, s.source_id.end());
    EXPECT_EQ(s.position[std::size_t(it - s.source_id.begin())], raw.position[std::size_t(tip)]);
  }
  // Disabled: nothing inserted.
  EXPECT_EQ(build_skeleton(raw, {.collar_ratio = 0, .max_lateral_angle = 0}).report.raised_laterals, 0u);
}

TEST(Skeleton, BranchRunningInsideItsSiblingIsMerged) {
  // A "lateral" that starts on the trunk's axis and runs up inside the trunk's long edge for
  // two nodes before turning away (as Sapling writes whorls) is folded into the trunk.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.2);
  raw.add(1, 0, dvec3(0, 0, 1), 0.18);
  raw.add(2, 1, dvec3(0, 0, 3), 0.15);       // trunk, one long edge
  raw.add(3, 1, dvec3(0, 0.01, 1.6), 0.05);  // inside the trunk
  raw.add(4, 3, dvec3(0, 0.01, 2.2), 0.05);  // still inside
  raw.add(5, 4, dvec3(0.8, 0, 2.6), 0.04);   // turns away
  const auto r = build_skeleton(raw);
  EXPECT_EQ(r.report.merged_inner, 2u);
  // Node 5's branch now leaves from a trunk node near height 2.2.
  const Skeleton& s = r.skeleton;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.source_id[i] == 5) {
      NodeId p = s.parent[i];
      while (s.source_id[p.idx()] < 0 && !s.is_fork(p)) p = s.parent[p.idx()];
      EXPECT_NEAR(s.position[p.idx()].z, 2.2, 1e-9);
      EXPECT_NEAR(s.position[p.idx()].x, 0.0, 1e-9);
      // It still starts at its own radius (node 4's), not the trunk's.
      EXPECT_EQ(s.start_radius(NodeId(i)), 0.05);
    }
  }
  // The base radius survives the JSON export: re-imported, the lateral starts at 0.05 again.
  const Skeleton again = build_skeleton(parse_skeleton_json(skeleton_to_json(s), "export")).skeleton;
  std::size_t laterals = 0;
  for (std::size_t i = 1; i < again.size(); ++i) {
    if (again.start_radius(NodeId(i)) == 0.05) ++laterals;
  }
  EXPECT_EQ(laterals, 1u);
}

TEST(Skeleton, ThickerNodeIsNotFoldedIntoAThinnerSibling) {
  // Node 3 (radius 0.12) lies on the axis of its sibling's edge 1 -> 2, but that edge is
  // thinner (0.05 there): folding it would lose its thickness. It stays.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.15);
  raw.add(1, 0, dvec3(0, 0, 1), 0.12);
  raw.add(2, 1, dvec3(0, 0, 3), 0.04);
  raw.add(3, 1, dvec3(0, 0.005, 1.3), 0.12);
  raw.add(4, 3, dvec3(0.8, 0, 1.6), 0.1);
  const auto r = build_skeleton(raw);
  EXPECT_EQ(r.report.merged_inner, 0u);
  EXPECT_EQ(std::count(r.skeleton.source_id.begin(), r.skeleton.source_id.end(), 3), 1);
}

TEST(Skeleton, WhorlHubJustAboveAForkIsMerged) {
  // sapling_small_pine's whorls: the trunk continues from node 1 in one long edge, and the
  // whorl hangs off a hub that starts 0.07 above node 1 on the trunk's axis (inside the fork's
  // own sphere) and carries its laterals on nodes a few millimetres apart. The hub chain is
  // folded into the trunk; the laterals leave from trunk nodes on the axis.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.07);
  raw.add(1, 0, dvec3(0, 0, 1.76), 0.065);
  raw.add(2, 1, dvec3(0, 0, 2.34), 0.053);        // trunk, one long edge
  raw.add(3, 1, dvec3(0, 0.001, 1.83), 0.031);    // hub, along the trunk
  raw.add(4, 3, dvec3(0.3, 0.07, 1.80), 0.026);   // lateral
  raw.add(5, 3, dvec3(0, 0.001, 1.837), 0.031);   // hub continues a hair above
  raw.add(6, 5, dvec3(-0.3, 0.05, 1.85), 0.026);  // lateral
  raw.add(7, 5, dvec3(0.05, -0.3, 1.86), 0.025);  // lateral
  const auto r = build_skeleton(raw, {.collar_ratio = 0, .max_lateral_angle = 0});
  const Skeleton& s = r.skeleton;
  expect_valid(s);
  EXPECT_GE(r.report.merged_inner, 2u);
  for (const std::int64_t hub : {3, 5}) EXPECT_EQ(std::count(s.source_id.begin(), s.source_id.end(), hub), 0);
  for (const std::int64_t lateral : {4, 6, 7}) {
    const auto it = std::find(s.source_id.begin(), s.source_id.end(), lateral);
    ASSERT_NE(it, s.source_id.end());
    const std::size_t p = s.parent[std::size_t(it - s.source_id.begin())].idx();
    EXPECT_LT(glm::length(glm::dvec2(s.position[p])), 1e-3) << lateral;  // on the trunk's axis
    EXPECT_NEAR(s.position[p].z, 1.83, 0.03) << lateral;
  }
  // A lateral leaving the same fork at 40 degrees is an ordinary fork: kept.
  RawSkeleton fork;
  fork.add(0, -1, dvec3(0), 0.07);
  fork.add(1, 0, dvec3(0, 0, 1.76), 0.065);
  fork.add(2, 1, dvec3(0, 0, 2.34), 0.053);
  fork.add(3, 1, dvec3(0, 0, 1.76) + 0.08 * dvec3(std::sin(0.7), 0, std::cos(0.7)), 0.03);
  fork.add(4, 3, dvec3(0.6, 0, 2.4), 0.025);
  const auto kept = build_skeleton(fork, {.collar_ratio = 0, .max_lateral_angle = 0});
  EXPECT_EQ(kept.report.merged_inner, 0u);
  EXPECT_EQ(std::count(kept.skeleton.source_id.begin(), kept.skeleton.source_id.end(), 3), 1);
}

TEST(Skeleton, TipWhollyInsideItsParentIsRemoved) {
  // A pruned trunk digitised with a knob: tip 3 (radius 0.04) 4 cm from trunk node 1
  // (radius 0.09) lies wholly inside the trunk and is removed; tip 4 (radius 0.04, reaching
  // 0.3 out of the trunk) is a real stub and stays.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.1);
  raw.add(1, 0, dvec3(0, 0, 1), 0.09);
  raw.add(2, 1, dvec3(0, 0, 2), 0.08);
  raw.add(3, 1, dvec3(0.02, 0, 1.03), 0.04);  // hidden knob
  raw.add(4, 1, dvec3(0.3, 0, 1.1), 0.04);    // stub outside
  const auto r = build_skeleton(raw, {.collar_ratio = 0, .max_lateral_angle = 0});
  const Skeleton& s = r.skeleton;
  expect_valid(s);
  EXPECT_EQ(r.report.hidden_tips, 1u);
  EXPECT_EQ(r.report.warnings.count("hidden_tip"), 1u);
  EXPECT_EQ(std::count(s.source_id.begin(), s.source_id.end(), 3), 0);
  EXPECT_EQ(std::count(s.source_id.begin(), s.source_id.end(), 4), 1);
  // The end of a branch is never removed, however short.
  RawSkeleton end;
  end.add(0, -1, dvec3(0), 0.1);
  end.add(1, 0, dvec3(0, 0, 1), 0.09);
  end.add(2, 1, dvec3(0, 0, 1.01), 0.05);
  EXPECT_EQ(build_skeleton(end).report.hidden_tips, 0u);
}

TEST(Skeleton, BranchRunningBackInsideItsParentIsMerged) {
  // A whorl hub as Sapling writes it: a child of node 2 that starts back down inside the
  // trunk edge 1 -> 2 (0.4 below node 2, on the axis), its two laterals leaving from there.
  // The hub is folded into the trunk edge: the laterals leave from a trunk node at its height.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.1);
  raw.add(1, 0, dvec3(0, 0, 1), 0.1);
  raw.add(2, 1, dvec3(0, 0, 2), 0.09);
  raw.add(3, 2, dvec3(0, 0, 3), 0.08);
  raw.add(4, 2, dvec3(0.005, 0, 1.6), 0.03);  // the hub
  raw.add(5, 4, dvec3(1, 0, 1.6), 0.02);
  raw.add(6, 4, dvec3(-1, 0, 1.7), 0.02);
  const auto r = build_skeleton(raw, {.collar_ratio = 0, .max_lateral_angle = 0});
  EXPECT_EQ(r.report.warnings.count("inner_branch_back"), 1u);
  const Skeleton& s = r.skeleton;
  expect_valid(s);
  EXPECT_EQ(std::count(s.source_id.begin(), s.source_id.end(), 4), 0);  // the hub is gone
  for (const std::int64_t lateral : {5, 6}) {
    const auto it = std::find(s.source_id.begin(), s.source_id.end(), lateral);
    ASSERT_NE(it, s.source_id.end());
    const dvec3 base = s.position[s.parent[std::size_t(it - s.source_id.begin())].idx()];
    EXPECT_NEAR(base.x, 0.0, 1e-9);  // on the trunk's axis
    EXPECT_NEAR(base.y, 0.0, 1e-9);
    EXPECT_NEAR(base.z, 1.6, 0.25 * 0.1);  // within a step of the binarized chain (0.2 x radius)
  }
}

TEST(Skeleton, CrossingBranchesAreSwungApart) {
  // Two laterals from different forks of a trunk, the lower one rising through the upper one
  // 0.3 m from the trunk: a collision away from their common ancestor.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.1);
  raw.add(1, 0, dvec3(0, 0, 1), 0.1);
  raw.add(2, 1, dvec3(0, 0, 1.5), 0.09);
  raw.add(3, 2, dvec3(0, 0, 3), 0.08);
  raw.add(4, 1, dvec3(0.6, 0, 2.0), 0.03);     // rising lateral
  raw.add(5, 2, dvec3(0.8, 0.02, 1.5), 0.03);  // flat lateral, crossed near x = 0.3
  SkeletonParams p;
  p.separate = false;
  const Skeleton kept = build_skeleton(raw, p).skeleton;
  EXPECT_FALSE(find_collisions(kept).empty());
  p.separate = true;
  const auto r = build_skeleton(raw, p);
  EXPECT_GT(r.report.branch_collisions, 0u);
  EXPECT_EQ(r.report.unresolved_collisions, 0u);
  EXPECT_GT(r.report.max_separation, 0.0);
  EXPECT_LT(r.report.max_separation, 0.5);
  EXPECT_TRUE(find_collisions(r.skeleton).empty());
  expect_valid(r.skeleton);
}

TEST(Skeleton, HubsAreClustered) {
  // 1,000 twigs from one node: on one chain of 999 binary forks, each fork carries every twig
  // above it (the sum over the nodes of the twigs above them, which the particle count
  // follows, is about 500,000); grouped under cluster nodes, chains stay short and the sum
  // near-linear in the twigs.
  const RawSkeleton raw = test::star(1000);
  SkeletonParams p;
  p.separate = false;
  // Tips in all the nodes' subtrees, summed; and the tip count.
  auto carried = [](const Skeleton& s) {
    std::vector<std::size_t> tips(s.size(), 0);
    std::size_t sum = 0, twigs = 0;
    for (std::size_t i = s.size(); i-- > 0;) {
      if (s.is_tip(NodeId(i))) {
        tips[i] = 1;
        ++twigs;
      }
      if (s.parent[i].valid()) tips[s.parent[i].idx()] += tips[i];
      sum += tips[i];
    }
    return std::pair(sum, twigs);
  };
  const auto r = build_skeleton(raw, p);
  expect_valid(r.skeleton);
  EXPECT_GT(r.report.clustered_nodes, 0u);
  EXPECT_EQ(r.report.warnings.count("clustered_children"), r.report.clustered_nodes);
  const auto [sum, twigs] = carried(r.skeleton);
  EXPECT_EQ(twigs, 1000u);  // every twig kept
  EXPECT_LT(sum, 20'000u);
  p.max_chain_forks = 0;
  const auto chained = build_skeleton(raw, p);
  EXPECT_EQ(chained.report.clustered_nodes, 0u);
  EXPECT_GT(carried(chained.skeleton).first, 400'000u);
}

TEST(Skeleton, DenseHubIsLeftAsItIs) {
  // 1,000 twigs from one node: edges crowding each other by the hundred, which no swinging
  // clears (it used to take 13 s and move twigs 12 m; examining the pairs alone is
  // quadratic). Left in place and reported.
  const RawSkeleton raw = test::star(1000);
  const auto r = build_skeleton(raw, {.separate = true});
  EXPECT_EQ(r.report.max_separation, 0.0);
  EXPECT_EQ(r.report.warnings.count("separated_branches"), 0u);
  EXPECT_EQ(r.report.warnings.count("dense_branches"), 1u);
  expect_valid(r.skeleton);
}

TEST(Skeleton, TightBendsAreStraightened) {
  // A twig of radius 3 mm: up 50 mm, up 6 mm more, 6 mm sideways, then 50 mm at 30 degrees
  // above the horizontal. At node 2 it turns by 90 degrees, which needs r tan(45) = 3 mm of
  // straight edge on either side: half of its shorter edge (6 mm).
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.003);
  raw.add(1, 0, dvec3(0, 0, 0.05), 0.003);
  raw.add(2, 1, dvec3(0, 0, 0.056), 0.003);
  raw.add(3, 2, dvec3(0.006, 0, 0.056), 0.003);
  raw.add(4, 3, dvec3(0.006 + 0.05 * std::cos(std::numbers::pi / 6), 0, 0.056 + 0.05 * std::sin(std::numbers::pi / 6)),
          0.003);
  auto ids = [](const Skeleton& s) { return std::vector<std::int64_t>(s.source_id.begin(), s.source_id.end()); };
  // By default (the input as given) a node is removed only where the straightened branch passes
  // within max_node_move x its radius of it: node 2 lies 1.4 radii off the line from 1 to 3.
  const auto kept = build_skeleton(raw, {.collar_ratio = 0, .max_lateral_angle = 0, .tight_bend_ratio = 0.01});
  EXPECT_EQ(kept.report.tight_bends, 0u);
  EXPECT_EQ(ids(kept.skeleton), (std::vector<std::int64_t>{0, 1, 2, 3, 4}));
  {
    // Node 2 half a millimetre above 1 (0.17 radii off the line from 1 to 3): removed.
    RawSkeleton near = raw;
    near.position[2] = dvec3(0, 0, 0.0505);
    near.position[3] = dvec3(0.006, 0, 0.0505);
    const auto r = build_skeleton(near, {.collar_ratio = 0, .max_lateral_angle = 0});
    EXPECT_EQ(r.report.tight_bends, 1u);
    EXPECT_EQ(ids(r.skeleton), (std::vector<std::int64_t>{0, 1, 3, 4}));
    EXPECT_EQ(r.report.max_move, 0.0);
  }
  // With `separate` every tight bend goes, however far the branch then moves.
  auto with = [&](double ratio) {
    return build_skeleton(raw, {.collar_ratio = 0, .max_lateral_angle = 0, .tight_bend_ratio = ratio, .separate = true});
  };
  // 0.6 allows 3.6 mm: kept.
  const auto loose = with(0.6);
  EXPECT_EQ(loose.report.tight_bends, 0u);
  EXPECT_EQ(ids(loose.skeleton), (std::vector<std::int64_t>{0, 1, 2, 3, 4}));
  // 0.4 allows 2.4 mm: node 2 is removed. Node 1 then turns by 45 degrees (1.2 mm of the
  // 8.5 mm edge to node 3), node 3 by 15: both kept.
  const auto r = with(0.4);
  EXPECT_EQ(r.report.tight_bends, 1u);
  EXPECT_EQ(r.report.warnings.count("tight_bend"), 1u);
  EXPECT_EQ(ids(r.skeleton), (std::vector<std::int64_t>{0, 1, 3, 4}));
  expect_valid(r.skeleton);
  for (std::size_t i = 0; i < r.skeleton.size(); ++i) {
    const auto k = std::size_t(std::find(raw.id.begin(), raw.id.end(), r.skeleton.source_id[i]) - raw.id.begin());
    EXPECT_EQ(r.skeleton.position[i], raw.position[k]);  // nothing moved
    EXPECT_EQ(r.skeleton.radius[i], raw.radius[k]);
  }
  // Each removal sharpens the neighbours' turns: at 0.01 nodes 2, 1 and 3 go in turn (never
  // the root or the tip).
  const auto strict = with(0.01);
  EXPECT_EQ(strict.report.tight_bends, 3u);
  EXPECT_EQ(ids(strict.skeleton), (std::vector<std::int64_t>{0, 4}));
  EXPECT_EQ(with(0).report.tight_bends, 0u);  // off
}

TEST(Skeleton, HairpinsAreReattachedWhereTheyComeBackTo) {
  // A pruned top with regrowth: the trunk runs up to node 2, and its only child turns back
  // down by 150 degrees (reaching 0.25 back down the 0.5 m edge) before going on sideways.
  // The child is re-attached to the trunk edge 0.25 below node 2, which becomes a stub.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.1);
  raw.add(1, 0, dvec3(0, 0, 1), 0.1);
  raw.add(2, 1, dvec3(0, 0, 1.5), 0.09);
  raw.add(3, 2, dvec3(0.25 * std::tan(30.0 * std::numbers::pi / 180), 0, 1.25), 0.05);
  raw.add(4, 3, dvec3(0.6, 0, 1.35), 0.04);
  const auto r = build_skeleton(raw, {.collar_ratio = 0, .max_lateral_angle = 0, .separate = true});
  EXPECT_EQ(r.report.hairpins, 1u);
  EXPECT_EQ(r.report.warnings.count("hairpin"), 1u);
  const Skeleton& s = r.skeleton;
  expect_valid(s);
  auto node = [&](std::int64_t id) {
    return std::size_t(std::find(s.source_id.begin(), s.source_id.end(), id) - s.source_id.begin());
  };
  EXPECT_TRUE(s.is_tip(NodeId(node(2))));  // the pruned top is a stub
  const NodeId base = s.parent[node(3)];
  EXPECT_EQ(s.source_id[base.idx()], -1);  // a new node on the trunk edge
  EXPECT_NEAR(s.position[base.idx()].z, 1.25, 1e-9);
  EXPECT_NEAR(glm::length(dvec2(s.position[base.idx()])), 0.0, 1e-9);
  EXPECT_EQ(s.position[node(3)], raw.position[3]);  // nothing else moved
  EXPECT_EQ(s.position[node(4)], raw.position[4]);
  // Turned off (with the tight-bend repair, which would remove the node it turns at), the
  // hairpin stays.
  const auto kept =
      build_skeleton(raw, {.collar_ratio = 0, .max_lateral_angle = 0, .max_turn_back = 0, .tight_bend_ratio = 0});
  EXPECT_EQ(kept.report.hairpins, 0u);
  const Skeleton& k = kept.skeleton;
  const auto k3 = std::size_t(std::find(k.source_id.begin(), k.source_id.end(), 3) - k.source_id.begin());
  ASSERT_LT(k3, k.size());
  EXPECT_EQ(k.source_id[k.parent[k3].idx()], 2);
}

TEST(Skeleton, ThickChildPolicies) {
  const auto clamp = build_skeleton(test::thick_child(), {.thick_child_policy = ThickChildPolicy::clamp_child});
  EXPECT_EQ(clamp.report.clamped_children, 1u);
  for (std::size_t i = 1; i < clamp.skeleton.size(); ++i) {
    EXPECT_LE(clamp.skeleton.radius[i], clamp.skeleton.radius[clamp.skeleton.parent[i].idx()] * (1 + 1e-12));
  }
  SkeletonParams raise;
  raise.thick_child_policy = ThickChildPolicy::raise_parent;
  const auto r = build_skeleton(test::thick_child(), raise);
  EXPECT_GE(r.report.clamped_children, 1u);
  for (std::size_t i = 1; i < r.skeleton.size(); ++i) {
    EXPECT_LE(r.skeleton.radius[i], r.skeleton.radius[r.skeleton.parent[i].idx()] * (1 + 1e-12));
  }
  EXPECT_NEAR(r.skeleton.radius[0], 0.1, 1e-12);
  SkeletonParams keep;
  keep.thick_child_policy = ThickChildPolicy::keep;
  EXPECT_EQ(build_skeleton(test::thick_child(), keep).report.clamped_children, 0u);
}

TEST(Skeleton, ResamplingSplitsLongEdges) {
  SkeletonParams p;
  p.max_edge_ratio = 2.0;
  const auto r = build_skeleton(test::straight_branch(3), p);
  expect_valid(r.skeleton);
  EXPECT_GT(r.report.resampled_edges, 0u);
  for (std::size_t i = 1; i < r.skeleton.size(); ++i) {
    const double rr = 0.5 * (r.skeleton.radius[i] + r.skeleton.radius[r.skeleton.parent[i].idx()]);
    EXPECT_LE(r.skeleton.edge_length(NodeId(i)), 2.0 * rr * 1.05);
  }
}

TEST(Skeleton, LongChainHasNoRecursion) {
  const auto r = build_skeleton(test::long_chain(100'000));
  EXPECT_EQ(r.skeleton.size(), 100'000u);
  EXPECT_NO_THROW(validate_binary_skeleton(r.skeleton));
  EXPECT_LT(max_twist(r.skeleton), 1e-6);
  const auto json = skeleton_to_json(r.skeleton);
  EXPECT_EQ(build_skeleton(parse_skeleton_json(json)).skeleton.size(), 100'000u);
}

TEST(Skeleton, FramesOrthonormalAndTwistFree) {
  for (const auto& raw : {test::y_fork(), test::six_children(), test::grown_tree(3)}) {
    const Skeleton s = built(raw);
    for (const Frame& f : s.frame) {
      EXPECT_NEAR(glm::length(f.normal), 1, 1e-9);
      EXPECT_NEAR(glm::dot(f.normal, f.tangent), 0, 1e-9);
      EXPECT_NEAR(glm::dot(glm::cross(f.tangent, f.normal), f.binormal), 1, 1e-9);
    }
    EXPECT_LT(max_twist(s), 1e-6) << raw.source;
  }
}

TEST(Skeleton, JsonRoundTrip) {
  const Skeleton a = built(test::six_children());
  const Skeleton b = built(parse_skeleton_json(skeleton_to_json(a)));
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a.position[i], b.position[i]);
    EXPECT_EQ(a.radius[i], b.radius[i]);
    EXPECT_EQ(a.parent[i], b.parent[i]);
    EXPECT_EQ(a.children[i], b.children[i]);
  }
}

TEST(Skeleton, SwcImport) {
  const std::string swc =
      "# a small neuron-like tree\n"
      "1 1 0 0 0 0.5 -1\n"
      "2 3 0 0 2 0.4 1\n"
      "\n"
      "3 3 1 0 3 0.2 2   # lateral\n"
      "4 3 0 0 4.0 0.3 2\n";
  const Skeleton s = built(parse_swc(swc, "test.swc"), {.collar_ratio = 0});
  EXPECT_EQ(s.size(), 4u);
  EXPECT_EQ(count_forks(s), 1u);
  EXPECT_EQ(s.source_id[s.children[1][0].idx()], 4);
}

TEST(Skeleton, UpAxisAndUnknownKeys) {
  const auto raw = parse_skeleton_json(
      R"({"up_axis":"y","extra":{"a":1},"nodes":[{"id":5,"parent":-1,"position":[0,0,0],"radius":1,"color":"red"},
          {"id":9,"parent":5,"position":[0,2,0],"radius":0.5}]})");
  EXPECT_EQ(raw.up_axis, UpAxis::y);
  const Skeleton s = built(raw);
  EXPECT_EQ(s.up_axis, UpAxis::y);
  EXPECT_EQ(s.size(), 2u);
}

struct BadInput {
  const char* name;
  const char* text;
  const char* expected;  // substring of the error message
  bool swc = false;
};

class Malformed : public ::testing::TestWithParam<BadInput> {};

TEST_P(Malformed, GivesOneClearError) {
  const BadInput& b = GetParam();
  try {
    const RawSkeleton raw = b.swc ? parse_swc(b.text, "in.swc") : parse_skeleton_json(b.text, "in.json");
    build_skeleton(raw);
    FAIL() << "accepted " << b.name;
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find(b.expected), std::string::npos) << b.name << ": " << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(
    Table, Malformed,
    ::testing::Values(
        BadInput{"truncated", R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,)", "in.json:1:"},
        BadInput{"string_for_number", R"({"nodes":[{"id":0,"parent":-1,"position":[0,"a",0],"radius":1}]})",
                 "\"position\"[1] must be a number, not string"},
        BadInput{"nan_literal", R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,0],"radius":NaN}]})",
                 "not valid JSON"},
        BadInput{"overflow_inf", R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,1e999],"radius":1}]})",
                 "not valid JSON: number overflow"},
        BadInput{"cycle",
                 R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,0],"radius":1},
                    {"id":1,"parent":2,"position":[0,0,1],"radius":1},{"id":2,"parent":1,"position":[0,0,2],"radius":1}]})",
                 "cycle"},
        BadInput{"self_parent", R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,0],"radius":1},
                    {"id":1,"parent":1,"position":[0,0,1],"radius":1}]})",
                 "its own parent"},
        BadInput{"two_roots", R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,0],"radius":1},
                    {"id":1,"parent":-1,"position":[0,0,1],"radius":1}]})",
                 "second root"},
        BadInput{"no_root", R"({"nodes":[{"id":0,"parent":1,"position":[0,0,0],"radius":1},
                    {"id":1,"parent":0,"position":[0,0,1],"radius":1}]})",
                 "no root"},
        BadInput{"missing_parent", R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,0],"radius":1},
                    {"id":1,"parent":7,"position":[0,0,1],"radius":1}]})",
                 "parent id 7 does not exist"},
        BadInput{"negative_radius", R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,0],"radius":-0.5}]})",
                 "radius -0.5 is negative"},
        BadInput{"duplicate_id", R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,0],"radius":1},
                    {"id":0,"parent":0,"position":[0,0,1],"radius":1}]})",
                 "duplicate node id 0"},
        BadInput{"empty_file", "", "the file is empty"}, BadInput{"empty_nodes", R"({"nodes":[]})", "no nodes"},
        BadInput{"no_nodes_key", R"({"bones":[]})", "missing the \"nodes\" array"},
        BadInput{"sanitized_not_bool",
                 R"({"sanitized":"yes","nodes":[{"id":0,"parent":-1,"position":[0,0,0],"radius":1}]})",
                 "\"sanitized\" must be true or false"},
        BadInput{"binary_garbage",
                 "\x7f"
                 "ELF\x02\x01\x01\x00\xff\xfe\x00\x10",
                 "not valid JSON"},
        BadInput{"swc_nan", "1 1 0 0 0 nan -1\n", "radius nan is not finite", true},
        BadInput{"swc_fields", "1 1 0 0 0 1\n", "in.swc:1: expected 7 fields", true},
        BadInput{"swc_text", "1 1 0 zero 0 1 -1\n", "in.swc:1: y \"zero\" is not a number", true},
        BadInput{"swc_missing_parent", "1 1 0 0 0 1 -1\n2 1 0 0 1 1 5\n",
                 "in.swc: line 2 (id 2): parent id 5 does not exist", true}),
    [](const ::testing::TestParamInfo<BadInput>& p) { return std::string(p.param.name); });

TEST(Skeleton, NodeLimit) {
  SkeletonParams p;
  p.max_nodes = 10;
  EXPECT_THROW(build_skeleton(test::long_chain(11), p), InvalidInputError);
}

TEST(Samples, LoadSanitizeRoundTrip) {
  const auto files = test::sample_skeletons();
  ASSERT_FALSE(files.empty()) << "tests/data/skeletons is empty";
  for (const auto& f : files) {
    SCOPED_TRACE(f.filename().string());
    for (const SkeletonParams& sp : {SkeletonParams{}, SkeletonParams{.thick_child_policy = ThickChildPolicy::clamp_child,
                                                                     .collar_ratio = 0.7,
                                                                     .max_lateral_angle = 60,
                                                                     .separate = true}}) {
    const auto r = build_skeleton(read_skeleton(f), sp);
    expect_valid(r.skeleton);
    EXPECT_EQ(r.report.output_nodes, r.skeleton.size());
    EXPECT_LT(max_twist(r.skeleton), 1e-6);
    // Sanitizing the exported result again changes nothing (the export is marked sanitized,
    // so the geometric refinements, which can feed each other, are not applied twice).
    const RawSkeleton exported = parse_skeleton_json(skeleton_to_json(r.skeleton));
    EXPECT_TRUE(exported.sanitized);
    const Skeleton back = built(exported, sp);
    ASSERT_EQ(back.size(), r.skeleton.size());
    for (std::size_t i = 0; i < back.size(); ++i) {
      ASSERT_EQ(back.position[i], r.skeleton.position[i]);
      ASSERT_EQ(back.radius[i], r.skeleton.radius[i]);
      ASSERT_EQ(back.children[i], r.skeleton.children[i]);
    }
    }
  }
}

TEST(Grower, DeterministicAndSeedDependent) {
  const std::string a = raw_skeleton_to_json(test::grown_tree(5));
  const std::string b = raw_skeleton_to_json(test::grown_tree(5));
  const std::string c = raw_skeleton_to_json(test::grown_tree(6));
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  const auto r = build_skeleton(test::grown_tree(5));
  EXPECT_GT(r.skeleton.size(), 200u);
  EXPECT_GT(count_forks(r.skeleton), 20u);
  EXPECT_EQ(r.report.warnings.total(), 0u) << r.report.warnings.to_string();
}

}  // namespace
}  // namespace sm
