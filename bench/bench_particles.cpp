// Particle relaxation throughput (particles stage) and strand building, on a grown tree of
// more than 20,000 nodes, with the quality figures beside the time.
//
// "particles" is the sum over nodes of the cloud sizes, as the paper counts them (its Fig. 9a
// tree: 21,345 nodes, 6,240 strands, 564,632 particles in 3.38 s, about 170k particles/s).
//   build-particles/bench/bench_particles [--benchmark_filter=...]

#include <benchmark/benchmark.h>

#include <cstdio>

#include <tbb/global_control.h>

#include "particles/particles.h"
#include "particles/quality.h"
#include "skeleton/build.h"
#include "grow/random_grower.h"
#include "strands/strands.h"

namespace {

using namespace sm;

/// The benchmark tree: the random grower with a thick trunk and thin twigs, seed 1 (20,605
/// grown nodes and 6,423 tips; 26,105 nodes once the skeleton stage has added its collar
/// nodes).
const Skeleton& tree() {
  static const Skeleton sk = [] {
    RandomGrowParams gp;
    gp.trunk_radius = 0.4;
    gp.min_radius = 0.0025;
    gp.max_nodes = 400'000;
    return build_skeleton(grow_random(gp)).skeleton;
  }();
  return sk;
}

void report_quality(benchmark::State& state, const Skeleton& sk, const ParticleField& f) {
  const ParticleQuality q = measure_particles(sk, f, {.holes = false});
  state.counters["min_pair"] = q.min_pair;
  state.counters["loss_pct"] = 100.0 * q.loss_fraction();
}

/// compute_particles with state.range(0) threads (default parameters).
void BM_Particles(benchmark::State& state) {
  const Skeleton& sk = tree();
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
  ParticleField f;
  double relax_cpu = 0, place_cpu = 0;
  for (auto _ : state) {
    f = compute_particles(sk);
    benchmark::DoNotOptimize(f.position.data());
    relax_cpu += f.stats.timings.get("relaxation_cpu");
    place_cpu += f.stats.timings.get("placement_cpu");
  }
  const double it = double(state.iterations());
  state.counters["nodes"] = double(f.stats.nodes);
  state.counters["strands"] = double(f.stats.strands);
  state.counters["particles"] = double(f.stats.particles);
  state.counters["relaxed"] = double(f.stats.relaxed_particles);
  state.counters["steps"] = double(f.stats.relaxation_steps);
  state.counters["particles_per_s"] =
      benchmark::Counter(double(f.stats.particles) * it, benchmark::Counter::kIsRate);
  state.counters["relax_cpu_s"] = relax_cpu / it;
  state.counters["place_cpu_s"] = place_cpu / it;
  report_quality(state, sk, f);
}
BENCHMARK(BM_Particles)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond)->MinTime(2.0);

/// The same tree with a finer spacing: the root carries 60,000 strands (new strands start
/// along the trunk and the big branches; about 1.1 M particles).
void BM_ParticlesFine(benchmark::State& state) {
  const Skeleton& sk = tree();
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
  ParticleField f;
  for (auto _ : state) {
    f = compute_particles(sk, {.root_strands = 60'000});
    benchmark::DoNotOptimize(f.position.data());
  }
  state.counters["strands"] = double(f.stats.strands);
  state.counters["particles"] = double(f.stats.particles);
  state.counters["particles_per_s"] =
      benchmark::Counter(double(f.stats.particles) * double(state.iterations()), benchmark::Counter::kIsRate);
  report_quality(state, sk, f);
}
BENCHMARK(BM_ParticlesFine)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond)->MinTime(2.0);

/// build_strands on the default field (points and Catmull-Rom tangents of every particle).
void BM_Strands(benchmark::State& state) {
  const Skeleton& sk = tree();
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
  static const ParticleField f = compute_particles(sk);
  for (auto _ : state) {
    StrandSet st = build_strands(sk, f);
    benchmark::DoNotOptimize(st.point.data());
  }
  state.counters["particles_per_s"] =
      benchmark::Counter(double(f.position.size()) * double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Strands)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
