#pragma once
/// Repair stage: every change made to the surface after it is stitched, so that it is closed,
/// free of self-intersections and holds the thick skeleton nodes, without moving the skeleton.
/// repair_mesh runs its steps in order, each where the one before left something to do:
///  1. folds near the forks (junction_folds.h): flips, moves and collapses on the stitched
///     crotches, and the count of the self-intersecting pairs left;
///  2. the fork retry (fork_retry.h): the forks around pairs or thick nodes outside sliced and
///     stitched again with other contour settings, each crotch keeping its best;
///  3. the near-miss push (near_misses.h): the surface pushed over thick nodes just outside it;
///  4. the outer surface (outer_surface.h): parts inside parts cut away, spheres joined around
///     thick nodes outside (CGAL);
///  5. crossings anywhere (repair_crossings, repair.cpp): pairs over the whole mesh, folds
///     within two rings untangled and the rest replaced by the boundary of the union of the
///     solids the surface wraps (self_union.h). Where crossings close a loop the union has a
///     handle: genus > 0 is then the truth, not a defect;
///  7. slivers (slivers.h): triangles with an angle under `sliver_angle` flipped or collapsed
///     away where no crossing results;
///  8. the normals of the finished surface: angle-weighted per vertex, and per corner where a
///     fan is split into smoothing groups (finish_normals).
/// Each step keeps a change only when the mesh does better by the stage's one rule
/// (verdict.h: the whole mesh in steps 4 and 5, the triangles around each change in steps 1
/// and 3, each crotch in step 2) and otherwise leaves it as it was; a clean mesh passes
/// through unchanged.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "contours/contours.h"
#include "core/param_table.h"
#include "core/progress.h"
#include "core/report.h"
#include "meshing/meshing.h"
#include "repair/fork_retry.h"
#include "repair/junction_folds.h"
#include "repair/near_misses.h"
#include "repair/outer_surface.h"
#include "repair/collars.h"
#include "repair/slivers.h"
#include "skeleton/skeleton.h"

