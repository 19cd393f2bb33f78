#include "apps/cli/export_options.h"

#include "meshio/export_text.h"

#include <string>
#include <string_view>

#include "apps/cli/param_help.h"
#include "meshio/export.h"

namespace sm::cli {

namespace {

std::string help(std::string_view key, std::string_view more = {}) { return param_help<ExportParams>(key, more); }

}  // namespace

void add_export_options(CLI::App& sub, ExportOptions& o) {
  const std::string group = "Export (docs/export.md)";
  sub.add_option("--up-axis", o.up_axis, help("up_axis"))->check(CLI::IsMember({"y", "z", "auto"}))->group(group);
  sub.add_option("--pivot", o.pivot, help("pivot"))
      ->check(CLI::IsMember({"root", "center", "origin", "auto"}))
      ->group(group);
  sub.add_option("--scale", o.scale, help("scale"))->group(group);
  sub.add_option("--attributes", o.attributes, help("attributes"))->group(group);
  sub.add_flag("--no-optimize", o.no_optimize, help("optimize", "; this flag turns it off"))->group(group);
  sub.add_option("--compress", o.compress, help("compress"))->check(CLI::IsMember({"meshopt", "none"}))->group(group);
  sub.add_option("--lods", o.lods, help("lods"))->check(CLI::Range(1, 8))->group(group);
  sub.add_flag("--lod-files", o.lod_files, help("lod_files"))->group(group);
  sub.add_flag("--quantize", o.quantize, help("quantize"))->group(group);
}

void apply_export_options(const ExportOptions& o, ExportParams& p) {
  if (!o.up_axis.empty()) p.file_up_axis = parse_up_axis(o.up_axis);
  if (!o.pivot.empty()) p.pivot = parse_pivot(o.pivot);
  if (!o.scale.empty()) p.scale = parse_scale(o.scale);
  if (!o.attributes.empty()) set_attributes(o.attributes, p);
  if (o.no_optimize) p.optimize = false;
  if (!o.compress.empty()) p.compress = parse_compression(o.compress);
  if (o.quantize) p.quantize = true;
  if (o.lods > 0) p.lods = o.lods;
  if (o.lod_files) p.lod_files = true;
}

}  // namespace sm::cli
