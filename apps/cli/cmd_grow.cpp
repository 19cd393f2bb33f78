// strandmesh grow: procedural skeletons from the built-in growers.
//
//   strandmesh grow --seed N -o tree.json                   the simple random grower (grow/random_grower.h)
//   strandmesh grow --preset NAME|FILE.json [--seed N] -o tree.json   self-organizing / space colonization
//   strandmesh grow --list-presets

#include <cstdio>
#include <memory>

#include "apps/cli/commands.h"
#include "apps/cli/skeleton_options.h"
#include "core/errors.h"
#include "core/file_io.h"
#include "core/log.h"
#include "grow/messy_grower.h"
#include "grow/presets.h"
#include "grow/random_grower.h"
#include "grow/tree_grower.h"
#include "skeleton/io.h"

#ifndef STRANDMESH_CONFIG_DIR
#define STRANDMESH_CONFIG_DIR "configs"
#endif

namespace sm::cli {
namespace {

std::filesystem::path preset_dir() {
  return std::filesystem::path(STRANDMESH_CONFIG_DIR) / "grow";
}

/// v with `digits` decimals.
std::string fmt(int digits, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

int list_presets() {
  const auto files = list_grow_presets(preset_dir());
  if (files.empty()) {
    log::warn("no presets found in " + preset_dir().string());
    return int(kOk);
  }
  for (const auto& f : files) {
    const GrowPreset p = load_grow_preset(f);
    std::string range = p.expected_max_nodes > 0 ? std::to_string(p.expected_min_nodes) + "-" +
                                                       std::to_string(p.expected_max_nodes) + " nodes"
                                                 : std::string("nodes: not documented");
    std::printf("%-14s %-18s %s\n", p.name.c_str(), range.c_str(), p.description.c_str());
  }
  return int(kOk);
}

}  // namespace

void add_grow_command(CLI::App& app, const GlobalOptions& global) {
  add_command(app, "grow", "Grow a procedural tree skeleton and write it as JSON", [&global](CLI::App& sub) -> Action {
    struct Opts {
      std::uint64_t seed = 1;
      std::string output;
      std::string preset;
      bool list = false;
      bool messy = false;
      std::vector<double> origin;
      CLI::Option* seed_option = nullptr;
    };
    auto o = std::make_shared<Opts>();
    o->seed_option = sub.add_option("--seed", o->seed,
                                    "Random seed (same seed, same skeleton); with --preset it overrides the preset's")
                         ->capture_default_str()
                         ->check(kNotNegative);
    sub.add_option("--preset", o->preset,
                   "Grow with a preset: a name from configs/grow (see --list-presets) or a path to a .json file");
    sub.add_flag("--messy", o->messy,
                 "Grow a messy test tree (grow/messy_grower.h): crossing and hanging limbs, zigzags, a hub, "
                 "hairpins, zero radii, children thicker than their parent");
    sub.add_option("--origin", o->origin, "With --messy: position of the root, X Y Z in metres (georeferenced)")
        ->expected(3);
    sub.add_flag("--list-presets", o->list, "List the grow presets with their node ranges and descriptions");
    sub.add_option("-o,--output", o->output, "Output skeleton file (.json), or - for standard output");
    return [o, &global] {
      if (o->list) return list_presets();
      if (o->output.empty()) throw UsageError("grow: -o FILE.json is required");
      if (o->output != "-") check_json_output(o->output, "-o");
      if (o->messy) {
        if (!o->preset.empty()) throw UsageError("grow: --messy and --preset exclude each other");
        MessyGrowParams params;
        params.seed = o->seed;
        if (!o->origin.empty()) params.origin = dvec3(o->origin[0], o->origin[1], o->origin[2]);
        const RawSkeleton raw = grow_messy(params);
        build_skeleton(raw);  // rejects what the mesher could not take, before writing
        write_output(o->output, raw_skeleton_to_json(raw));
        log::info("grew a messy tree of " + std::to_string(raw.size()) + " nodes (seed " + std::to_string(o->seed) +
                  ") -> " + o->output);
        return int(kOk);
      }
      if (!o->origin.empty()) throw UsageError("grow: --origin needs --messy");
      if (o->preset.empty()) {
        RandomGrowParams params;
        params.seed = o->seed;
        const RawSkeleton raw = grow_random(params);
        const SkeletonResult result = build_skeleton(raw);
        write_output(o->output, raw_skeleton_to_json(raw));
        log::info("grew " + std::to_string(raw.size()) + " nodes (seed " + std::to_string(o->seed) + ") -> " +
                  o->output);
        log::verbose(describe_skeleton(result));
        return int(kOk);
      }
      GrowPreset preset = load_grow_preset(find_grow_preset(o->preset, preset_dir()));
      if (o->seed_option->count() > 0) preset.params.seed = o->seed;
      GrowResult grown;
      {
        ProgressBar bar(!global.quiet);
        grown = grow_tree(preset.params, [&bar](std::string_view phase, double f) { bar.update(phase, f); });
      }
      const GrowStats& s = grown.stats;
      for (const auto& w : s.warnings.list()) log::warn(w.message);
      const SkeletonResult result = build_skeleton(grown.skeleton);
      write_output(o->output, raw_skeleton_to_json(grown.skeleton));
      log::info("grew " + std::to_string(s.nodes) + " nodes, " + std::to_string(s.forks) + " forks, " +
                std::to_string(s.tips) + " tips, height " + fmt(2, s.height) + " m, trunk radius " +
                fmt(3, s.trunk_radius) + " m (preset " + preset.name + ", seed " + std::to_string(preset.params.seed) +
                ") in " + fmt(2, s.timings.total()) + " s -> " + o->output);
      log::verbose("iterations " + std::to_string(s.iterations) + ", attraction points " +
                   std::to_string(s.attraction_points) + " (" + std::to_string(s.points_reached) + " reached), grown " +
                   std::to_string(s.grown_nodes) + " nodes, merged " + std::to_string(s.merged_nodes) + ", slid " +
                   std::to_string(s.slid_laterals) + " and pruned " + std::to_string(s.pruned_laterals) +
                   " laterals (" + std::to_string(s.pruned_nodes) + " nodes), short fork edges " +
                   std::to_string(s.short_edges) + ", touching twigs pruned " + std::to_string(s.collisions_pruned) +
                   " (" + std::to_string(s.collision_pruned_nodes) + " nodes), touching edge pairs left " +
                   std::to_string(s.touching_edges));
      for (const auto& t : s.timings.entries) log::verbose("  " + t.name + " " + fmt(3, t.seconds) + " s");
      log::verbose(describe_skeleton(result));
      return int(kOk);
    };
  });
}

}  // namespace sm::cli
