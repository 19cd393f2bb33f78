#include "apps/cli/commands.h"

namespace sm::cli {

void register_commands(CLI::App& app, const GlobalOptions& global) {
  add_info_command(app, global);
  add_grow_command(app, global);
  add_particles_command(app, global);
  add_unavailable_command(app, "mesh", "Mesh a skeleton: strandmesh mesh SKELETON -o OUT.glb");
  add_check_command(app, global);
  add_unavailable_command(app, "bench", "Benchmark the pipeline on grown trees");
}

}  // namespace sm::cli
