// Tests of the strands stage: curves through their control points, finite everywhere, smooth
// across nodes, strand paths and arc-length sampling, determinism and the dump format.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include <nlohmann/json.hpp>
#include <tbb/task_arena.h>

#include "core/errors.h"
#include "particles/particles.h"
#include "skeleton/build.h"
#include "skeleton/io.h"
#include "strands/dump.h"
#include "strands/strands.h"
#include "tests/fixtures.h"

namespace sm {
namespace {

using test::built;

bool finite(const dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

/// Every property of a strand set that holds for any input; `what` names the case.
void expect_curves(const Skeleton& sk, const ParticleField& f, const StrandSet& st, const std::string& what) {
  ASSERT_EQ(st.point.size(), f.position.size()) << what;
  const double scale = 1e-9 * (1.0 + glm::length(sk.position[0]));  // coordinates may be far from 0
  std::size_t off_point = 0, off_end = 0, not_finite = 0, kinks = 0, cusps = 0;
  for (std::size_t i = 0; i < sk.size(); ++i) {
    const NodeId n(i);
    for (std::uint32_t j = 0; j < f.count(n); ++j) {
      const std::uint32_t g = f.global(n, j);
      const dvec3 want = sk.position[i] + sk.frame[i].to_world(f.position[g]);
      if (glm::length(st.point[g] - want) > scale) ++off_point;
      if (!finite(st.point[g])) ++not_finite;
      if (!sk.parent[i].valid()) continue;
      const SegmentTangents m = st.tangents(sk, f, n, j);
      if (!finite(m.at_node) || !finite(m.at_parent)) ++not_finite;
      // Through the control points: t = 1 at the node, t = 0 at the parent.
      const dvec3 at_parent = st.point[f.global(sk.parent[i], parent_index(sk, f, n, j))];
      if (glm::length(st.evaluate(sk, f, n, j, 1.0) - st.point[g]) > scale) ++off_end;
      if (glm::length(st.evaluate(sk, f, n, j, 0.0) - at_parent) > scale) ++off_end;
      const double chord = glm::length(st.point[g] - at_parent);
      for (int k = 0; k <= 16; ++k) {
        const double t = k / 16.0;
        if (!finite(st.evaluate(sk, f, n, j, t)) || !finite(st.derivative(sk, f, n, j, t))) ++not_finite;
        // Centripetal Catmull-Rom has no cusps: the speed stays away from zero.
        if (chord > scale && glm::length(st.derivative(sk, f, n, j, t)) < 1e-6 * chord) ++cusps;
      }
      // Smooth across the node: the child's segment leaves n in the direction this segment
      // arrives (same Catmull-Rom neighbours, so the tangents are parallel).
      const NodeId c0 = sk.children[i][0], c1 = sk.children[i][1];
      if (j < f.new_begin[i]) {
        const std::uint32_t n0 = c0.valid() ? f.count(c0) : 0;
        const NodeId c = j < n0 ? c0 : c1;
        const dvec3 a = m.at_node, b = st.tangents(sk, f, c, j < n0 ? j : j - n0).at_parent;
        if (glm::length(a) > 0 && glm::length(b) > 0) {
          const double cosine = glm::dot(a, b) / (glm::length(a) * glm::length(b));
          if (cosine < 1 - 1e-9) ++kinks;
        }
      }
    }
  }
  EXPECT_EQ(off_point, 0u) << what;
  EXPECT_EQ(off_end, 0u) << what;
  EXPECT_EQ(not_finite, 0u) << what;
  EXPECT_EQ(kinks, 0u) << what;
  EXPECT_EQ(cusps, 0u) << what;
  EXPECT_EQ(st.stats.strands, f.strand_count()) << what;
  EXPECT_EQ(st.stats.segments, f.position.size() - f.count(Skeleton::root())) << what;
}

TEST(Strands, FixturesAndGrownTrees) {
  const std::pair<const char*, RawSkeleton> cases[] = {
      {"straight_branch", test::straight_branch(8)}, {"y_fork", test::y_fork()},
      {"six_children", test::six_children()},         {"zero_length_edges", test::zero_length_edges()},
      {"grown 1", test::grown_tree(1)},               {"grown 2", test::grown_tree(2)},
  };
  for (const auto& [name, raw] : cases) {
    const Skeleton sk = built(raw);
    const ParticleField f = compute_particles(sk);
    expect_curves(sk, f, build_strands(sk, f), name);
  }
}

TEST(Strands, SampleSkeletons) {
  const auto files = test::sample_skeletons();
  ASSERT_FALSE(files.empty()) << "tests/data/skeletons is empty";
  for (const auto& file : files) {
    const Skeleton sk = build_skeleton(read_skeleton(file)).skeleton;
    const ParticleField f = compute_particles(sk);
    expect_curves(sk, f, build_strands(sk, f), file.filename().string());
  }
}

TEST(Strands, StraightBranchStrandsAreStraight) {
  // A straight untapered branch: every strand is a straight line parallel to the axis.
  RawSkeleton raw;
  for (int i = 0; i < 5; ++i) raw.add(i, i - 1, dvec3(0, 0, 0.3 * i), 0.05);
  const Skeleton sk = built(raw);
  const ParticleField f = compute_particles(sk);
  const StrandSet st = build_strands(sk, f);
  for (std::uint32_t j = 0; j < f.count(NodeId(2u)); ++j) {
    const dvec3 a = st.evaluate(sk, f, NodeId(2u), j, 0.0), b = st.evaluate(sk, f, NodeId(2u), j, 1.0);
    const dvec3 mid = st.evaluate(sk, f, NodeId(2u), j, 0.37);
    EXPECT_NEAR(mid.x, a.x, 1e-12);
    EXPECT_NEAR(mid.y, a.y, 1e-12);
    EXPECT_NEAR(b.z - a.z, 0.3, 1e-12);
    EXPECT_NEAR(glm::length(st.derivative(sk, f, NodeId(2u), j, 0.5) - dvec3(0, 0, 0.3)), 0, 1e-9);
  }
}

TEST(Strands, PathsAndArcLength) {
  const Skeleton sk = built(test::grown_tree(3));
  const ParticleField f = compute_particles(sk);
  const StrandSet st = build_strands(sk, f);
  for (std::size_t s = 0; s < f.strand_count(); s += 97) {
    const StrandId id(s);
    const StrandPath path = strand_path(sk, f, id);
    ASSERT_FALSE(path.nodes.empty());
    EXPECT_EQ(path.nodes.front(), f.strand_start[s]);
    EXPECT_EQ(path.nodes.back(), Skeleton::root());
    for (std::size_t k = 0; k < path.nodes.size(); ++k) {
      EXPECT_EQ(f.strand[f.global(path.nodes[k], path.local[k])], id);
      if (k > 0) {
        EXPECT_EQ(sk.parent[path.nodes[k - 1].idx()], path.nodes[k]);
      }
    }
    const StrandPolyline line = sample_strand(sk, f, st, id, 6);
    ASSERT_EQ(line.points.size(), 6 * (path.nodes.size() - 1) + 1);
    EXPECT_EQ(line.points.front(), st.point[f.global(path.nodes.front(), path.local.front())]);
    EXPECT_EQ(line.points.back(), st.point[f.global(Skeleton::root(), path.local.back())]);
    for (std::size_t i = 1; i < line.arc_length.size(); ++i) EXPECT_GE(line.arc_length[i], line.arc_length[i - 1]);
    const double total = line.arc_length.back();
    EXPECT_EQ(point_at_arc_length(line, -1.0), line.points.front());
    EXPECT_EQ(point_at_arc_length(line, total + 1.0), line.points.back());
    // Halfway by arc length lies between the samples that bracket it.
    const dvec3 half = point_at_arc_length(line, 0.5 * total);
    const std::size_t i = std::size_t(std::upper_bound(line.arc_length.begin(), line.arc_length.end(), 0.5 * total) -
                                      line.arc_length.begin());
    EXPECT_NEAR(glm::length(half - line.points[i - 1]) + glm::length(line.points[i] - half),
                glm::length(line.points[i] - line.points[i - 1]), 1e-9);
    // The polyline is at least as long as the chord from tip to root.
    EXPECT_GE(total, glm::length(line.points.back() - line.points.front()) - 1e-12);
  }
  EXPECT_THROW(strand_path(sk, f, StrandId(f.strand_count())), InternalError);
}

TEST(Strands, IdenticalForOneAndTwoThreads) {
  const Skeleton sk = built(test::grown_tree(4));
  const ParticleField f = compute_particles(sk);
  StrandSet one, two;
  tbb::task_arena(1).execute([&] { one = build_strands(sk, f); });
  tbb::task_arena(2).execute([&] { two = build_strands(sk, f); });
  ASSERT_EQ(one.point.size(), two.point.size());
  EXPECT_EQ(0, std::memcmp(one.point.data(), two.point.data(), one.point.size() * sizeof(dvec3)));
  EXPECT_EQ(one.stats.warnings.list().size(), two.stats.warnings.list().size());
}

TEST(Strands, AlphaIsChecked) {
  const Skeleton sk = built(test::y_fork());
  const ParticleField f = compute_particles(sk);
  EXPECT_THROW(build_strands(sk, f, {.alpha = -0.1}), InvalidInputError);
  EXPECT_THROW(build_strands(sk, f, {.alpha = 1.5}), InvalidInputError);
  // Uniform and chordal variants also interpolate their points.
  for (double alpha : {0.0, 1.0}) expect_curves(sk, f, build_strands(sk, f, {.alpha = alpha}), "alpha");
}

TEST(Strands, DumpFollowsTheStrands) {
  const Skeleton sk = built(test::y_fork());
  const ParticleField f = compute_particles(sk);
  const StrandSet st = build_strands(sk, f);
  const auto j = nlohmann::json::parse(strands_to_json(sk, f, st));
  EXPECT_EQ(j["format"], "strandmesh-strands");
  const auto point = j["point"].get<std::vector<double>>();
  const auto parent = j["parent_global"].get<std::vector<std::int64_t>>();
  const auto start = j["start_global"].get<std::vector<std::uint32_t>>();
  ASSERT_EQ(point.size(), 3 * f.position.size());
  ASSERT_EQ(start.size(), f.strand_count());
  // Following parent_global from each start reaches the root block, with the same strand id.
  for (std::size_t s = 0; s < start.size(); ++s) {
    std::int64_t g = start[s];
    int guard = 0;
    while (parent[std::size_t(g)] >= 0 && guard++ < 1000) {
      EXPECT_EQ(f.strand[std::size_t(g)], StrandId(s));
      g = parent[std::size_t(g)];
    }
    EXPECT_LT(std::size_t(g), f.count(Skeleton::root()));
    EXPECT_EQ(f.strand[std::size_t(g)], StrandId(s));
  }
  for (std::size_t g = 0; g < f.position.size(); ++g) {
    EXPECT_EQ(point[3 * g + 2], st.point[g].z);
  }
}

}  // namespace
}  // namespace sm
