#pragma once
/// One add_<name>_command() per subcommand file; register_commands() adds them all.

#include <array>
#include <utility>

#include "apps/cli/cli.h"
#include "pipeline/pipeline.h"

namespace sm::cli {

void add_info_command(CLI::App& app, const GlobalOptions& global);
void add_grow_command(CLI::App& app, const GlobalOptions& global);
void add_check_command(CLI::App& app, const GlobalOptions& global);
void add_mesh_command(CLI::App& app, const GlobalOptions& global);
void add_bench_command(CLI::App& app, const GlobalOptions& global);
void add_particles_command(CLI::App& app, const GlobalOptions& global);
void add_batch_command(CLI::App& app, const GlobalOptions& global);
void add_params_command(CLI::App& app, const GlobalOptions& global);

/// The pipeline's stages in order, each with its phases' Timings where it has some (contours
/// meshing and repair), as `mesh` and `bench` print them.
std::array<std::pair<const char*, const Timings*>, 6> stage_phases(const PipelineResult& r);

/// Adds every subcommand in the order shown by --help.
void register_commands(CLI::App& app, const GlobalOptions& global);

}  // namespace sm::cli
