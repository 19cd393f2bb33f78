#pragma once
/// Shared pieces of the strandmesh command-line tool. Each subcommand lives in its own
/// cmd_<name>.cpp and registers itself with add_<name>_command().
///
/// Exit codes: 0 ok, 1 bad input (malformed file, invalid parameters, unreadable or
/// unwritable file), 2 usage error (unknown option, missing argument), 3 internal error,
/// 4 the mesh fails a check (`check`, `mesh --strict`); `batch`: 5 some trees failed, 6 all did.

#include <functional>
#include <optional>
#include <set>
#include <string>

#include <CLI/CLI.hpp>

#include "apps/common/prologue.h"
#include "core/progress.h"
#include "core/report.h"

namespace sm::cli {

using app::ExitCode;  // apps/common/prologue.h: kOk, kBadInput, kUsage, kInternal, kCheckFailed
using app::kBadInput;
using app::kCheckFailed;
using app::kInternal;
using app::kOk;
using app::kUsage;

struct GlobalOptions {
  int threads = 0;  ///< 0 = all cores
  bool quiet = false;
  bool verbose = false;
};

/// Validator of an unsigned integer option: CLI11 would take "-1" as 2^64 - 1 (or 2^32 - 1).
inline const CLI::Validator kNotNegative(
    [](std::string& s) { return s.find('-') == std::string::npos ? std::string() : "must not be negative, got " + s; },
    "NON-NEGATIVE");

/// The action a subcommand runs once parsing is done; returns the exit code.
using Action = std::function<int()>;

/// Registers a subcommand. `setup` adds the options to `sub` and returns the action, which
/// main() runs after parsing when that subcommand was chosen.
void add_command(CLI::App& app, const std::string& name, const std::string& description,
                 const std::function<Action(CLI::App& sub)>& setup);

/// The action of the subcommand that was parsed, or an empty function when none was.
Action parsed_action();

/// A subcommand that exists in the interface but not yet in the code: it fails with
/// "not yet available" and exit code 2.
void add_unavailable_command(CLI::App& app, const std::string& name, const std::string& description);

/// With --verbose: a stage's phases (its Timings), one indented line each, as `mesh` and
/// `bench` print them under the stage's own line.
void verbose_phases(const Timings& phases);

/// Writes `bytes` to the file `path` atomically, or to standard output when `path` is "-".
void write_output(const std::string& path, std::string_view bytes);

/// Warning kinds the built-in growers' trees have on purpose (twig tips thinner than one
/// particle spacing): for a grown skeleton they are listed only with --verbose.
extern const std::set<std::string> kExpectedOfGrownTrees;

/// Prints warnings grouped by kind, one line each: "MESSAGE (N×; e.g. A, B, C)"; with
/// `verbose` every kept place follows on its own line. Kinds in `expected` go to --verbose only.
void print_warnings(const Warnings& warnings, bool verbose, const std::set<std::string>& expected = {});

/// A progress bar on stderr (only when stderr is a terminal, and not --quiet): the phase's
/// full name, a bar that only moves forward, the percentage and, once a run has taken a few
/// seconds, an estimate of the time left. With `overall`, the bar shows the whole run (the
/// phases weighted by OverallProgress); without, each phase's own fraction.
class ProgressBar {
 public:
  explicit ProgressBar(bool enabled, std::optional<OverallProgress> overall = std::nullopt);
  ~ProgressBar();
  void update(std::string_view phase, double fraction);
  void finish();
  /// The line update() draws for `phase` at `fraction` after `seconds` (tested without a terminal).
  static std::string line(std::string_view phase, double fraction, double seconds);

 private:
  bool enabled_;
  std::optional<OverallProgress> overall_;
  Stopwatch clock_;
  bool drawn_ = false;
  std::string phase_;
  double shown_ = 0;       // fraction of the current phase (or the run) shown, never decreasing
  int last_permille_ = -1;
  int last_second_ = -1;
  std::size_t width_ = 0;  // characters of the longest line drawn, to clear it
};

}  // namespace sm::cli
