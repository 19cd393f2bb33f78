#pragma once
/// One add_<name>_command() per subcommand file; register_commands() adds them all.

#include "apps/cli/cli.h"

namespace sm::cli {

void add_info_command(CLI::App& app, const GlobalOptions& global);
void add_grow_command(CLI::App& app, const GlobalOptions& global);
void add_check_command(CLI::App& app, const GlobalOptions& global);
void add_mesh_command(CLI::App& app, const GlobalOptions& global);
void add_bench_command(CLI::App& app, const GlobalOptions& global);
void add_particles_command(CLI::App& app, const GlobalOptions& global);

/// Adds every subcommand in the order shown by --help.
void register_commands(CLI::App& app, const GlobalOptions& global);

}  // namespace sm::cli
