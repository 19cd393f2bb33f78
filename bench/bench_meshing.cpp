// Contours and meshing throughput on the `large` grow preset, seed 1 (the tree `strandmesh
// bench` measures: 32,817 nodes, 1.66 M particles, 3.41 M triangles), each stage alone with
// its phases, the normals on their own, and the fork retry's cost on a sample skeleton.
//
// "particles" is the sum over nodes of the cloud sizes, as the paper counts them (its
// Fig. 9a tree: 564,632 particles meshed in 2.75 s, about 200k particles/s).
//   build/bench/bench_meshing [--benchmark_filter=...]

#include <benchmark/benchmark.h>

#include <filesystem>

#include <tbb/global_control.h>

#include "contours/contours.h"
#include "apps/common/huge_pages.h"
#include "core/mesh.h"
#include "meshcheck/checks.h"
#include "meshing/meshing.h"
#include "pipeline/pipeline.h"
#include "grow/presets.h"
#include "grow/tree_grower.h"
#include "skeleton/io.h"

namespace {

using namespace sm;

/// The pipeline up to the mesh, once, on the large preset with the default parameters.
const PipelineResult& tree() {
  static const PipelineResult r = [] {
    GrowPreset preset = load_grow_preset(std::filesystem::path(STRANDMESH_CONFIG_DIR) / "grow" / "large.json");
    preset.params.seed = 1;
    return run_pipeline(grow_tree(preset.params).skeleton, PipelineParams{});
  }();
  return r;
}

void rate(benchmark::State& state, double per_iteration, const char* name) {
  state.counters[name] = benchmark::Counter(per_iteration * double(state.iterations()), benchmark::Counter::kIsRate);
}

/// Each phase's seconds per iteration (summed over the iterations in `sum`).
void add_phases(Timings& sum, const Timings& run) {
  for (const auto& e : run.entries) sum.add(e.name, e.seconds);
}
void report_phases(benchmark::State& state, const Timings& sum) {
  for (const auto& e : sum.entries) state.counters[e.name + "_s"] = e.seconds / double(state.iterations());
}

/// compute_contours: slicing, split detection and boundary loops (with the seconds of each phase).
void BM_Contours(benchmark::State& state) {
  const PipelineResult& r = tree();
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
  Timings phases;
  for (auto _ : state) {
    ContourSet c = compute_contours(r.skeleton.skeleton, r.particles, r.strands);
    benchmark::DoNotOptimize(c.point.data());
    add_phases(phases, c.stats.timings);
  }
  report_phases(state, phases);
  rate(state, double(r.particles.stats.particles), "particles_per_s");
}
BENCHMARK(BM_Contours)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

/// The meshing stage and the repair stage's first step, as on a tree over count_pairs_up_to:
/// stitching, fusion, caps, the fold repair near the forks, normals, UVs and the topology
/// check (with the seconds of each phase).
void BM_Mesh(benchmark::State& state) {
  const PipelineResult& r = tree();
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
  RepairParams params;
  params.fork_retry = false;  // not run above 300,000 triangles anyway
  std::size_t triangles = 0;
  Timings phases;
  for (auto _ : state) {
    StitchedMesh stitched = stitch_mesh(r.skeleton.skeleton, r.contours);
    Stopwatch clock;
    Crossings crossings;
    Warnings warnings;
    repair_junction_folds(stitched, r.skeleton.skeleton, r.contours, params, crossings, warnings);
    const double folds = clock.lap();
    MeshResult m = finish_mesh(std::move(stitched));
    m.stats.timings.add("fold_repair", folds);
    triangles = m.mesh.triangles.size();
    benchmark::DoNotOptimize(m.mesh.triangles.data());
    add_phases(phases, m.stats.timings);
  }
  report_phases(state, phases);
  state.counters["triangles"] = double(triangles);
  rate(state, double(r.particles.stats.particles), "particles_per_s");
  rate(state, double(triangles), "triangles_per_s");
}
BENCHMARK(BM_Mesh)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

/// angle_weighted_normals on the finished mesh.
void BM_Normals(benchmark::State& state) {
  const Mesh& mesh = tree().mesh.mesh;
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
  for (auto _ : state) {
    std::vector<glm::dvec3> n = angle_weighted_normals(mesh);
    benchmark::DoNotOptimize(n.data());
  }
  rate(state, double(mesh.positions.size()), "vertices_per_s");
}
BENCHMARK(BM_Normals)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

/// inside_closed_mesh for every thick node of the tree (the near misses' test, which every
/// mesh pays).
void BM_ThickNodesInside(benchmark::State& state) {
  const PipelineResult& r = tree();
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
  std::vector<glm::dvec3> at;
  for (const std::uint32_t n : thick_node_ids(r.skeleton.skeleton)) at.push_back(r.skeleton.skeleton.position[n]);
  for (auto _ : state) {
    std::vector<std::uint8_t> inside = inside_closed_mesh(r.mesh.mesh, at);
    benchmark::DoNotOptimize(inside.data());
  }
  rate(state, double(r.mesh.mesh.triangles.size()), "triangles_per_s");
}
BENCHMARK(BM_ThickNodesInside)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

/// The whole pipeline on a sample skeleton where the fork retry runs (small_pine: 20 pairs
/// before, 2 after, 0 after the outer surface; 10 more runs of contours and meshing), against
/// the same run without it.
/// The sample comes from tests/data/skeletons.
void BM_ForkRetry(benchmark::State& state) {
  const std::filesystem::path path = std::filesystem::path(STRANDMESH_SAMPLE_DIR) / "sapling_small_pine.json";
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("sample skeleton not found");
    return;
  }
  static const RawSkeleton raw = read_skeleton(path);
  PipelineParams params;
  params.repair.fork_retry = state.range(0) != 0;
  ForkRetryStats retry;
  for (auto _ : state) {
    const PipelineResult r = run_pipeline(raw, params);
    retry = r.repair.fork_retry;
    benchmark::DoNotOptimize(r.mesh.mesh.triangles.data());
  }
  if (retry.runs > 0) {
    state.counters["pairs_before"] = double(retry.pairs_before);
    state.counters["pairs_after"] = double(retry.pairs_after);
    state.counters["runs"] = double(retry.runs);
  }
}
BENCHMARK(BM_ForkRetry)->ArgName("retry")->Arg(0)->Arg(1)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  sm::keep_freed_memory();  // as the command line does (apps/common/huge_pages.h)
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
