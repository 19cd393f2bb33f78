#include "apps/cli/input_options.h"

#include <cstdio>

#include "core/errors.h"
#include "core/file_io.h"
#include "skeleton/import/formats.h"

namespace sm::cli {

void add_input_options(CLI::App& sub, InputOptions& o) {
  sub.add_option("--format", o.format,
                 "Input format: auto (by extension and content), json, swc, table (QSM cylinder CSV or TreeQSM "
                 "text), mat (TreeQSM), mtg (OpenAlea)")
      ->capture_default_str();
  sub.add_option("--columns", o.columns,
                 "Table columns or MTG features by field, FIELD=NAME,... (fields: " + known_column_fields() + ")");
  sub.add_option("--units", o.units,
                 "Units of the file: LENGTH[,THICKNESS], e.g. cm,mm or mm,0.1mm (m, dm, cm, mm, um, in, ft); "
                 "default m, MTG cm,mm");
}

ReadOptions read_options(const InputOptions& o) {
  ReadOptions r;
  r.format = parse_format_name(o.format);
  if (!o.columns.empty()) r.columns = parse_column_map(o.columns);
  if (!o.units.empty()) std::tie(r.length_unit, r.thickness_unit) = parse_units(o.units);
  return r;
}

RawSkeleton read_skeleton_arg(const std::string& path, const ReadOptions& options) {
  if (path != "-") return read_skeleton(path, options);
  std::string text;
  char buf[1 << 16];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, stdin)) > 0;) {
    text.append(buf, n);
    if (text.size() > kMaxInputBytes) throw IoError("standard input: more than 2 GiB");
  }
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  const bool json = options.format == SkeletonFormat::json ||
                    (options.format == SkeletonFormat::automatic && first != std::string::npos && text[first] == '{');
  if (json) return parse_skeleton_json(text, "<stdin>");
  if (options.format == SkeletonFormat::swc || options.format == SkeletonFormat::automatic) return parse_swc(text, "<stdin>");
  throw UsageError("standard input is read as JSON or SWC only; write the skeleton to a file for --format " +
                   format_name(options.format));
}

}  // namespace sm::cli
