#pragma once
/// Meshing stage: stitches the contour loops into one closed, consistently oriented surface
/// (as in Interactive Invigoration, Li et al.).
///
///  - Consecutive loops of a tube are joined by the greedy shortest-diagonal strip,
///    starting at a strand both loops share (or the closest pair), with a guard that
///    keeps the strip monotone around the branch axis.
///  - Branch fusion: at a junction the crotch is the closest pair of
///    vertices between the two upper loops; the lower loop is cut at the two vertices on
///    either side of the crotch, each half is stitched to one upper loop (opened at its crotch
///    vertex), and two special triangles on the crotch edge close the gap: a pair of pants
///    with no holes and no overlaps, manifold by construction (see fuse_loops). Junctions
///    stacked a single loop apart are merged into one with three or more upper loops
///    (MeshParams::merge_stacked_junctions; fuse_many in meshing.cpp).
///  - Caps: a dome on the last loop of every tube that ends at a tip, a nearly flat base
///    (5% of the radius deep) on the root's loop.
///  - Normals are computed on the finished mesh (angle-weighted), UVs follow the strands:
///    u around the branch (from the parallel-transported frame, so it does not twist), v along
///    it, scaled by the circumference so texels stay square. Seams are per-corner UVs only.
///
/// The result is a welded mesh: a closed 2-manifold of genus 0 for any tree (checked by
/// `check_mesh`, meshcheck/checks.h).

#include <array>
#include <cstdint>

#include "core/param_table.h"
#include "contours/contours.h"
#include "core/mesh.h"
#include "core/progress.h"
#include "core/report.h"
#include "skeleton/skeleton.h"

