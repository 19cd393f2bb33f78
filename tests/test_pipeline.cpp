// The whole pipeline on fixtures, grown trees and every sample skeleton: the mesh must be one
// closed, consistently oriented 2-manifold of genus 0 without degenerate or self-intersecting
// triangles, and follow the skeleton (DESIGN.md, "What neither reference solves").

#include <gtest/gtest.h>

#include "core/errors.h"
#include "meshing/checks.h"
#include "pipeline/pipeline.h"
#include "skeleton/io.h"
#include "tests/fixtures.h"

namespace sm {
namespace {

struct Case {
  std::string name;
  RawSkeleton raw;
};

MeshCheckReport run_and_check(const RawSkeleton& raw, bool self_intersections, PipelineResult* out = nullptr) {
  PipelineResult r = run_pipeline(raw, {});
  EXPECT_EQ(r.mesh.stats.bad_edges, 0u);
  MeshCheckParams cp;
  cp.self_intersections = self_intersections;
  cp.skeleton = &r.skeleton.skeleton;
  MeshCheckReport rep = check_mesh(r.mesh.mesh, cp);
  if (out) *out = std::move(r);
  return rep;
}

void expect_good(const MeshCheckReport& rep, const std::string& name) {
  EXPECT_TRUE(rep.closed) << name << ": " << rep.boundary_edges << " boundary edges";
  EXPECT_TRUE(rep.edge_manifold) << name;
  EXPECT_TRUE(rep.vertex_manifold) << name << ": " << rep.nonmanifold_vertices << " non-manifold vertices";
  EXPECT_TRUE(rep.oriented) << name;
  EXPECT_EQ(rep.components, 1u) << name;
  ASSERT_TRUE(rep.genus.has_value()) << name;
  EXPECT_EQ(*rep.genus, 0) << name;
  EXPECT_EQ(rep.degenerate_triangles, 0u) << name;
  EXPECT_GT(rep.signed_volume, 0) << name;
  if (rep.self_intersections_checked) EXPECT_EQ(rep.self_intersecting_pairs, 0u) << name;
  EXPECT_LE(rep.fidelity_p95, 0.15) << name;
  EXPECT_EQ(rep.thick_nodes_inside, rep.thick_nodes) << name;
}

TEST(Pipeline, Fixtures) {
  const std::vector<Case> cases{{"straight_branch", test::straight_branch()}, {"y_fork", test::y_fork()},
                                {"y_fork_narrow", test::y_fork(10)},         {"y_fork_wide", test::y_fork(75)},
                                {"trifurcation", test::trifurcation()},      {"six_children", test::six_children()},
                                {"zero_length_edges", test::zero_length_edges()},
                                {"thick_child", test::thick_child()}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    expect_good(run_and_check(c.raw, true), c.name);
  }
}

TEST(Pipeline, GrownTrees) {
  for (std::uint64_t seed : {1, 2, 3}) {
    SCOPED_TRACE(seed);
    expect_good(run_and_check(test::grown_tree(seed), true), "grown " + std::to_string(seed));
  }
}

TEST(Pipeline, Samples) {
  const auto files = test::sample_skeletons();
  if (files.empty()) GTEST_SKIP() << "../shared/skeletons not found";
  for (const auto& f : files) {
    SCOPED_TRACE(f.filename().string());
    expect_good(run_and_check(read_skeleton(f), true), f.filename().string());
  }
}

TEST(Pipeline, DeterministicAcrossRuns) {
  PipelineResult a, b;
  run_and_check(test::grown_tree(4), false, &a);
  run_and_check(test::grown_tree(4), false, &b);
  ASSERT_EQ(a.mesh.mesh.positions.size(), b.mesh.mesh.positions.size());
  EXPECT_EQ(a.mesh.mesh.positions, b.mesh.mesh.positions);
  EXPECT_EQ(a.mesh.mesh.triangles, b.mesh.mesh.triangles);
}

TEST(Pipeline, ParamsJsonRoundTripAndStrictKeys) {
  PipelineParams p;
  p.particles.seed = 77;
  p.contours.slice_step = 0.3;
  p.skeleton.thick_child_policy = ThickChildPolicy::keep;
  const PipelineParams q = parse_params_json(params_to_json(p), "x.json");
  EXPECT_EQ(q.particles.seed, 77u);
  EXPECT_EQ(q.contours.slice_step, 0.3);
  EXPECT_EQ(q.skeleton.thick_child_policy, ThickChildPolicy::keep);
  EXPECT_THROW(parse_params_json(R"({"particles": {"sed": 3}})", "x.json"), InvalidInputError);
  EXPECT_THROW(parse_params_json(R"({"particle": {}})", "x.json"), InvalidInputError);
  EXPECT_THROW(parse_params_json(R"({"contours": {"slice_step": "big"}})", "x.json"), InvalidInputError);
  try {
    parse_params_json(R"({"particles": {"sed": 3}})", "cfg.json");
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("cfg.json: particles: unknown key \"sed\""), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace sm
