// strandmesh: command-line front end. Only composes the stage libraries.

#include <cstdio>
#include <exception>
#include <memory>
#include <thread>

#include <tbb/global_control.h>

#include "apps/cli/cli.h"
#include "apps/cli/commands.h"
#include "core/errors.h"
#include "core/huge_pages.h"
#include "core/log.h"

int main(int argc, char** argv) {
  sm::reexec_with_huge_pages(argv);  // see core/huge_pages.h
  sm::keep_freed_memory();
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

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kUsage;
  }

  sm::log::set_level(global.quiet ? sm::log::Level::quiet : global.verbose ? sm::log::Level::verbose : sm::log::Level::normal);
  if (sm::running_with_huge_pages()) sm::log::verbose("memory: transparent huge pages (glibc.malloc.hugetlb=1)");
  std::unique_ptr<tbb::global_control> threads;
  if (global.threads > 0) {
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<std::size_t>(global.threads));
  }
  const Action action = parsed_action();
  if (!action) return kUsage;
  try {
    return action();
  } catch (const sm::InvalidInputError& e) {
    sm::log::error(e.what());
    return kBadInput;
  } catch (const sm::IoError& e) {
    sm::log::error(e.what());
    return kBadInput;
  } catch (const sm::UsageError& e) {
    sm::log::error(e.what());
    return kUsage;
  } catch (const std::bad_alloc&) {
    sm::log::error("out of memory");
    return kInternal;
  } catch (const std::exception& e) {
    sm::log::error(std::string("internal error: ") + e.what());
    return kInternal;
  }
}
