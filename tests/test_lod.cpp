// Levels of detail (lod/lod.h): pruning keeps a valid tree, and every level of a grown tree and
// of the sample skeletons comes out closed, manifold and free of self-intersections, with fewer
// triangles level by level; the simplification a level falls back to (lod/simplify.h) keeps a
// clean mesh clean. The slow build (test_lod_slow) runs every level of every sample.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lod/lod.h"
#include "lod/simplify.h"
#include "meshcheck/checks.h"
#include "skeleton/io.h"
#include "tests/fixtures.h"
#include "tests/mesh_fixtures.h"

namespace sm {
namespace {

#ifndef STRANDMESH_LOD_SLOW_TESTS

TEST(Lod, PruningDropsThinSubtreesAndKeepsTheRest) {
  // Root r 1 -> a r 0.5 -> b r 0.05 -> c r 0.5 (beyond a thin node: dropped too); a -> d r 0.3.
  RawSkeleton raw;
  raw.add(10, -1, {0, 0, 0}, 1.0);
  raw.add(11, 10, {0, 0, 1}, 0.5);
  raw.add(12, 11, {0, 0, 2}, 0.05);
  raw.add(13, 12, {0, 0, 3}, 0.5);
  raw.add(14, 11, {1, 0, 1.5}, 0.3);
  std::size_t pruned = 0;
  const RawSkeleton p = prune_thin_branches(raw, 0.1, &pruned);
  EXPECT_EQ(pruned, 2u);
  EXPECT_EQ(p.id, (std::vector<std::int64_t>{10, 11, 14}));
  EXPECT_EQ(p.parent_id, (std::vector<std::int64_t>{-1, 10, 11}));
  // The root's first child stays whatever its radius, so that a tree keeps an edge.
  EXPECT_EQ(prune_thin_branches(raw, 10.0).size(), 2u);
  EXPECT_EQ(prune_thin_branches(raw, 0.0).size(), raw.size());
}

TEST(Simplify, KeepsAClosedMeshClosedAndRefusesEveryCrossing) {
  // A torus with a rod through its hole, 5 mm from the inner equator: collapses along the
  // inner equator cut its arc short by chords that would run through the rod.
  const Mesh rod = test::box({0.73, -0.02, -0.5}, {0.745, 0.02, 0.5});
  const Mesh mesh = test::merged(test::torus(1.0, 0.25, 48, 16), rod);
  ASSERT_EQ(check_mesh(mesh).self_intersecting_pairs, 0u);
  SimplifyStats st;
  const Mesh s = simplify_mesh(mesh, {.target_triangles = 120}, &st);
  EXPECT_LE(s.triangle_count(), 200u);
  EXPECT_LT(s.triangle_count(), mesh.triangle_count() / 4);
  EXPECT_GT(st.refused_intersection, 0u);  // the rule was needed, and kept
  EXPECT_EQ(st.pairs_after, 0u);
  const MeshCheckReport c = check_mesh(s);
  EXPECT_TRUE(c.closed && c.edge_manifold && c.vertex_manifold && c.oriented) << to_text(c);
  EXPECT_EQ(c.self_intersecting_pairs, 0u);
  EXPECT_EQ(c.genus, 1u);  // the torus keeps its hole, the rod stays a box
  EXPECT_EQ(c.components, 2u);
  // The kept vertices did not move: every position is one of the input's.
  for (const glm::dvec3& p : s.positions) {
    EXPECT_NE(std::find(mesh.positions.begin(), mesh.positions.end(), p), mesh.positions.end());
  }
}

TEST(Simplify, CarriesUvsAndBranchIdsAndStopsAtTheTarget) {
  const Mesh tube = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 16, 8, true, 7);
  SimplifyStats st;
  const Mesh s = simplify_mesh(tube, {.target_triangles = tube.triangle_count() / 2}, &st);
  EXPECT_LE(s.triangle_count(), tube.triangle_count() / 2);
  EXPECT_EQ(st.collapses * 2, tube.triangle_count() - s.triangle_count());
  ASSERT_EQ(s.corner_uvs.size(), s.triangle_count());
  ASSERT_EQ(s.triangle_branch.size(), s.triangle_count());
  EXPECT_EQ(s.normals.size(), tube.normals.empty() ? 0u : s.vertex_count());
  // On the side (u = angle / 2 pi, v = z), each corner keeps its vertex's v, and u changes
  // across a triangle as the angle does: no corner takes a UV from across the seam (u 1 -> 0).
  std::size_t side = 0;
  for (std::size_t f = 0; f < s.triangle_count(); ++f) {
    const auto& t = s.triangles[f];
    const glm::dvec3 n = glm::normalize(s.face_normal(t));
    if (std::abs(n.z) > 0.5) continue;  // a cap (planar UVs)
    ++side;
    for (int k = 0; k < 3; ++k) {
      const glm::dvec3 &a = s.positions[t[k]], &b = s.positions[t[(k + 1) % 3]];
      EXPECT_NEAR(s.corner_uvs[f][k].y, a.z, 1e-6);
      const double turn = std::remainder(std::atan2(b.y, b.x) - std::atan2(a.y, a.x), 2 * std::numbers::pi);
      EXPECT_NEAR(s.corner_uvs[f][(k + 1) % 3].x - s.corner_uvs[f][k].x, turn / (2 * std::numbers::pi), 1e-5);
    }
  }
  EXPECT_GT(side, 0u);
  EXPECT_TRUE(check_mesh(s).ok()) << to_text(check_mesh(s));
}

TEST(Lod, LevelsAreCoarserAndEachPassesTheChecks) {
  std::vector<std::pair<std::string, RawSkeleton>> trees{{"grown", test::grown_tree(3)}};
  for (const auto& path : test::sample_skeletons()) {
    if (path.filename() == "sapling_quaking_aspen.json") trees.emplace_back(path.filename().string(), read_skeleton(path));
  }
  for (const auto& [name, raw] : trees) {
    const PipelineParams params;
    std::size_t previous = run_pipeline(raw, params).mesh.mesh.triangle_count();
    for (std::uint32_t k = 1; k <= 3; ++k) {
      SCOPED_TRACE(name + " level " + std::to_string(k));
      LodLevel level;
      const PipelineResult r = mesh_lod(raw, params, k, {}, {}, &level);
      EXPECT_LE(level.skeleton.size(), raw.size());
      EXPECT_LT(level.params.particles.max_root_strands, params.particles.max_root_strands);
      const MeshCheckReport c = check_mesh(r.mesh.mesh);
      EXPECT_TRUE(c.closed && c.edge_manifold && c.vertex_manifold && c.oriented) << to_text(c);
      EXPECT_EQ(c.self_intersecting_pairs, 0u) << to_text(c);
      EXPECT_TRUE(c.ok()) << to_text(c);
      EXPECT_LT(r.mesh.mesh.triangle_count(), previous);
      previous = r.mesh.mesh.triangle_count();
    }
  }
}

#else  // STRANDMESH_LOD_SLOW_TESTS

// Every level of every sample, each level made from the one before where its own run keeps
// pairs (as `strandmesh mesh --lods 4` does): closed, manifold, oriented, no more pairs than its
// own run, and none where the finer level has none. (With the input as given by default, the
// full meshes of three samples keep crossings the repair could not fuse, issue 30; a level
// simplified from such a mesh keeps them.)
TEST(LodSlow, EveryLevelOfEverySamplePassesTheChecks) {
  for (const auto& path : test::sample_skeletons()) {
    const RawSkeleton raw = read_skeleton(path);
    const PipelineParams params;
    std::vector<PipelineResult> levels;
    levels.push_back(run_pipeline(raw, params));
    for (std::uint32_t k = 1; k <= 3; ++k) {
      SCOPED_TRACE(path.filename().string() + " level " + std::to_string(k));
      LodLevel level;
      levels.push_back(mesh_lod(raw, params, k, {}, {}, &level, &levels.back()));
      const Mesh& m = levels.back().mesh.mesh;
      const std::size_t finer_pairs = check_mesh(levels[k - 1].mesh.mesh).self_intersecting_pairs;
      const MeshCheckReport c = check_mesh(m);
      EXPECT_TRUE(c.closed && c.edge_manifold && c.vertex_manifold && c.oriented) << to_text(c);
      EXPECT_EQ(c.self_intersecting_pairs, level.pairs);
      EXPECT_LE(level.pairs, level.rerun_pairs);
      if (finer_pairs == 0) {
        EXPECT_EQ(level.pairs, 0u);
        EXPECT_TRUE(c.ok()) << to_text(c);
      }
      EXPECT_LT(m.triangle_count(), levels[k - 1].mesh.mesh.triangle_count());
      if (level.simplified) {
        EXPECT_GT(level.rerun_pairs, 0u);
      }
    }
  }
}

#endif  // STRANDMESH_LOD_SLOW_TESTS

}  // namespace
}  // namespace sm
