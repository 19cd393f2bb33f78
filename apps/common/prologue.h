#pragma once
/// What both programs (strandmesh, strandmesh-view) do around their own options: the memory
/// set-up before anything runs, parsing with the exit codes it maps to, the log level and
/// thread limit, and the library's exceptions turned into one error line and an exit code.

#include <functional>
#include <memory>
#include <optional>

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

namespace sm::app {

/// Exit codes of both programs; 4 is strandmesh's failed check (check, mesh --strict) and
/// strandmesh-view's missing display or OpenGL 3.3.
enum ExitCode : int { kOk = 0, kBadInput = 1, kUsage = 2, kInternal = 3, kCheckFailed = 4 };

/// First thing in main(): re-executes with huge pages where that helps and keeps freed memory
/// for reuse (apps/common/huge_pages.h).
void start_process(char** argv);

/// Parses the command line. Returns the exit code to stop with (0 after printing --help or
/// --version, kUsage after printing a parse error), or nothing when the program goes on.
std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv);

/// Sets the log level (quiet wins over verbose) and, for `threads` > 0, limits oneTBB to that
/// many threads for as long as the returned object lives (empty when not limited).
std::unique_ptr<tbb::global_control> apply_common_options(int threads, bool quiet, bool verbose);

/// Runs `body` and returns its exit code; the library's exceptions become one error line and
/// an exit code: InvalidInputError and IoError kBadInput, UsageError kUsage, anything else
/// kInternal ("out of memory" for std::bad_alloc).
int run_reporting_errors(const std::function<int()>& body);

}  // namespace sm::app