namespace sm {

struct MeshParams {
  /// Height of the dome on a tip relative to the tip loop's radius (0 = flat cap; at most 10).
  double tip_dome = 0.9;
  /// Texture repeats around the branch (u runs over [0, uv_repeat_u) once around).
  double uv_repeat_u = 1.0;
  /// Texture size in metres; 0 = u once around every branch (uv_repeat_u times). Otherwise u is
  /// the distance around the branch and v the distance along it over this size, so texel
  /// density does not depend on the radius (uv_repeat_u unused; one seam per loop still).
  double uv_metres = 0.0;
  /// Compute per-corner UVs.
  bool uvs = true;
  /// Compute smooth vertex normals.
  bool normals = true;
  /// Mesh a junction whose child tube is a single loop ending in another junction (forks a
  /// fraction of a slice apart) as one junction with three or more upper loops, skipping that
  /// loop: the stacked binary crotches would overlap (see fuse_many in meshing.cpp).
  bool merge_stacked_junctions = true;
  /// Rounds of fold repair (fold_repair.h): triangles near junctions are tested for
  /// self-intersections (exact predicates) and intersecting pairs are untangled by edge flips
  /// where another triangulation of the same vertices is free of the crossing, by small vertex
  /// moves where not (fold_repair_max_move). 0 disables. 8 rather than 4 rounds: pairs on the
  /// samples, seeds 1-3, 331 -> 303 (boutdenoylum2 21 / 24 / 24 -> 11 / 21 / 17, small_pine seed
  /// 3 58 -> 50), boutdenoylum2 fold repair 0.49 -> 0.88 s, the bench tree +0.05 s.
  std::uint32_t fold_repair_rounds = 8;
  /// Where no flip untangles a pair, the fold repair may move a vertex of it (towards the
  /// centroid of its neighbours, or along its normal) by at most this fraction of the local
  /// skeleton radius (0 = flips only). Measured with centroid moves alone: 0.1 / 0.2 / 0.35 /
  /// 0.5 left agraf 456 / 354 / 315 / 316 pairs (542 with flips only), boutdenoylum2 56 / 36 /
  /// 49 / 56 (116); fidelity p95 unchanged.
  double fold_repair_max_move = 0.25;
  /// Where neither flips nor moves untangle a pair, the fold repair may collapse an edge of
  /// one of its triangles or of a triangle next to them (removing one vertex and two
  /// triangles; the kept vertex at either end or midway, on the old edge) when that lowers the
  /// crossings around the pair, turns no triangle over and keeps the surface a closed
  /// 2-manifold of the same genus. Self-intersecting pairs, samples x particle seeds 1-3:
  /// 936 without, 449 with (callistemon 19 -> 0); fidelity p95 unchanged or better.
  bool fold_repair_collapses = true;
  /// Last resort of the fold repair: around a pair still crossing, the star of one of its
  /// vertices, or else the triangles within 1, 2 or 3 rings of the pair (or of either of its
  /// triangles) where they form a disk, is replaced by CGAL's hole-filling triangulation of
  /// the disk's boundary loop (smallest largest dihedral angle, then area) when that lowers
  /// the crossings around it; the disk's inner vertices go. Pairs, samples x particle seeds
  /// 1-3: 449 without, 252 with (boutdenoylum2 10 -> 0, qsm 63 -> 17, agraf 141 -> 91,
  /// small_pine 235 -> 144); grown `bush` preset 3 -> 0.
  bool fold_repair_refills = true;
  /// On meshes of at most count_pairs_up_to triangles where the fold repair leaves self-intersecting pairs
  /// (counted over the whole mesh), try two more orders of its vertex moves from the stitched
  /// mesh and keep the run leaving the fewest (see meshing.cpp, repair_folds). Off by default
  /// since the fork retry (below) does better: samples x particle seeds 1-3, 135 pairs with
  /// these variants alone, 82 with the retry alone, 73 with both at 1.9 x the retry's time.
  bool fold_repair_variants = false;
  /// Largest mesh (triangles) whose self-intersecting pairs are counted over the whole mesh
  /// after the fold repair, for the fork retry and the outer surface below (and the variants
  /// above). A larger mesh has only the pairs counted that the fold repair left among the
  /// triangles it examined (junctions, the strips at fused and split loops, and their
  /// neighbours), since a count over the whole mesh costs more than the fold repair: grown
  /// presets at grow seed 1, 440,000-940,000 triangles, 0.20-0.57 s -> 0.46-1.08 s where they
  /// are clean, 0.59 -> 3.83 s for broadleaf, whose retry then also covers a node outside.
  /// Pairs away from the junctions (a branch running into a neighbour's crotch) then stay
  /// unrepaired, with a note of `strandmesh mesh` (grown `oak` at grow seed 21, before
  /// ContourParams::thin_gap_radii: 12 pairs left in 0.54 s; counted everywhere, 0 in 3.68 s),
  /// and the thick nodes are tested only by the near-miss push (cover_near_misses), whose
  /// leftovers are warned about (`thick_nodes_outside`; grown conifer at grow seed 11, one
  /// twig node; counted everywhere, the fork retry covers it, 0.39 -> 6.3 s). Hero assets
  /// raise it (configs/high_detail.json counts every mesh).
  std::size_t count_pairs_up_to = 300'000;
  /// Where self-intersecting pairs (counted as for fold_repair_variants, on meshes of at most
  /// count_pairs_up_to triangles) or thick skeleton nodes outside the mesh are still left, the pipeline
  /// re-slices the forks around them with other split gaps, fork transitions and slice steps
  /// and keeps each crotch's best: up to 10 more runs of contours and meshing
  /// (pipeline/fork_retry.h).
  bool fork_retry = false;
  /// Where self-intersecting pairs or thick skeleton nodes outside the mesh are still left after
  /// the fork retry (meshes of at most count_pairs_up_to triangles), the mesh is replaced by its outer
  /// surface: the intersecting triangles cut along their intersections and the parts inside
  /// other parts removed (CGAL's autorefinement), and a small sphere joined around each thick
  /// node outside (CGAL's union; meshing/outer_surface.h), where the result passes the mesh
  /// checks at least as well in every respect and has fewer pairs or more nodes inside.
  bool outer_surface = false;
  /// Thick skeleton nodes a little outside the finished mesh (within their radius of it: a
  /// twig's base at a crotch) get the surface nearest them pushed over them, where no new
  /// crossing, turned triangle or lost node results (meshing/near_misses.h). Runs after the
  /// fork retry, before the outer surface, on meshes of any size.
  bool cover_near_misses = true;
};

/// The config key, accepted range, unit and help of each field of MeshParams, in header order
/// (core/param_table.h; the defaults are the initializers above).
const ParamTable<MeshParams>& param_table(std::type_identity<MeshParams>);

struct MeshStats {
  std::size_t vertices = 0;
  std::size_t triangles = 0;
  std::size_t strips = 0;            ///< loop-to-loop strips
  std::size_t junctions = 0;         ///< branch fusions (junctions of the contours, merged ones included)
  std::size_t merged_junctions = 0;  ///< junctions meshed as part of the junction below them
  std::size_t tip_caps = 0;
  std::size_t fold_pairs = 0;      ///< self-intersecting pairs the fold repair found near junctions and caps
  std::size_t fold_flips = 0;      ///< edge flips it made
  std::size_t fold_moves = 0;      ///< vertices it moved
  std::size_t fold_collapses = 0;  ///< edges it collapsed
  std::size_t fold_refills = 0;    ///< disks it replaced by a triangulation of their boundary
  std::size_t bad_edges = 0;       ///< edges not shared by exactly two triangles (0 unless a bug)
  Warnings warnings;
  Timings timings;
};

/// Which construction made a triangle (for debugging and the viewer).
enum class TriangleKind : std::uint8_t { strip, fusion, tip_cap, root_cap };

/// A self-intersecting pair of triangles: the mean of their six corners, and the skeleton node
/// whose edge or section made each corner (Mesh::vertex_node).
struct Crossing {
  glm::dvec3 at{0.0};
  std::array<NodeId, 6> nodes{};
};

/// The Crossing of triangles f and g of `mesh` (nodes left invalid without Mesh::vertex_node).
Crossing crossing_of(const Mesh& mesh, std::uint32_t f, std::uint32_t g);

struct MeshResult {
  Mesh mesh;
  std::vector<TriangleKind> triangle_kind;  ///< #F
  MeshStats stats;
  /// The self-intersecting triangle pairs left, if the fold repair counted them
  /// (`crossings_counted`: with MeshParams::fold_repair_variants, fork_retry or
  /// outer_surface, the repair not stopped): over the whole mesh on meshes of at most count_pairs_up_to
  /// triangles (MeshParams; `crossings_everywhere`), else those it left among the triangles it examined
  /// (near forks; FoldRepairStats::left).
  std::vector<Crossing> crossings;
  bool crossings_counted = false;
  bool crossings_everywhere = true;
  /// Every position is a multiple of this power of two (core/mesh.h float_grid), so that the
  /// exported float32 mesh is the mesh checked (0: not snapped).
  double grid = 0;
};

/// Throws InvalidInputError naming the first parameter out of its range ("meshing.uv_repeat_u
/// must be > 0, got 0"). build_mesh checks its parameters with it; the pipeline checks them
/// before its first stage.
void validate_params(const MeshParams& params);

/// Builds the branch mesh from the contour loops.
/// Precondition: `contours` was computed for `skeleton`.
MeshResult build_mesh(const Skeleton& skeleton, const ContourSet& contours, const MeshParams& params = {},
                      const ProgressFn& progress = {});

/// Triangulates the band between two closed loops of vertex ids (both counter-clockwise seen
/// from the tip side; `lower` nearer the root) with the greedy shortest-diagonal rule, starting
/// at the pair (lower[0], upper[0]). Appends outward-facing triangles to `out`.
/// Exposed for tests.
void stitch_loops(const std::vector<std::uint32_t>& lower, const std::vector<std::uint32_t>& upper,
                  const std::vector<glm::dvec3>& positions, std::vector<Mesh::Triangle>& out);

/// Branch fusion: triangulates the pair of pants between `lower` and the two upper loops
/// (vertex ids, all counter-clockwise seen from the tip side; `tangent` points up the parent
/// branch). Every loop edge is used once and every new edge twice, in opposite directions.
/// Preconditions: each loop has at least 3 vertices; the loops share no vertex.
void fuse_loops(const std::vector<std::uint32_t>& lower, const std::vector<std::uint32_t>& upper_main,
                const std::vector<std::uint32_t>& upper_lateral, const std::vector<glm::dvec3>& positions,
                const glm::dvec3& tangent, std::vector<Mesh::Triangle>& out);

}  // namespace sm
