// Every sample skeleton at particle seeds 2 and 3 (seed 1 is Pipeline.Samples in the default
// label): the whole pipeline with the default parameters passes every check of
// `strandmesh check --skeleton`: one closed, oriented 2-manifold of genus 0, no degenerate
// triangles, no self-intersecting pair, fidelity p95 within the tolerance, every thick node
// inside. Label slow (ctest -L slow): 30 s on two cores, most of it the fork retry.

#include <gtest/gtest.h>

#include <string>

#include "fixtures.h"
#include "meshcheck/checks.h"
#include "pipeline/pipeline.h"
#include "skeleton/io.h"

namespace sm {
namespace {

TEST(SamplesSlow, EverySampleAtParticleSeedsTwoAndThreePassesEveryCheck) {
  const auto files = test::sample_skeletons();
  ASSERT_FALSE(files.empty()) << "tests/data/skeletons is empty";
  for (const auto& f : files) {
    const RawSkeleton raw = read_skeleton(f);
    for (const std::uint64_t seed : {2u, 3u}) {
      SCOPED_TRACE(f.filename().string() + " at particle seed " + std::to_string(seed));
      PipelineParams p;
      p.particles.seed = seed;
      const PipelineResult r = run_pipeline(raw, p);
      MeshCheckParams cp;
      cp.skeleton = &r.skeleton.skeleton;
      const MeshCheckReport rep = check_mesh(r.mesh.mesh, cp);
      std::string why;
      for (const auto& failure : rep.failures()) why += failure + "; ";
      EXPECT_TRUE(rep.ok()) << why;
      EXPECT_GT(rep.thick_nodes, 0u);
    }
  }
}

}  // namespace
}  // namespace sm
