#pragma once
/// Command-line options shared by every command that reads a skeleton.

#include <string>

#include "apps/cli/cli.h"
#include "skeleton/build.h"
#include "skeleton/io.h"
#include "skeleton/skeleton.h"

namespace sm::cli {

/// Adds --max-nodes, --merge-edge-ratio, --radius-floor, --thick-child, --max-child-ratio,
/// --max-edge-ratio to `sub`, writing into `params`.
void add_skeleton_options(CLI::App& sub, SkeletonParams& params);

/// Before any work: `path` (given with `option`) must end in .json and be writable
/// (check_output_path). Throws InvalidInputError or IoError.
void check_json_output(const std::string& path, const char* option);

/// Reads and sanitizes a skeleton file; logs the repairs as warnings (unless quiet).
SkeletonResult load_skeleton(const std::string& path, const SkeletonParams& params, const ReadOptions& read = {});

/// Multi-line human-readable summary: counts, depth, radius range, extent, repairs.
std::string describe_skeleton(const SkeletonResult& result);

}  // namespace sm::cli
