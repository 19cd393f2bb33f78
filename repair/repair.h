#pragma once
/// Repair stage: makes the built surface clean where the contours alone could not, without
/// moving the skeleton. Branches that cross or touch away from their fork, and folds at tight
/// crotches, hubs and hairpins, leave the stitched surface intersecting itself; every
/// intersecting pair is found over the whole mesh, and the surface there is replaced by the
/// boundary of the union of the solids it wraps (self_union.h). Where crossings close a loop
/// the union has a handle: genus > 0 is then the truth, not a defect.
///
/// The cost is one pass over the mesh for the pairs and one for the winding numbers per round,
/// plus work that grows with the triangles cut; rounds repeat only where snapping the new
/// vertices to the float grid made new pairs.

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/param_table.h"
#include "core/report.h"
#include "meshing/meshing.h"
#include "skeleton/skeleton.h"

namespace sm {

struct RepairParams {
  /// Replace self-intersecting parts of the surface by their union (false: leave them).
  bool self_union = true;
  /// Rounds of finding pairs and cutting them (a count; a round after the first only meets
  /// pairs made by rounding the cut lines' vertices to the float grid).
  std::uint32_t max_rounds = 4;
  /// Rounds of fold repair (flips, moves, collapses) on pairs within two rings of each other,
  /// before the union (0 = none).
  std::uint32_t fold_rounds = 8;
  /// Largest vertex move of the fold repair, relative to the local skeleton radius.
  double fold_max_move = 0.25;
  /// Largest mesh (triangles) whose pairs are looked for over the whole mesh; a larger one
  /// skips the repair stage (a count over 3.5 M triangles takes seconds; the meshing stage's
  /// fold repair has looked near the junctions). configs/high_detail.json counts every mesh.
  std::size_t count_pairs_up_to = 300'000;
};

/// The config key, accepted range, unit and help of each field of RepairParams, in header order
/// (core/param_table.h; the defaults are the initializers above).
const ParamTable<RepairParams>& param_table(std::type_identity<RepairParams>);

struct RepairStats {
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
  std::string problem;             ///< why a round was refused (empty: none was)
  Warnings warnings;
  Timings timings;
};

/// Throws InvalidInputError naming the first parameter out of its range.
void validate_params(const RepairParams& params);

/// Repairs `mesh` in place (positions, triangles and their attributes, triangle kinds).
/// Precondition: `mesh` is closed, edge-manifold and oriented outward (build_mesh's result).
RepairStats repair_mesh(MeshResult& mesh, const Skeleton& skeleton, const RepairParams& params = {});

}  // namespace sm
