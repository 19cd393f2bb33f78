#pragma once
/// Command-line options that say how to read a skeleton file: --format, --columns, --units.

#include <memory>
#include <string>

#include "apps/cli/cli.h"
#include "skeleton/io.h"

namespace sm::cli {

/// The options as typed; read_options() checks and converts them.
struct InputOptions {
  std::string format = "auto";
  std::string columns;  ///< "FIELD=NAME,..."
  std::string units;    ///< "LENGTH[,THICKNESS]"
};

/// Adds --format, --columns and --units to `sub`.
void add_input_options(CLI::App& sub, InputOptions& options);

/// The ReadOptions of the typed options. Throws UsageError for a bad value.
ReadOptions read_options(const InputOptions& options);

/// Reads the skeleton named on the command line: a file, or "-" for standard input (JSON or
/// SWC, by --format or by content: JSON starts with '{'). Throws like read_skeleton().
RawSkeleton read_skeleton_arg(const std::string& path, const ReadOptions& options);

}  // namespace sm::cli
