#include "apps/cli/commands.h"

namespace sm::cli {

std::array<std::pair<const char*, const Timings*>, 6> stage_phases(const PipelineResult& r) {
  return {{{"skeleton", nullptr},
           {"particles", nullptr},
           {"strands", nullptr},
           {"contours", &r.contours.stats.timings},
           {"meshing", &r.mesh.stats.timings},
           {"repair", &r.repair.timings}}};
}

void register_commands(CLI::App& app, const GlobalOptions& global) {
  add_info_command(app, global);
  add_grow_command(app, global);
  add_particles_command(app, global);
  add_mesh_command(app, global);
  add_batch_command(app, global);
  add_check_command(app, global);
  add_bench_command(app, global);
  add_params_command(app, global);
}

}  // namespace sm::cli