namespace sm {

struct RepairParams {
  /// Largest mesh (triangles) whose self-intersecting pairs are looked for over the whole
  /// mesh (default: every mesh). On a larger one only the pairs the fold repair near the forks
  /// leaves there are known, and the last step is skipped.
  std::size_t count_pairs_up_to = 1'000'000'000;
  /// Rounds of the fold repair near the forks (step 1; 0 = none).
  std::uint32_t junction_fold_rounds = 8;
  /// Largest vertex move of the fold repair near the forks, relative to the local skeleton
  /// radius (0 = flips only).
  double junction_fold_max_move = 0.25;
  /// Where flips and moves fail, the fold repair near the forks may collapse an edge near the pair.
  bool junction_fold_collapses = true;
  /// Where collapses fail, it may replace a disk around the pair by a triangulation of its boundary.
  bool junction_fold_refills = true;
  /// Where pairs are left (meshes up to count_pairs_up_to), it tries two more orders of its
  /// vertex moves and keeps the run leaving the fewest.
  bool junction_fold_variants = false;
  /// Step 2: re-slice the forks around pairs or thick nodes outside and keep each crotch's best.
  bool fork_retry = false;
  /// Step 3: push the surface over thick nodes just outside it where no crossing results.
  bool cover_near_misses = true;
  /// Step 4: where pairs or thick nodes outside are left, keep the mesh's outer surface if it
  /// checks better.
  bool outer_surface = false;
  /// Step 5: replace self-intersecting parts of the surface by their union (false: leave them).
  bool self_union = true;
  /// Rounds of finding pairs and cutting them (a count; a round after the first only meets
  /// pairs made by rounding the cut lines' vertices to the float grid).
  std::uint32_t max_rounds = 4;
  /// Rounds of fold repair (flips, moves, collapses) on pairs within two rings of each other,
  /// before the union (0 = none).
  std::uint32_t fold_rounds = 8;
  /// Largest vertex move of that fold repair, relative to the local skeleton radius.
  double fold_max_move = 0.25;
  /// Step 6: replace the surface around pairs the union left by a patch drawn from a voxel
  /// grid of the solid there (repair/volume_patch.h).
  bool volume_patch = true;
  /// Thick skeleton nodes left outside the mesh get such a patch too (around the node).
  bool patch_uncovered = true;
  /// Then every skeleton node still outside, thin ones too (a twig's first node at a hub), at
  /// its own scale; kept only where more nodes are inside and nothing else is worse.
  bool patch_uncovered_thin = true;
  /// Pairs left: where the seams of the pass for thin nodes leave more pairs than there were,
  /// one round of patches around those before the pass is judged; and last, one more pass for
  /// the crossings still left. Both in regions drawn around the pairs as they are now, kept only
  /// where fewer pairs are left and the input's nodes inside and the fidelity to its cones are
  /// no worse.
  bool patch_left = true;
  /// Voxels per thinnest local radius of those patches.
  double patch_voxels_per_radius = 4;
  /// A patch's region: the pairs' box grown by this many local radii.
  double patch_reach = 2.5;
  /// Largest voxel grid of one patch (coarser voxels beyond, down to 2.5 per thinnest radius).
  std::uint32_t patch_max_voxels = 1'500'000;
  /// Voxels of all patches' grids together, smallest regions first (the rest are not patched).
  std::uint32_t patch_budget_voxels = 40'000'000;
  /// Inside a patch, branches thinner than this many voxels in radius are drawn at this radius
  /// (a grid loses thinner ones, and the patch its rim there); 0: such a region is not patched.
  double patch_min_twig_voxels = 1.25;
  /// Step 6b: the surface where a lateral leaves its parent remeshed finer and laid onto a
  /// collar, the smooth union of the input's round cones there (repair/collars.h). Off by
  /// default (2-4 times the triangles); on in configs/closeup.json.
  bool collars = false;
  /// A collar's region: the surface within this many lateral radii of the lateral's base.
  double collar_reach = 2.5;
  /// Target edge length of a collar's remeshed region (lateral radii).
  double collar_edge = 0.3;
  /// Width of the blend between the lateral's surface and its parent's (lateral radii): the
  /// collar lies at most a quarter of it outside the union of their round cones.
  double collar_blend = 0.6;
  /// Largest move of a vertex onto the collar (x the larger of the lateral's and the local
  /// radius); a region needing more stays as it was (its surface is not this fork's).
  double collar_max_move = 1.0;
  /// Smallest angle of the fans the remeshed region makes of the triangles outside its split
  /// border edges (degrees), unless a fanned triangle had less: a region needing thinner ones
  /// stays as it was.
  double collar_min_angle = 1.0;
  /// Most triangles of one collar's region: a larger region gets a longer target edge.
  std::uint32_t collar_max_triangles = 4000;
  /// Step 7: triangles with an angle under this are flipped or collapsed away (degrees; 0 = none).
  double sliver_angle = 10.0;
  /// Largest turn of a triangle's normal by those flips and collapses (degrees).
  double sliver_max_turn = 30.0;
  /// Farthest a vertex those edits remove or move may lie from the surface after them (share
  /// of the local radius; 0 = no limit).
  double sliver_max_move = 0.1;
  /// Step 8: where a vertex's fan has creases or its normal faces (nearly) away from one of its
  /// triangles, one normal per smoothing group at the corners (Mesh::corner_normals; the
  /// writers split the vertex there). false: one normal per vertex, as in older versions.
  bool split_normals = true;
  /// Edges whose dihedral angle exceeds this are creases between smoothing groups (degrees).
  double crease_angle = 90.0;
};

/// The config key, accepted range, unit and help of each field of RepairParams, in header order
/// (core/param_table.h; the defaults are the initializers above).
const ParamTable<RepairParams>& param_table(std::type_identity<RepairParams>);

struct RepairStats {
  JunctionFoldStats junction_folds;  ///< step 1
  ForkRetryStats fork_retry;         ///< step 2
  NearMissStats near_misses;         ///< step 3
  OuterSurfaceStats outer_surface;   ///< step 4
  // Step 5:
  bool counted = false;            ///< the mesh was small enough to look for pairs everywhere
  std::size_t pairs_found = 0;     ///< self-intersecting pairs of the built mesh (whole mesh)
  std::size_t pairs_left = 0;      ///< after the repair (whole mesh)
  std::size_t fold_pairs = 0;       ///< pairs within two rings of each other (folds)
  std::size_t fold_changes = 0;    ///< flips, moves, collapses and refills the fold repair made
  std::size_t rounds = 0;          ///< rounds of self-union run
  std::size_t cut_triangles = 0;   ///< triangles cut, over all rounds
  std::size_t dropped_triangles = 0;  ///< uncut triangles dropped inside other parts
  std::size_t new_vertices = 0;    ///< vertices made on cut lines
  std::size_t split_vertices = 0;  ///< vertices split where kept parts met at a point
  std::size_t inner_shells = 0;    ///< enclosed voids dropped
  std::size_t lumps = 0;           ///< loose parts without a skeleton node dropped
  std::size_t coincident_vertices = 0;  ///< vertices moved off another at the same position
  /// The pairs left, sorted, where they are known exactly (counted, and none left or no vertex
  /// moved off another after they were found); for the sliver step, which then need not search
  /// the whole mesh again.
  std::optional<std::vector<std::array<std::uint32_t, 2>>> left_pairs;
  // Step 6:
  std::size_t patch_clusters = 0;  ///< regions of pairs left by the union
  std::size_t patched = 0;         ///< of those, replaced by a volume patch
  std::size_t patch_voxels = 0;    ///< voxels of their grids
  CollarStats collars;             ///< step 6b
  SliverStats slivers;             ///< step 7
  // Step 8:
  std::size_t split_normal_vertices = 0;  ///< vertices whose fan was split into smoothing groups
  std::size_t extra_normals = 0;          ///< normals beyond one per vertex (vertices the writers add)
  std::string problem;             ///< why a round was refused (empty: none was)
  Warnings warnings;               ///< every step's
  Timings timings;                 ///< every step's
};

/// Throws InvalidInputError naming the first parameter out of its range.
void validate_params(const RepairParams& params);

/// What the repair stage reads of the earlier stages: the skeleton whose nodes belong inside
/// the mesh, and for the fork retry, which slices and stitches forks again, the particles,
/// strands and the contour and meshing parameters the surface was made with.
struct RepairInputs {
  const Skeleton& skeleton;
  const ParticleField& particles;
  const StrandSet& strands;
  const ContourParams& contour_params;
  const MeshParams& mesh_params;
  /// The skeleton as the file gives it (input_skeleton), what `check --skeleton` measures
  /// against: the volume patch's fidelity guard and the nodes the sliver step keeps inside.
  /// Null: the sanitized skeleton's input nodes (those with a source id) stand for it.
  const Skeleton* input = nullptr;
};

/// Drops the triangles left as (u, u, u) (fold repair, sliver removal) and the vertices no
/// triangle uses any more, keeping the order of the rest; returns, per triangle left, its
/// index before.
std::vector<std::uint32_t> drop_degenerate(MeshResult& r);

/// Step 8 on a finished mesh (repair_mesh runs it last; levels of detail made by simplifying a
/// mesh run it again): with `mesh.normals` non-empty, makes them the angle-weighted vertex
/// normals and, with `params.split_normals`, the corner normals of the smoothing groups
/// (core/mesh.h split_vertex_normals at `params.crease_angle`); otherwise clears the corner
/// normals. Fills the step's figures of `stats`.
void finish_normals(Mesh& mesh, const RepairParams& params, RepairStats* stats = nullptr);

/// The repair stage: repairs `stitched` (stitch_mesh's result for `contours`) and finishes it
/// (finish_mesh) into `mesh`. Where the fork retry keeps a mesh of re-sliced forks, `contours`
/// become the contours it was made from.
RepairStats repair_mesh(StitchedMesh stitched, ContourSet& contours, MeshResult& mesh, const RepairInputs& inputs,
                        const RepairParams& params = {}, const ProgressFn& progress = {});

/// Step 5 on a finished mesh (exposed for tests; repair_mesh runs it last): fills the step's
/// figures of the result. Precondition: `mesh` is closed, edge-manifold and oriented outward.
/// `input`: as RepairInputs::input.
RepairStats repair_crossings(MeshResult& mesh, const Skeleton& skeleton, const RepairParams& params = {},
                             const Skeleton* input = nullptr);

}  // namespace sm
