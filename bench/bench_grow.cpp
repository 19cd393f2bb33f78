// Growth time per grow preset (configs/grow/*.json), with the tree's size beside it:
//   bench_grow --benchmark_filter=large
// Each line reports nodes, forks, tips and height (metres) as counters and a label
// "large: 28240 nodes, 5843 forks, 14.0 m, trunk r 0.153 m".
// Also sanitizing (build_skeleton) of a tall zigzag chain, whose edges all share one x range
// (the branch separation's sweep once ran along x and was quadratic there):
//   bench_grow --benchmark_filter=sanitize

#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "skeleton/build.h"
#include "grow/presets.h"
#include "grow/tree_grower.h"

namespace {

void grow_preset(benchmark::State& state, const std::filesystem::path& file) {
  const sm::GrowPreset preset = sm::load_grow_preset(file);
  sm::GrowStats stats;
  for (auto _ : state) {
    sm::GrowResult result = sm::grow_tree(preset.params);
    benchmark::DoNotOptimize(result.skeleton.position.data());
    stats = result.stats;
  }
  state.counters["nodes"] = double(stats.nodes);
  state.counters["forks"] = double(stats.forks);
  state.counters["tips"] = double(stats.tips);
  state.counters["height_m"] = stats.height;
  state.counters["nodes_per_s"] =
      benchmark::Counter(double(stats.nodes), benchmark::Counter::kIsIterationInvariantRate);
  char label[160];
  std::snprintf(label, sizeof label, "%s: %zu nodes, %zu forks, %.1f m, trunk r %.3f m", preset.name.c_str(),
                stats.nodes, stats.forks, stats.height, stats.trunk_radius);
  state.SetLabel(label);
}

/// A vertical chain of `state.range(0)` nodes zigzagging 1 cm sideways every 4 mm (radius 3 mm):
/// every node is a hairpin or a tight bend, and every edge overlaps every other in x.
void sanitize_tall_zigzag(benchmark::State& state) {
  const auto n = static_cast<std::int64_t>(state.range(0));
  sm::RawSkeleton raw;
  for (std::int64_t i = 0; i < n; ++i) raw.add(i, i - 1, sm::dvec3(0.01 * double(i % 2), 0, 0.004 * double(i)), 0.003);
  std::size_t nodes = 0;
  for (auto _ : state) {
    const sm::SkeletonResult result = sm::build_skeleton(raw);
    nodes = result.skeleton.size();
    benchmark::DoNotOptimize(result.skeleton.position.data());
  }
  state.counters["nodes_out"] = double(nodes);
  state.counters["nodes_per_s"] = benchmark::Counter(double(n), benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

int main(int argc, char** argv) {
  for (const auto& file : sm::list_grow_presets(std::filesystem::path(STRANDMESH_CONFIG_DIR) / "grow")) {
    benchmark::RegisterBenchmark(("grow/" + file.stem().string()).c_str(), grow_preset, file)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
  benchmark::RegisterBenchmark("sanitize/tall_zigzag", sanitize_tall_zigzag)
      ->Arg(20'000)
      ->Arg(200'000)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
