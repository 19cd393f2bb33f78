// Levels of detail (lod/lod.h): pruning keeps a valid tree, and every level of a grown tree and
// of the sample skeletons comes out of the pipeline closed, manifold and free of
// self-intersections, with fewer triangles level by level.

#include <gtest/gtest.h>

#include "lod/lod.h"
#include "meshcheck/checks.h"
#include "skeleton/io.h"
#include "tests/fixtures.h"

namespace sm {
namespace {

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

}  // namespace
}  // namespace sm
