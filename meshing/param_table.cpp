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
     .help = "texture repeats around the branch", .slider = {0.25, 8}},
    {.key = "uv_metres", .field = &M::uv_metres, .range = {.min = 0}, .unit = "m",
     .help = "texture size: u and v in metres over this (0 = u once around every branch)", .slider = {0, 1}},
    {.key = "uvs", .field = &M::uvs, .help = "compute per-corner UVs"},
    {.key = "normals", .field = &M::normals, .help = "compute smooth vertex normals"},
    {.key = "merge_stacked_junctions", .field = &M::merge_stacked_junctions,
     .help = "mesh junctions a single loop apart as one junction with three or more branches"},
    {.key = "fold_repair_rounds", .field = &M::fold_repair_rounds, .range = {.min = 0}, .unit = "count",
     .help = "rounds of edge flips untangling self-intersections near junctions and caps (0 = off)",
     .slider = {0, 16}},
    {.key = "fold_repair_max_move", .field = &M::fold_repair_max_move, .range = {.min = 0}, .unit = "x local radius",
     .help = "largest vertex move of the fold repair (0 = flips only)", .slider = {0, 1}},
    {.key = "fold_repair_collapses", .field = &M::fold_repair_collapses,
     .help = "where flips and moves fail, the fold repair may collapse an edge near the pair"},
    {.key = "fold_repair_refills", .field = &M::fold_repair_refills,
     .help = "where collapses fail, the fold repair may refill a disk around the pair"},
    {.key = "fold_repair_variants", .field = &M::fold_repair_variants,
     .help = "where pairs are left (meshes up to count_pairs_up_to), try two more orders of the repair's moves"},
    {.key = "count_pairs_up_to", .field = &M::count_pairs_up_to, .range = {.min = 0}, .unit = "triangles",
     .help = "largest mesh whose self-intersecting pairs are counted everywhere; larger ones near junctions only",
     .slider = {1000, 1e9, true}},
    {.key = "fork_retry", .field = &M::fork_retry,
     .help = "where pairs or thick nodes outside are left, re-slice the forks around them and keep each crotch's best"},
    {.key = "outer_surface", .field = &M::outer_surface,
     .help = "where pairs or thick nodes outside are still left, keep the mesh's outer surface if it checks better"},
    {.key = "cover_near_misses", .field = &M::cover_near_misses,
     .help = "push the surface over thick nodes just outside it where no crossing results"},
};

}  // namespace

const ParamTable<MeshParams>& param_table(std::type_identity<MeshParams>) {
  static const ParamTable<MeshParams> t{"meshing", kFields};
  return t;
}

}  // namespace sm
