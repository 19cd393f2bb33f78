// read_skeleton(): picks the reader by extension and content and converts units (skeleton/io.h).

#include <algorithm>
#include <cmath>

#include "core/errors.h"
#include "core/file_io.h"
#include "skeleton/import/formats.h"
#include "skeleton/import/text.h"
#include "skeleton/io.h"

namespace sm {
namespace {

using import::trim;

/// The first line of `head` that is neither blank nor a comment ('#').
std::string_view first_content_line(std::string_view head) {
  std::string_view found;
  import::for_each_line(head, [&](std::string_view line, std::size_t) {
    const std::string_view s = trim(line);
    if (s.empty() || s.front() == '#') return true;
    found = s;
    return false;
  });
  return found;
}

/// Tables and SWC share extensions (.txt): 7 numbers per line is SWC, anything else a table.
SkeletonFormat table_or_swc(std::string_view head) {
  const std::string_view line = first_content_line(head);
  std::size_t count = 0;
  bool numeric = true;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == ',')) ++i;
    if (i >= line.size()) break;
    std::size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != ',') ++j;
    double d = 0;
    numeric = numeric && import::parse_number(line.substr(i, j - i), d);
    ++count;
    i = j;
  }
  return numeric && count == 7 ? SkeletonFormat::swc : SkeletonFormat::table;
}

double unit_factor(std::string_view text, const std::string& whole) {
  const std::string_view s = trim(text);
  std::size_t i = 0;
  while (i < s.size() && (std::isdigit(static_cast<unsigned char>(s[i])) || s[i] == '.' || s[i] == 'e' || s[i] == 'E' ||
                          ((s[i] == '-' || s[i] == '+') && i > 0 && (s[i - 1] == 'e' || s[i - 1] == 'E')))) {
    ++i;
  }
  // "0.1mm": a factor and a unit; "mm": the unit alone; "0.001": metres.
  double factor = 1;
  if (i > 0 && !import::parse_number(s.substr(0, i), factor)) i = 0, factor = 1;
  const std::string_view unit = trim(s.substr(i));
  double metres = 0;
  if (unit.empty() && i > 0) metres = 1;
  else if (unit == "m") metres = 1;
  else if (unit == "dm") metres = 0.1;
  else if (unit == "cm") metres = 0.01;
  else if (unit == "mm") metres = 0.001;
  else if (unit == "um" || unit == "µm") metres = 1e-6;
  else if (unit == "in") metres = 0.0254;
  else if (unit == "ft") metres = 0.3048;
  const double f = factor * metres;
  if (!(f > 0) || !std::isfinite(f)) {
    throw UsageError("--units " + whole + ": " + import::quoted(s) +
                     " is not a unit (m, dm, cm, mm, um, in, ft, optionally with a factor such as 0.1mm, or a number of metres)");
  }
  return f;
}

}  // namespace

std::string format_name(SkeletonFormat format) {
  switch (format) {
    case SkeletonFormat::automatic: return "auto";
    case SkeletonFormat::json: return "json";
    case SkeletonFormat::swc: return "swc";
    case SkeletonFormat::table: return "table";
    case SkeletonFormat::mat: return "mat";
    case SkeletonFormat::mtg: return "mtg";
  }
  return "auto";
}

SkeletonFormat parse_format_name(const std::string& name) {
  for (const auto f : {SkeletonFormat::automatic, SkeletonFormat::json, SkeletonFormat::swc, SkeletonFormat::table,
                       SkeletonFormat::mat, SkeletonFormat::mtg}) {
    if (format_name(f) == name) return f;
  }
  if (name == "csv" || name == "treeqsm") return SkeletonFormat::table;
  throw UsageError("unknown format \"" + name + "\" (auto, json, swc, table, mat, mtg)");
}

std::pair<double, double> parse_units(const std::string& text) {
  const auto comma = text.find(',');
  const double length = unit_factor(std::string_view(text).substr(0, comma), text);
  const double thickness = comma == std::string::npos ? length : unit_factor(std::string_view(text).substr(comma + 1), text);
  return {length, thickness};
}

