// strandmesh grow: procedural skeletons from the built-in growers.

#include <cstdio>

#include "apps/cli/commands.h"
#include "apps/cli/skeleton_options.h"
#include "core/file_io.h"
#include "core/log.h"
#include "skeleton/grow/random_grower.h"
#include "skeleton/io.h"

namespace sm::cli {

void add_grow_command(CLI::App& app, const GlobalOptions&) {
  add_command(app, "grow", "Grow a procedural tree skeleton and write it as JSON", [](CLI::App& sub) -> Action {
    struct Opts {
      std::uint64_t seed = 1;
      std::string output;
    };
    auto o = std::make_shared<Opts>();
    sub.add_option("--seed", o->seed, "Random seed (same seed, same skeleton)")->capture_default_str();
    sub.add_option("-o,--output", o->output, "Output skeleton file (.json)")->required();
    return [o] {
      RandomGrowParams params;
      params.seed = o->seed;
      const RawSkeleton raw = grow_random(params);
      const SkeletonResult result = build_skeleton(raw);
      write_file_atomically(o->output, raw_skeleton_to_json(raw));
      log::info("grew " + std::to_string(raw.size()) + " nodes (seed " + std::to_string(o->seed) + ") -> " + o->output);
      log::verbose(describe_skeleton(result));
      return int(kOk);
    };
  });
}

}  // namespace sm::cli
