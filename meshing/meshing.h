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
///  - Normals are computed on the finished mesh (angle-weighted). UVs: u is the distance around
///    the branch (its loop's arc length), v the distance along it, both over uv_metres, and
///    each loop continues the UVs of the loop below it, through the forks too: a child's strands
///    take u and v from where they were on the parent's last loop (see compute_uvs in
///    meshing.cpp). One seam per branch, where u wraps; at a fork it goes on into the child it
///    is nearer to, and the other child's starts at its crotch. Seams are per-corner UVs only.
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
  /// With uv_metres = 0: texture repeats once around every branch (u over uv_repeat_u per turn).
  double uv_repeat_u = 1.0;
  /// Texture size in metres: u is the distance around the branch and v the distance along it
  /// over this, so texels are square and of one size on thick and thin branches (docs/defaults.md:
  /// why 0.2). 0 = u once around every branch (uv_repeat_u times), v over the circumference.
  double uv_metres = 0.2;
  /// Compute per-corner UVs.
  bool uvs = true;
  /// Compute smooth vertex normals.
  bool normals = true;
  /// Mesh a junction whose child tube is a single loop ending in another junction (forks a
  /// fraction of a slice apart) as one junction with three or more upper loops, skipping that
  /// loop: the stacked binary crotches would overlap (see fuse_many in meshing.cpp).
  bool merge_stacked_junctions = true;
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
  std::size_t bad_edges = 0;         ///< edges not shared by exactly two triangles (0 unless a bug)
  Warnings warnings;
  Timings timings;
};

/// Which construction made a triangle (for debugging and the viewer).
enum class TriangleKind : std::uint8_t { strip, fusion, tip_cap, root_cap };

struct MeshResult {
  Mesh mesh;
  std::vector<TriangleKind> triangle_kind;  ///< #F
  MeshStats stats;
  /// Every position is a multiple of this power of two (core/mesh.h float_grid), so that the
  /// exported float32 mesh is the mesh checked (0: not snapped).
  double grid = 0;
};

/// The surface as stitched, before finish_mesh completes it. Its vertices are the contour
/// points (same indices), then the caps' ring and apex vertices and the root's base centre;
/// those of loops skipped between merged junctions are used by no triangle. Between the two
/// calls a repair may move vertices (onto the float grid, `grid`) and replace triangles,
/// keeping their count and their branch and kind entries (a removed triangle becomes
/// (u, u, u)), but add no vertex: the repair stage untangles folds near the forks here
/// (repair/fold_repair.h), on the contours' numbering and before the normals and UVs are made.
struct StitchedMesh {
  Mesh mesh;  ///< positions, triangles, triangle_branch, vertex_node, vertex_strand (no normals, no UVs)
  std::vector<TriangleKind> triangle_kind;  ///< #F
  /// Per vertex: u (around the branch), v (along it) and the u of one turn, from which the
  /// corner UVs are made (a triangle across the seam lifts its small u by one turn).
  std::vector<double> vertex_u, vertex_v, vertex_period;
  /// Per vertex: 1 for a cap's apex or base centre, where u meets (half a turn from the seam).
  std::vector<std::uint8_t> vertex_pole;
  MeshStats stats;
  double grid = 0;  ///< as MeshResult::grid
};

/// Throws InvalidInputError naming the first parameter out of its range ("meshing.uv_repeat_u
/// must be > 0, got 0"). build_mesh checks its parameters with it; the pipeline checks them
/// before its first stage.
void validate_params(const MeshParams& params);

/// Builds the branch mesh from the contour loops: finish_mesh(stitch_mesh(...)).
/// Precondition: `contours` was computed for `skeleton`.
MeshResult build_mesh(const Skeleton& skeleton, const ContourSet& contours, const MeshParams& params = {},
                      const ProgressFn& progress = {});

/// The first half of build_mesh: strips, fusions and caps, every vertex on the float grid.
StitchedMesh stitch_mesh(const Skeleton& skeleton, const ContourSet& contours, const MeshParams& params = {},
                         const ProgressFn& progress = {});

/// The second half: drops the triangles left as (u, u, u) and the vertices no triangle uses
/// (the rest keep their order, but for the last ones, which fill the gaps), then computes the
/// normals and corner UVs (as `params` asks) and checks the topology (MeshStats::bad_edges).
MeshResult finish_mesh(StitchedMesh stitched, const MeshParams& params = {});

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
