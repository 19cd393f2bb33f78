// RepairParams' table (core/param_table.h): config key, range, unit and help of each field.

#include "repair/repair.h"

namespace sm {
namespace {

using R = RepairParams;

const ParamSpec<R> kFields[] = {
    {.key = "count_pairs_up_to", .field = &R::count_pairs_up_to, .range = {.min = 0}, .unit = "triangles",
     .help = "largest mesh whose self-intersecting pairs are looked for everywhere; on larger ones near the forks "
             "only, and the self-union is skipped",
     .slider = {1000, 1e9, true}},
    {.key = "junction_fold_rounds", .field = &R::junction_fold_rounds, .range = {.min = 0}, .unit = "count",
     .help = "rounds of the fold repair near the forks (flips, moves, collapses; 0 = off)", .slider = {0, 16}},
    {.key = "junction_fold_max_move", .field = &R::junction_fold_max_move, .range = {.min = 0},
     .unit = "x local radius", .help = "largest vertex move of the fold repair near the forks (0 = flips only)",
     .slider = {0, 1}},
    {.key = "junction_fold_collapses", .field = &R::junction_fold_collapses,
     .help = "where flips and moves fail, the fold repair near the forks may collapse an edge near the pair"},
    {.key = "junction_fold_refills", .field = &R::junction_fold_refills,
     .help = "where collapses fail, it may refill a disk around the pair"},
    {.key = "junction_fold_variants", .field = &R::junction_fold_variants,
     .help = "where pairs are left (meshes up to count_pairs_up_to), try two more orders of its moves"},
    {.key = "fork_retry", .field = &R::fork_retry,
     .help = "where pairs or thick nodes outside are left, re-slice the forks around them and keep each crotch's best"},
    {.key = "cover_near_misses", .field = &R::cover_near_misses,
     .help = "push the surface over thick nodes just outside it where no crossing results"},
    {.key = "outer_surface", .field = &R::outer_surface,
     .help = "where pairs or thick nodes outside are still left, keep the mesh's outer surface if it checks better"},
    {.key = "self_union", .field = &R::self_union,
     .help = "replace self-intersecting parts of the surface by their union"},
    {.key = "max_rounds", .field = &R::max_rounds, .range = {.min = 0, .max = 100}, .unit = "count",
     .help = "rounds of finding pairs and cutting them", .slider = {0, 10}},
    {.key = "fold_rounds", .field = &R::fold_rounds, .range = {.min = 0, .max = 1000}, .unit = "count",
     .help = "rounds of fold repair on nearby pairs anywhere before the union (0 = none)", .slider = {0, 16}},
    {.key = "fold_max_move", .field = &R::fold_max_move, .range = {.min = 0, .max = 1}, .unit = "x local radius",
     .help = "largest vertex move of that fold repair"},
    {.key = "volume_patch", .field = &R::volume_patch,
     .help = "replace the surface around pairs the union left by a patch drawn from a voxel grid of the solid"},
    {.key = "patch_uncovered", .field = &R::patch_uncovered,
     .help = "thick skeleton nodes left outside the mesh get such a patch too (around the node)"},
    {.key = "patch_uncovered_thin", .field = &R::patch_uncovered_thin,
     .help = "then every node still outside, thin ones too, at its own scale (kept where more nodes are inside)"},
    {.key = "patch_left", .field = &R::patch_left,
     .help = "patches around the pairs left as they are now: the seams of the pass for thin nodes, then the crossings "
             "still left (kept only where fewer pairs are left and the input's nodes and fidelity are no worse)"},
    {.key = "patch_voxels_per_radius", .field = &R::patch_voxels_per_radius, .range = {.min = 2.5, .max = 32},
     .unit = "voxels", .help = "voxels per thinnest local radius of those patches", .slider = {3, 16}},
    {.key = "patch_reach", .field = &R::patch_reach, .range = {.min = 0.5, .max = 20}, .unit = "x local radius",
     .help = "a patch's region: the pairs' box grown by this many local radii", .slider = {1, 8}},
    {.key = "patch_max_voxels", .field = &R::patch_max_voxels, .range = {.min = 1000, .max = 100'000'000},
     .unit = "voxels", .help = "largest voxel grid of one patch (coarser voxels beyond)"},
    {.key = "patch_budget_voxels", .field = &R::patch_budget_voxels, .range = {.min = 0, .max = 4'000'000'000},
     .unit = "voxels", .help = "voxels of all patches' grids together, smallest regions first (the rest not patched)"},
    {.key = "patch_min_twig_voxels", .field = &R::patch_min_twig_voxels, .range = {.min = 0, .max = 4}, .unit = "voxels",
     .help = "inside a patch, thinner branches are drawn at this radius in voxels (0: a region with them is not patched)"},
    {.key = "collars", .field = &R::collars,
     .help = "remesh the surface where a lateral leaves its parent finer and lay it onto a collar (the smooth union of "
             "the input's round cones; 2-4 times the triangles)"},
    {.key = "collar_reach", .field = &R::collar_reach, .range = {.min = 0.5, .max = 8}, .unit = "x lateral radius",
     .help = "a collar's region: the surface within this many lateral radii of the lateral's base", .slider = {1, 4}},
    {.key = "collar_edge", .field = &R::collar_edge, .range = {.min = 0.05, .max = 2}, .unit = "x lateral radius",
     .help = "target edge length of a collar's remeshed region", .slider = {0.1, 1}},
    {.key = "collar_blend", .field = &R::collar_blend, .range = {.min = 0.05, .max = 2}, .unit = "x lateral radius",
     .help = "width of the blend between lateral and parent (the collar lies at most a quarter of it outside the branches)",
     .slider = {0.1, 1.5}},
    {.key = "collar_max_move", .field = &R::collar_max_move, .range = {.min = 0, .max = 4}, .unit = "x radius",
     .help = "largest move of a vertex onto the collar (x the larger of the lateral's and the local radius); a region "
             "needing more stays as it was", .slider = {0, 2}},
    {.key = "collar_min_angle", .field = &R::collar_min_angle, .range = {.min = 0, .max = 30}, .unit = "degrees",
     .help = "smallest angle of the fans at a collar region's border (a region needing thinner ones stays as it was)",
     .slider = {0, 15}},
    {.key = "collar_max_triangles", .field = &R::collar_max_triangles, .range = {.min = 100, .max = 1'000'000},
     .unit = "triangles", .help = "most triangles of one collar's region (a larger one gets a longer target edge)"},
    {.key = "sliver_angle", .field = &R::sliver_angle, .range = {.min = 0, .max = 30}, .unit = "degrees",
     .help = "triangles with an angle under this are flipped or collapsed away at the end (0 = none)",
     .slider = {0, 10}},
    {.key = "sliver_max_turn", .field = &R::sliver_max_turn, .range = {.min = 0, .max = 90}, .unit = "degrees",
     .help = "largest turn of a triangle's normal by those flips and collapses", .slider = {0, 90}},
    {.key = "sliver_max_move", .field = &R::sliver_max_move, .range = {.min = 0, .max = 1}, .unit = "radii",
     .help = "farthest a vertex those edits remove or move may lie from the surface after them, in local radii (0: no limit)",
     .slider = {0, 0.5}},
    {.key = "split_normals", .field = &R::split_normals,
     .help = "one normal per smoothing group where a vertex's fan has creases or would face away from a triangle "
             "(false: one per vertex)"},
    {.key = "crease_angle", .field = &R::crease_angle, .range = {.min = 1, .max = 180}, .unit = "degrees",
     .help = "edges whose dihedral angle exceeds this are creases between smoothing groups", .slider = {1, 180}},
};

// The keys the meshing section had before the repair stage took over these steps.
const ParamMoved kMoved[] = {
    {"meshing", "count_pairs_up_to", "count_pairs_up_to"},
    {"meshing", "fold_repair_rounds", "junction_fold_rounds"},
    {"meshing", "fold_repair_max_move", "junction_fold_max_move"},
    {"meshing", "fold_repair_collapses", "junction_fold_collapses"},
    {"meshing", "fold_repair_refills", "junction_fold_refills"},
    {"meshing", "fold_repair_variants", "junction_fold_variants"},
    {"meshing", "fork_retry", "fork_retry"},
    {"meshing", "cover_near_misses", "cover_near_misses"},
    {"meshing", "outer_surface", "outer_surface"},
};

}  // namespace

const ParamTable<RepairParams>& param_table(std::type_identity<RepairParams>) {
  static const ParamTable<RepairParams> t{"repair", kFields, kMoved};
  return t;
}

}  // namespace sm
