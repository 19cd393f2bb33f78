// Growth time per grow preset (configs/grow/*.json), with the tree's size beside it:
//   bench_grow --benchmark_filter=large
// Each line reports nodes, forks, tips and height (metres) as counters and a label
// "large: 28240 nodes, 5843 forks, 14.0 m, trunk r 0.153 m".

#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "skeleton/grow/presets.h"
#include "skeleton/grow/tree_grower.h"

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
  state.counters["nodes_per_s"] = benchmark::Counter(double(stats.nodes), benchmark::Counter::kIsIterationInvariantRate);
  char label[160];
  std::snprintf(label, sizeof label, "%s: %zu nodes, %zu forks, %.1f m, trunk r %.3f m", preset.name.c_str(),
                stats.nodes, stats.forks, stats.height, stats.trunk_radius);
  state.SetLabel(label);
}

}  // namespace

int main(int argc, char** argv) {
  for (const auto& file : sm::list_grow_presets(std::filesystem::path(STRANDMESH_CONFIG_DIR) / "grow")) {
    benchmark::RegisterBenchmark(("grow/" + file.stem().string()).c_str(), grow_preset, file)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
