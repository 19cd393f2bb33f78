#pragma once
/// Skeleton file formats.
///
/// JSON (our format; see docs/skeleton-format.md and tests/data/skeletons/README.md):
///   {"up_axis": "z"|"y", "nodes": [{"id": 0, "parent": -1, "position": [x,y,z], "radius": r}, ...]}
///   Unknown keys are ignored; ids are any distinct non-negative integers.
/// SWC (one node per line, `id type x y z radius parent`, '#' starts a comment, parent -1
///   marks the root). Up axis z.
///
/// Measured trees: TreeQSM (.mat, text), cylinder tables (.csv: SimpleForest, aRchi, rTwig) and
///   OpenAlea MTG (.mtg); see skeleton/import/formats.h and docs/formats.md.
///
/// Readers only parse; validation is build_skeleton()'s job. Errors (InvalidInputError for
/// malformed content, IoError for unreadable files) name the file, the line (and column for
/// JSON syntax errors) or node, and the rule.

#include <filesystem>
#include <string>
#include <string_view>

#include "skeleton/import/formats.h"
#include "skeleton/skeleton.h"

namespace sm {

/// Parses our JSON skeleton format. `name` is used in error messages.
RawSkeleton parse_skeleton_json(std::string_view text, const std::string& name = "<json>");
/// Parses SWC. `name` is used in error messages.
RawSkeleton parse_swc(std::string_view text, const std::string& name = "<swc>");
/// The skeleton file formats read_skeleton() knows.
enum class SkeletonFormat { automatic, json, swc, table, mat, mtg };

/// How read_skeleton() reads a file.
struct ReadOptions {
  SkeletonFormat format = SkeletonFormat::automatic;  ///< automatic: by extension, then content
  ColumnMap columns;          ///< table columns / MTG features by field ("radius" -> "rad_m")
  double length_unit = 0;     ///< metres per coordinate unit of the file; 0 = the format's (m; MTG cm)
  double thickness_unit = 0;  ///< metres per radius/diameter unit; 0 = length_unit (MTG: mm)
};

/// The format a file is read as: by extension (.json, .swc, .mat, .mtg; .csv, .tsv, .txt and
/// .dat are tables or SWC by content), else by content (a MAT header, '{', an MTG's
/// sections, a header line naming columns, 7 or at least 10 numbers per line). Reads at most
/// the first 64 KiB.
SkeletonFormat detect_skeleton_format(const std::filesystem::path& path, std::string_view head);
/// "json", "swc", "table", "mat", "mtg" (and "auto").
std::string format_name(SkeletonFormat format);
/// The inverse of format_name(); throws UsageError naming the choices.
SkeletonFormat parse_format_name(const std::string& name);
/// Units as --units takes them: "LENGTH[,THICKNESS]", each a unit (m, dm, cm, mm, um, in, ft),
/// optionally with a factor ("0.1mm"), or a plain number of metres. Throws UsageError.
std::pair<double, double> parse_units(const std::string& text);
/// Parses --columns "FIELD=NAME,FIELD=NAME". Throws UsageError.
ColumnMap parse_column_map(const std::string& text);

/// Reads a skeleton file in any known format, in metres.
RawSkeleton read_skeleton(const std::filesystem::path& path, const ReadOptions& options = {});

/// Serializes a skeleton in our JSON format (ids = node indices; positions as given; the
/// input id of each node is kept as "source_id" when it has one). Round-trips through
/// parse_skeleton_json + build_skeleton to the same skeleton.
std::string skeleton_to_json(const Skeleton& skeleton, const std::string& source = {});
/// Same for a raw skeleton (used by growers before sanitizing).
std::string raw_skeleton_to_json(const RawSkeleton& raw);
/// Writes skeleton_to_json() to `path` atomically.
void write_skeleton_json(const Skeleton& skeleton, const std::filesystem::path& path, const std::string& source = {});

}  // namespace sm
