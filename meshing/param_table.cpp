// MeshParams' table (core/param_table.h): config key, range, unit and help of each field.

#include "meshing/meshing.h"

namespace sm {
namespace {

using M = MeshParams;

const ParamSpec<M> kFields[] = {
    // (A dome of 1e9 radii ran for minutes: its spikes cross everything near them.)
    {.key = "tip_dome", .field = &M::tip_dome, .range = {.min = 0, .max = 10}, .unit = "x tip loop radius",
     .help = "height of the tip caps (0 = flat)", .slider = {0, 2}},
    {.key = "uv_repeat_u", .field = &M::uv_repeat_u, .range = {.min = 0, .min_open = true}, .unit = "count",
     .help = "with uv_metres 0: texture repeats once around every branch", .slider = {0.25, 8}},
    {.key = "uv_metres", .field = &M::uv_metres, .range = {.min = 0}, .unit = "m",
     .help = "texture size: u around and v along the branch in metres over this (0 = once around every branch)",
     .slider = {0, 1}},
    {.key = "uvs", .field = &M::uvs, .help = "compute per-corner UVs"},
    {.key = "normals", .field = &M::normals, .help = "compute smooth vertex normals"},
    {.key = "merge_stacked_junctions", .field = &M::merge_stacked_junctions,
     .help = "mesh junctions a single loop apart as one junction with three or more branches"},
};

}  // namespace

const ParamTable<MeshParams>& param_table(std::type_identity<MeshParams>) {
  static const ParamTable<MeshParams> t{"meshing", kFields};
  return t;
}

}  // namespace sm
