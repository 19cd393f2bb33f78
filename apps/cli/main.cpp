// strandmesh: command-line front end. Only composes the stage libraries.

#include <string>

#include "apps/cli/cli.h"
#include "apps/cli/commands.h"
#include "apps/common/prologue.h"

int main(int argc, char** argv) {
  sm::app::start_process(argv);
  using namespace sm::cli;
  CLI::App app{"strandmesh: watertight strand-based tree meshes (Interactive Invigoration method)", "strandmesh"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("strandmesh ") + STRANDMESH_VERSION);
  app.footer(
      "Exit codes: 0 ok, 1 bad input (malformed or unreadable file, invalid parameters),\n"
      "            2 usage error, 3 internal error, 4 the mesh fails a check (check, mesh --strict).\n"
      "Global options --threads N, -q/--quiet, -v/--verbose go before or after the command.\n"
      "Run 'strandmesh COMMAND --help' for the options of a command.");
  GlobalOptions global;
  app.add_option("--threads", global.threads, "Worker threads (default: all cores); output is identical for any count")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("-q,--quiet", global.quiet, "Print only errors");
  app.add_flag("-v,--verbose", global.verbose, "Print details and per-phase timings");
  // Global options are accepted after the subcommand too ("strandmesh grow ... -q").
  app.fallthrough();
  register_commands(app, global);

  if (const auto stop = sm::app::parse_command_line(app, argc, argv)) return *stop;
  const auto thread_limit = sm::app::apply_common_options(global.threads, global.quiet, global.verbose);
  const Action action = parsed_action();
  if (!action) return kUsage;
  return sm::app::run_reporting_errors(action);
}
