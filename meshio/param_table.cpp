// ExportParams' table (core/param_table.h): the `export` section of config files.

#include <string>
#include <string_view>

#include "meshio/export.h"
#include "meshio/export_text.h"

namespace sm {
namespace {

using E = ExportParams;

std::string up_axis_text(const E& p) {
  if (!p.file_up_axis) return "auto";
  return *p.file_up_axis == UpAxis::y ? "y" : "z";
}
void set_up_axis(E& p, std::string_view text) { p.file_up_axis = parse_up_axis(text); }

std::string pivot_text(const E& p) {
  if (!p.pivot) return "auto";
  return *p.pivot == Pivot::root ? "root" : *p.pivot == Pivot::center ? "center" : "origin";
}
void set_pivot(E& p, std::string_view text) { p.pivot = parse_pivot(text); }

std::string attributes_text(const E& p) { return attribute_list(p); }
void set_attributes_text(E& p, std::string_view text) { set_attributes(text, p); }

const char* const kCompression[] = {"none", "meshopt"};

const ParamSpec<E> kFields[] = {
    {.key = "up_axis", .field = ParamText<E>{&up_axis_text, &set_up_axis, "`y`, `z`, `auto`"},
     .help = "up axis of the file (auto: y for glTF and OBJ, the input's for PLY)"},
    {.key = "pivot", .field = ParamText<E>{&pivot_text, &set_pivot, "`root`, `center`, `origin`, `auto`"},
     .help = "the file's origin: the trunk's base, the centre of the bounds or the input's origin (auto: root "
             "for glTF and OBJ, origin for PLY)"},
    {.key = "scale", .field = &E::scale, .range = {.min = 0, .min_open = true}, .unit = "file units per m",
     .help = "file units per metre; also m, cm, mm, in, ft", .from_name = &parse_scale},
    {.key = "attributes",
     .field = ParamText<E>{&attributes_text, &set_attributes_text,
                           "comma-separated: `normal`, `uv`, `branch_id`, `level`, `root_distance`, `pivot`, "
                           "`direction`, `phase`, `thickness`, `color`, `uv1`, `tangent`, `wind`, `all`, `none`"},
     .help = "vertex attributes written (docs/export.md)"},
    {.key = "optimize", .field = &E::optimize, .help = "meshoptimizer vertex-cache and vertex-fetch order"},
    {.key = "compress", .field = param_choice<&E::compress>(kCompression), .help = "glTF buffer compression"},
    {.key = "quantize", .field = &E::quantize,
     .help = "glTF: 16-bit positions and 8-bit normals (KHR_mesh_quantization)"},
    {.key = "lods", .field = &E::lods, .range = {.min = 1, .max = 8}, .unit = "count",
     .help = "levels of detail `mesh` writes, the full mesh included (1 = none), each a closed mesh of the pipeline "
             "run again on coarser settings; glTF: all in one file (MSFT_lod), OBJ and PLY: level k in OUT_lodK.EXT"},
    {.key = "lod_files", .field = &E::lod_files,
     .help = "glTF too: each level of detail in a file of its own (OUT_lodK.EXT) rather than one file with MSFT_lod"},
};

}  // namespace

const ParamTable<ExportParams>& param_table(std::type_identity<ExportParams>) {
  static const ParamTable<ExportParams> t{"export", kFields};
  return t;
}

}  // namespace sm
