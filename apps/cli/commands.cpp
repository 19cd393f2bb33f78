#include "apps/cli/commands.h"

namespace sm::cli {

void register_commands(CLI::App& app, const GlobalOptions& global) {
  add_info_command(app, global);
  add_grow_command(app, global);
  add_particles_command(app, global);
  add_mesh_command(app, global);
  add_check_command(app, global);
  add_bench_command(app, global);
}

}  // namespace sm::cli
