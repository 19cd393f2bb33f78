#include "apps/cli/input_options.h"

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

}  // namespace sm::cli
