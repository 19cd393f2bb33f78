// Every sample skeleton at particle seeds 2 and 3 (seed 1 is Pipeline.Samples... in the default
// label): the whole pipeline with the default parameters, checked as `strandmesh check
// --skeleton FILE` checks, against the skeleton as the file gives it: one closed, oriented
// 2-manifold in one piece, and pairs, fidelity p95 and thick nodes outside within regression
// bounds (the figures of 2026-11-29, pairs and nodes exact, p95 with a margin; issue 30's goal
// is no pair and every thick node inside, which these seeds do not meet yet: callistemon,
// small_pine and agraf at seed 3 keep pairs). Label slow (ctest -L slow).

#include <gtest/gtest.h>

#include <array>
#include <map>
#include <string>
#include <tuple>

#include "fixtures.h"
#include "meshcheck/checks.h"
#include "pipeline/pipeline.h"
#include "tests/sample_checks.h"
#include "skeleton/build.h"
#include "skeleton/io.h"

namespace sm {
namespace {

TEST(SamplesSlow, EverySampleAtParticleSeedsTwoAndThreeWithinItsBounds) {
  const auto files = test::sample_skeletons();
  ASSERT_FALSE(files.empty()) << "tests/data/skeletons is empty";
  // (pairs, fidelity p95, thick nodes outside) at seed 2 and at seed 3
  using Bound = std::tuple<std::size_t, double, std::size_t>;
  const std::map<std::string, std::array<Bound, 2>> bounds{
      {"mtg_agraf.json", {Bound{0, 0.085, 2}, Bound{8, 0.11, 5}}},
      {"mtg_boutdenoylum2.json", {Bound{0, 0.11, 0}, Bound{0, 0.11, 0}}},
      {"qsm_simpleforest_rtwig.json", {Bound{0, 0.095, 0}, Bound{0, 0.095, 0}}},
      {"sapling_callistemon.json", {Bound{6, 0.09, 2}, Bound{21, 0.09, 0}}},
      {"sapling_quaking_aspen.json", {Bound{0, 0.058, 0}, Bound{0, 0.055, 0}}},
      {"sapling_small_pine.json", {Bound{116, 0.1, 6}, Bound{42, 0.115, 10}}}};
  for (const auto& f : files) {
    const RawSkeleton raw = read_skeleton(f);
    for (const std::uint64_t seed : {2u, 3u}) {
      SCOPED_TRACE(f.filename().string() + " at particle seed " + std::to_string(seed));
      PipelineParams p;
      p.particles.seed = seed;
      const MeshCheckReport rep = test::mesh_and_check_against_input(raw, p);
      test::expect_one_sound_piece(rep);
      const auto it = bounds.find(f.filename().string());
      if (it == bounds.end()) continue;  // a sample added later: at least a sound surface
      const auto& [pairs, p95, outside] = it->second[seed - 2];
      test::expect_within(rep, pairs, p95, outside);
    }
  }
}

}  // namespace
}  // namespace sm
