#include "apps/cli/export_options.h"

#include "meshio/export_text.h"

namespace sm::cli {

void add_export_options(CLI::App& sub, ExportOptions& o) {
  const std::string group = "Export (docs/export.md)";
  sub.add_option("--up-axis", o.up_axis, "Up axis of the file: y, z or auto (glTF and OBJ y, PLY as the input)")
      ->check(CLI::IsMember({"y", "z", "auto"}))
      ->group(group);
  sub.add_option("--pivot", o.pivot,
                 "The file's origin: root (base of the trunk), center (of the bounds), origin (the input's "
                 "coordinates) or auto (root for glTF and OBJ, origin for PLY)")
      ->check(CLI::IsMember({"root", "center", "origin", "auto"}))
      ->group(group);
  sub.add_option("--scale", o.scale,
                 "File units per metre: a number or m, cm, mm, in, ft (default m: the input's metres)")
      ->group(group);
  sub.add_option("--attributes", o.attributes,
                 "Vertex attributes, comma-separated (docs/export.md): normal, uv, branch_id, level, root_distance, "
                 "pivot, direction, phase, thickness (wind: those six), color, uv1, tangent, all or none "
                 "(default normal,uv,branch_id)")
      ->group(group);
  sub.add_flag("--no-optimize", o.no_optimize, "Keep the mesher's vertex and triangle order")->group(group);
  sub.add_option("--compress", o.compress, "glTF buffer compression: meshopt (EXT_meshopt_compression) or none")
      ->check(CLI::IsMember({"meshopt", "none"}))
      ->group(group);
  sub.add_option("--lods", o.lods,
                 "Levels of detail in all (1-8), each a closed mesh from the pipeline run again on coarser settings "
                 "with thin twigs pruned; glTF: all in OUT (MSFT_lod), OBJ and PLY: level k in OUT_lodK.EXT")
      ->check(CLI::Range(1, 8))
      ->group(group);
  sub.add_flag("--lod-files", o.lod_files, "glTF too: each level of detail in a file of its own, OUT_lodK.EXT")
      ->group(group);
  sub.add_flag("--quantize", o.quantize, "glTF: 16-bit positions, 8-bit normals (KHR_mesh_quantization)")->group(group);
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