ColumnMap parse_column_map(const std::string& text) {
  ColumnMap map;
  std::size_t i = 0;
  while (i <= text.size()) {
    std::size_t j = text.find(',', i);
    if (j == std::string::npos) j = text.size();
    const std::string_view pair = trim(std::string_view(text).substr(i, j - i));
    const auto eq = pair.find('=');
    if (eq == std::string_view::npos || eq == 0 || eq + 1 == pair.size()) {
      throw UsageError("--columns: " + import::quoted(pair) + " must be FIELD=NAME (fields: " + known_column_fields() + ")");
    }
    map.emplace_back(std::string(trim(pair.substr(0, eq))), std::string(trim(pair.substr(eq + 1))));
    i = j + 1;
  }
  return map;
}

SkeletonFormat detect_skeleton_format(const std::filesystem::path& path, std::string_view head) {
  const std::string ext = extension_of(path);
  if (ext == "json") return SkeletonFormat::json;
  if (ext == "swc") return SkeletonFormat::swc;
  if (ext == "mat") return SkeletonFormat::mat;
  if (ext == "mtg") return SkeletonFormat::mtg;
  if (ext == "csv" || ext == "tsv" || ext == "txt" || ext == "dat") return table_or_swc(head);
  // Content: MAT v5 files start with a text header "MATLAB 5.0 MAT-file", v7.3 is HDF5 with
  // the same header in its 512-byte user block.
  if (head.substr(0, 6) == "MATLAB") return SkeletonFormat::mat;
  const std::string_view first = first_content_line(head);
  if (!first.empty() && first.front() == '{') return SkeletonFormat::json;
  bool code = false, mtg = false;
  import::for_each_line(head, [&](std::string_view line, std::size_t) {
    code = code || line.substr(0, 4) == "CODE";
    mtg = mtg || line.substr(0, 3) == "MTG";
    return !(code && mtg);
  });
  if (code && mtg) return SkeletonFormat::mtg;
  return table_or_swc(head);
}

RawSkeleton read_skeleton(const std::filesystem::path& path, const ReadOptions& options) {
  const std::string name = path.string();
  SkeletonFormat format = options.format;
  const std::string text = read_file(path);  // also for .mat: a missing file is an IoError naming it
  if (format == SkeletonFormat::automatic) format = detect_skeleton_format(path, std::string_view(text).substr(0, 65536));
  const bool mtg = format == SkeletonFormat::mtg;
  if (!options.columns.empty() && format != SkeletonFormat::table && !mtg) {
    throw UsageError(name + ": --columns applies to cylinder tables and MTG files, not to " + format_name(format));
  }
  RawSkeleton raw;
  switch (format) {
    case SkeletonFormat::json: raw = parse_skeleton_json(text, name); break;
    case SkeletonFormat::swc: raw = parse_swc(text, name); break;
    case SkeletonFormat::table: raw = parse_cylinder_table(text, name, options.columns); break;
    case SkeletonFormat::mtg: raw = parse_mtg(text, name, options.columns); break;
    case SkeletonFormat::mat:
    case SkeletonFormat::automatic: raw = read_treeqsm_mat(path); break;
  }
  // MTG files carry no units; digitised plants are usually written in cm with diameters in mm.
  const double length = options.length_unit > 0 ? options.length_unit : mtg ? 0.01 : 1.0;
  const double thickness = options.thickness_unit > 0 ? options.thickness_unit
                           : options.length_unit > 0 ? options.length_unit
                           : mtg                     ? 0.001
                                                     : 1.0;
  if (length != 1.0)
    for (dvec3& p : raw.position) p *= length;
  if (thickness != 1.0) {
    for (double& r : raw.radius) r *= thickness;
    for (double& r : raw.base_radius) r *= thickness;
  }
  return raw;
}

}  // namespace sm
