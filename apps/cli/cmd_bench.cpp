// strandmesh bench: the pipeline on grown (or given) trees, with time and quality side by side.
//
//   strandmesh bench                         the large preset (20k-40k nodes), seed 1
//   strandmesh bench --preset broadleaf --seed 3 --repeat 3 --check
//   strandmesh bench --skeleton tree.json --json bench.json

#include <algorithm>
#include <cstdio>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "apps/cli/commands.h"
#include "core/errors.h"
#include "core/file_io.h"
#include "core/log.h"
#include "meshcheck/checks.h"
#include "pipeline/pipeline.h"
#include "grow/presets.h"
#include "grow/tree_grower.h"
#include "skeleton/io.h"

#ifndef STRANDMESH_CONFIG_DIR
#define STRANDMESH_CONFIG_DIR "configs"
#endif

namespace sm::cli {

void add_bench_command(CLI::App& app, const GlobalOptions& global) {
  add_command(app, "bench", "Benchmark the pipeline on a grown tree (or a skeleton file)", [&global](CLI::App& sub) -> Action {
    struct Opts {
      std::string preset = "large", skeleton, config, json_path;
      std::uint64_t seed = 1;
      int repeat = 1;
      bool check = false;
    };
    auto o = std::make_shared<Opts>();
    sub.add_option("--preset", o->preset, "Grower preset to grow the tree with (see grow --list-presets)")->capture_default_str();
    sub.add_option("--seed", o->seed, "Grower seed")->capture_default_str();
    sub.add_option("--skeleton", o->skeleton, "Benchmark this skeleton file instead of a grown tree");
    sub.add_option("--config", o->config, "Pipeline parameter file");
    sub.add_option("--repeat", o->repeat, "Runs, each reusing the memory of the one before; the fastest is reported")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    sub.add_flag("--check", o->check, "Also check the mesh (closed, manifold, genus, self-intersections, fidelity)");
    sub.add_option("--json", o->json_path, "Write the figures as JSON to this file");
    return [o, &global] {
      if (!o->json_path.empty()) {
        if (extension_of(o->json_path) != "json") throw InvalidInputError(o->json_path + ": --json writes JSON; name it .json");
        check_output_path(o->json_path);
      }
      RawSkeleton raw;
      std::string name;
      if (!o->skeleton.empty()) {
        raw = read_skeleton(o->skeleton);
        name = o->skeleton;
      } else {
        GrowPreset preset = load_grow_preset(find_grow_preset(o->preset, std::filesystem::path(STRANDMESH_CONFIG_DIR) / "grow"));
        preset.params.seed = o->seed;
        Stopwatch grow_clock;
        raw = grow_tree(preset.params).skeleton;
        name = preset.name + " seed " + std::to_string(o->seed);
        log::verbose("grew " + std::to_string(raw.size()) + " nodes in " + std::to_string(grow_clock.elapsed()) + " s");
      }
      const PipelineParams params = o->config.empty() ? PipelineParams{} : load_params(o->config);
      // What the report needs of the fastest run. Each run is released before the next, whose
      // stages then reuse its memory (as in a long-lived process; touching fresh memory is
      // slow on some machines, see README): the repeats time the pipeline warm. The runs give
      // the same mesh (the pipeline is deterministic), so --check checks the first.
      struct Summary {
        Timings timings;
        std::vector<std::pair<const char*, std::optional<Timings>>> phases;
        std::size_t nodes = 0, strands = 0;
        double particles = 0, triangles = 0;
        std::string stats_json;
      };
      std::optional<Summary> best;
      std::string quality = "not checked";
      nlohmann::json check_json;
      for (int k = 0; k < o->repeat; ++k) {
        const PipelineResult r = run_pipeline(raw, params);
        if (k == 0 && o->check) {
          MeshCheckParams cp;
          cp.skeleton = &r.skeleton.skeleton;
          const MeshCheckReport rep = check_mesh(r.mesh.mesh, cp);
          char q[256];
          std::snprintf(
              q, sizeof q, "%s, genus %s, %zu self-intersections, fidelity p95 %.3f",
              rep.closed && rep.edge_manifold && rep.vertex_manifold && rep.oriented ? "watertight" : "NOT watertight",
              rep.genus ? std::to_string(*rep.genus).c_str() : "?", rep.self_intersecting_pairs, rep.fidelity_p95);
          quality = q;
          check_json = to_json(rep);
        }
        if (best && r.timings.total() >= best->timings.total()) continue;
        Summary sum{r.timings,
                    {},
                    r.skeleton.skeleton.size(),
                    r.particles.strand_count(),
                    double(r.particles.position.size()),
                    double(r.mesh.mesh.triangle_count()),
                    stats_to_json(r)};
        for (const auto& [stage, phases] : stage_phases(r))
          sum.phases.emplace_back(stage, phases ? std::optional<Timings>(*phases) : std::nullopt);
        best = std::move(sum);
      }
      const auto& t = best->timings;
      const double particles = best->particles;
      const double tris = best->triangles;
      const double mesh_s = t.get("strands") + t.get("contours") + t.get("meshing") + t.get("repair");
      const unsigned threads =
          global.threads > 0 ? unsigned(global.threads) : std::max(1u, std::thread::hardware_concurrency());
      std::printf("%s: %zu nodes, %zu strands, %.0f particles => %.0f triangles (%s) in %.2f s on %u threads\n",
                  name.c_str(), best->nodes, best->strands, particles, tris, quality.c_str(), t.total(), threads);
      // Per stage, and (with --verbose, on stderr) the phases of contours, meshing and repair under them.
      for (const auto& [stage, phases] : best->phases) {
        std::printf("  %-10s %8.3f s\n", stage, t.get(stage));
        std::fflush(stdout);
        if (phases) verbose_phases(*phases);
      }
      const double relaxation_rate = particles / std::max(t.get("particles"), 1e-9);
      std::printf("  relaxation %10.0f particles/s (paper: ~170,000)\n", relaxation_rate);
      // The paper meshes its Fig. 9a tree, 564,632 particles, in 2.75 s.
      constexpr double kPaperMeshing = 564'632.0 / 2.75;
      const double meshing_rate = particles / std::max(mesh_s, 1e-9), triangle_rate = tris / std::max(mesh_s, 1e-9);
      std::printf(
          "  meshing    %10.0f particles/s (paper: ~200,000), %.0f triangles/s (strands to repair)\n",
          meshing_rate, triangle_rate);
      std::printf("             %.1f x the paper's %.0f particles/s (564,632 particles in 2.75 s)\n",
                  meshing_rate / kPaperMeshing, kPaperMeshing);
      if (!o->json_path.empty()) {
        nlohmann::json j = nlohmann::json::parse(best->stats_json);
        j["name"] = name;
        j["threads"] = threads;
        j["relaxation_particles_per_second"] = relaxation_rate;
        j["meshing_particles_per_second"] = meshing_rate;
        j["meshing_times_paper"] = meshing_rate / kPaperMeshing;
        j["triangles_per_second"] = triangle_rate;
        if (o->check) j["check"] = check_json;
        write_file_atomically(o->json_path, j.dump(2) + "\n");
      }
      return int(kOk);
    };
  });
}

}  // namespace sm::cli
