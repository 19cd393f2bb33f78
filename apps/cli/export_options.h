#pragma once
/// Command-line options of the mesh writers (meshio/export.h), shared by the commands that
/// write meshes. Each overrides the config file's `export` section only when given.

#include <string>

#include "apps/cli/cli.h"
#include "meshio/export.h"

namespace sm::cli {

/// The export options as given on the command line (empty: not given).
struct ExportOptions {
  std::string up_axis, pivot, scale, attributes, compress;
  bool no_optimize = false, quantize = false, lod_files = false;
  std::uint32_t lods = 0;  ///< 0: not given
};

/// Adds --up-axis, --pivot, --scale, --attributes, --no-optimize, --compress, --quantize to `sub`.
void add_export_options(CLI::App& sub, ExportOptions& options);

/// Applies the options that were given to `params` (the config file's, or the defaults).
/// Throws InvalidInputError for a bad value.
void apply_export_options(const ExportOptions& options, ExportParams& params);

}  // namespace sm::cli
