#pragma once
/// \file fold_repair.h
/// Fold repair: removes local self-intersections of a closed triangle mesh by edge flips and,
/// where no flip helps, small vertex moves (steps 1 and 5 of the repair stage; the exact tests
/// come from sm_meshcheck's TriangleIntersections).
///
/// Where loops of very different shape are stitched (fused loops above a fork, split loops,
/// crotches), the greedy strips can fold: a triangle dips behind its neighbours and crosses
/// them. Most such pairs lie within a ring or two of each other (docs/defaults.md), and
/// another triangulation of the same vertices is free of the crossing.
/// The repair finds the intersecting pairs around the creases of the `suspect` triangles
/// (exact predicates) and flips an edge of either triangle whenever that lowers the number of
/// crossings with the triangles around it, keeping both new triangles facing the way the old
/// pair did; a flip keeps the mesh closed, manifold and of the same genus. Where no flip helps,
/// a vertex of the pair moves a bounded step towards the centroid of its neighbours under the
/// same rule (no triangle turned over). Deterministic: pairs are visited in sorted order,
/// serially.

#include <cstdint>
#include <span>
#include <unordered_set>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "core/mesh.h"

namespace sm {

struct FoldRepairStats {
  std::size_t found = 0;      ///< intersecting pairs among the suspect triangles before the repair
  std::size_t flips = 0;      ///< edge flips made
  std::size_t moves = 0;      ///< vertices moved
  std::size_t collapses = 0;  ///< edges collapsed (each removes a vertex and two triangles)
  std::size_t refills = 0;    ///< disks around a pair replaced by a triangulation of their boundary
  std::size_t rounds = 0;     ///< detection rounds run
  bool gave_up = false;       ///< more pairs than FoldRepairOptions::max_pairs: not repaired (or stopped)
  bool out_of_tests = false;  ///< stopped when its triangle tests ran over the budget
  /// The pairs it handled that still intersect at the end (sorted; triangle indices): the
  /// pairs left among the triangles it examined. Pairs elsewhere, and pairs its last round's
  /// changes made, are not in it.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> left;
};

/// Where a vertex move also tries towards its branch's axis (FoldRepairOptions::axis_point).
enum class AxisTargets : std::uint8_t { none, last, first };

/// The values repair_folds changed, from before it ran: each triangle and vertex once.
struct FoldRepairUndo {
  std::vector<std::pair<std::uint32_t, Mesh::Triangle>> triangles;
  std::vector<std::pair<std::uint32_t, glm::dvec3>> positions;
  std::unordered_set<std::uint32_t> triangle_seen, position_seen;
  /// Puts them back in `mesh` and keeps the repaired values instead: a second swap redoes
  /// the repair.
  void swap_with(Mesh& mesh) {
    for (auto& [f, t] : triangles) std::swap(mesh.triangles[f], t);
    for (auto& [v, p] : positions) std::swap(mesh.positions[v], p);
  }
};

struct FoldRepairOptions {
  /// Detection rounds (after the first, only around the triangles the previous round changed).
  int max_rounds = 8;
  /// A mesh whose suspect triangles have more intersecting pairs than this at the start is
  /// left as it is (gave_up): its branches run through each other, which no local change
  /// untangles, and which would take hours. The rounds also stop once they have handled 4 x
  /// this many pairs together. (Figures: docs/defaults.md.)
  std::size_t max_pairs = 20'000;
  /// Budget of exact triangle-pair tests: this many per triangle of the mesh, plus
  /// min_tests; beyond, the repair stops where it is (out_of_tests): far above what trees
  /// need, far below what a tangle of twigs from one node would take.
  std::size_t max_tests_per_triangle = 200;
  std::size_t min_tests = 5'000'000;
  /// Where flips and moves do not help, collapse an edge of the pair or of a triangle sharing
  /// a vertex with it (FoldRepair::try_collapse).
  bool collapse = true;
  /// Where nothing else helped, replace a disk of triangles around the pair by a
  /// triangulation of its boundary (FoldRepair::refill).
  bool refill = true;
  /// Points that must stay on their side of the surface (the skeleton's nodes): a collapse
  /// or refill that would carry the surface across one (its winding number changes) is
  /// refused, so neither cuts off part of a branch.
  std::span<const glm::dvec3> keep_side;
  /// Per vertex (#V, or empty): the nearest point on the axis of the branch that made it. A
  /// vertex move also tries half and all of its limit towards it, before (first) or after
  /// (last) the other targets.
  std::span<const glm::dvec3> axis_point;
  AxisTargets axis_targets = AxisTargets::none;
  /// When > 0, every position the repair writes is rounded to a multiple of this (the float
  /// grid, core/mesh.h), so that the mesh it judges is the one exported.
  double grid = 0;
};

/// Repairs `mesh` in place; triangles keep their index (a flip rewrites the two triangles of
/// the edge, which keep their branch ids). `suspect[f]` marks the triangles that may fold
/// (#F); those with a crease and the triangles sharing a vertex with them are examined, and
/// each flip is judged against every triangle within two rings of the pair.
/// Where no flip helps, a vertex of the pair may move towards the centroid of its neighbours
/// by at most `max_move[v]` (#V; 0 keeps it in place) when that lowers the crossings the same
/// way; then collapses and refills (see FoldRepairOptions). The triangles these remove are
/// left degenerate, as (u, u, u), for the caller to drop, and the vertices they remove are
/// no longer used.
FoldRepairStats repair_folds(Mesh& mesh, const std::vector<std::uint8_t>& suspect, const std::vector<double>& max_move,
                             const FoldRepairOptions& options, FoldRepairUndo* undo = nullptr);

}  // namespace sm
