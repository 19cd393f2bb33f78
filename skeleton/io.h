#pragma once
/// Skeleton file formats.
///
/// JSON (our format; see docs/skeleton-format.md and ../shared/skeletons/README.md):
///   {"up_axis": "z"|"y", "nodes": [{"id": 0, "parent": -1, "position": [x,y,z], "radius": r}, ...]}
///   Unknown keys are ignored; ids are any distinct non-negative integers.
/// SWC (one node per line, `id type x y z radius parent`, '#' starts a comment, parent -1
///   marks the root). Up axis z.
///
/// Readers only parse; validation is build_skeleton()'s job. Errors (InvalidInputError for
/// malformed content, IoError for unreadable files) name the file, the line (and column for
/// JSON syntax errors) or node, and the rule.

#include <filesystem>
#include <string>
#include <string_view>

#include "skeleton/skeleton.h"

namespace sm {

/// Parses our JSON skeleton format. `name` is used in error messages.
RawSkeleton parse_skeleton_json(std::string_view text, const std::string& name = "<json>");
/// Parses SWC. `name` is used in error messages.
RawSkeleton parse_swc(std::string_view text, const std::string& name = "<swc>");
/// Reads a skeleton file: `.swc` as SWC, anything else as JSON.
RawSkeleton read_skeleton(const std::filesystem::path& path);

/// Serializes a skeleton in our JSON format (ids = node indices; positions as given; the
/// input id of each node is kept as "source_id" when it has one). Round-trips through
/// parse_skeleton_json + build_skeleton to the same skeleton.
std::string skeleton_to_json(const Skeleton& skeleton, const std::string& source = {});
/// Same for a raw skeleton (used by growers before sanitizing).
std::string raw_skeleton_to_json(const RawSkeleton& raw);
/// Writes skeleton_to_json() to `path` atomically.
void write_skeleton_json(const Skeleton& skeleton, const std::filesystem::path& path, const std::string& source = {});

}  // namespace sm
