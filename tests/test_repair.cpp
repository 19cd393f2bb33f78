// The repair stage and its self-union, on inputs built in code.

#include <gtest/gtest.h>

#include <numeric>

#include "fixtures.h"
#include "mesh_fixtures.h"
#include "meshcheck/checks.h"
#include "meshcheck/intersections.h"
#include "pipeline/pipeline.h"
#include "repair/repair.h"
#include "repair/self_union.h"
#include "skeleton/build.h"

namespace sm {
namespace {

std::vector<std::array<std::uint32_t, 2>> all_pairs(const Mesh& m) {
  std::vector<std::uint32_t> all(m.triangles.size());
  std::iota(all.begin(), all.end(), 0u);
  return TriangleIntersections(m).pairs(all);
}

TEST(SelfUnion, InterpenetratingBoxesBecomeTheirUnion) {
  // Two unit cubes overlapping in a cube of side 1/2: the union is one closed surface of
  // volume 2 - 1/8, with the eight corners of each cube inside the other gone.
  Mesh m = test::interpenetrating_boxes();
  const auto pairs = all_pairs(m);
  ASSERT_GT(pairs.size(), 0u);
  std::vector<std::uint32_t> origin;
  const SelfUnionStats st = self_union(m, pairs, 0.0, {}, origin);
  EXPECT_TRUE(st.problem.empty()) << st.problem;
  EXPECT_EQ(origin.size(), m.triangles.size());
  const MeshCheckReport r = check_mesh(m);
  EXPECT_TRUE(r.ok()) << to_text(r);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.self_intersecting_pairs, 0u);
  EXPECT_NEAR(r.signed_volume, 2.0 - 0.125, 1e-12);
}

TEST(SelfUnion, DisjointPartsAreLeftAsTheyAre) {
  // No pairs: nothing to do, the mesh and the identity origin come back.
  Mesh m = test::box();
  const Mesh before = m;
  std::vector<std::uint32_t> origin;
  const SelfUnionStats st = self_union(m, {}, 0.0, {}, origin);
  EXPECT_TRUE(st.problem.empty());
  EXPECT_EQ(m.triangles, before.triangles);
  ASSERT_EQ(origin.size(), m.triangles.size());
  for (std::uint32_t f = 0; f < origin.size(); ++f) EXPECT_EQ(origin[f], f);
}

TEST(Repair, CleanMeshIsUnchanged) {
  MeshResult r;
  r.mesh = test::icosphere(2);
  r.triangle_kind.assign(r.mesh.triangle_count(), TriangleKind::strip);
  const Mesh before = r.mesh;
  const RepairStats st = repair_mesh(r, test::built(test::straight_branch()));
  EXPECT_TRUE(st.counted);
  EXPECT_EQ(st.pairs_found, 0u);
  EXPECT_EQ(st.rounds, 0u);
  EXPECT_EQ(r.mesh.positions, before.positions);
  EXPECT_EQ(r.mesh.triangles, before.triangles);
}

TEST(Repair, CrossingBranchesFuseWhereTheyAreWithAHandle) {
  // Two laterals from different forks of a trunk cross each other away from their forks: with
  // the input kept (no separation), the mesh is their union, in place: closed, one part, no
  // self-intersections, and the loop trunk - lateral - crossing - lateral - trunk is a handle.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0, 0, 0), 0.08);
  raw.add(1, 0, dvec3(0, 0, 1.0), 0.07);
  raw.add(2, 1, dvec3(0, 0, 2.0), 0.06);
  raw.add(3, 2, dvec3(0, 0, 3.0), 0.05);
  raw.add(4, 1, dvec3(0.5, 0, 1.5), 0.035);   // rising lateral from z = 1
  raw.add(5, 4, dvec3(1.0, 0.0, 2.0), 0.03);
  raw.add(6, 2, dvec3(0.5, 0.05, 1.5), 0.035);  // falling lateral from z = 2, crossing it near x = 0.5
  raw.add(7, 6, dvec3(1.0, 0.1, 1.0), 0.03);
  PipelineParams p;
  p.skeleton.separate = false;
  p.skeleton.max_lateral_angle = 0;
  const PipelineResult r = run_pipeline(raw, p);
  // The skeleton is where the file put it.
  EXPECT_EQ(r.skeleton.report.max_move, 0.0);
  const MeshCheckReport rep = check_mesh(r.mesh.mesh);
  EXPECT_TRUE(rep.closed);
  EXPECT_TRUE(rep.edge_manifold);
  EXPECT_TRUE(rep.oriented);
  EXPECT_EQ(rep.components, 1u);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  EXPECT_GT(r.repair.pairs_found, 0u);
  EXPECT_EQ(r.repair.pairs_left, 0u);
  ASSERT_TRUE(rep.genus.has_value());
  EXPECT_EQ(*rep.genus, 1);
}

}  // namespace
}  // namespace sm
