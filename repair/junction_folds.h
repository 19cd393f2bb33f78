#pragma once
/// Step 1 of the repair stage: the fold repair (fold_repair.h) on the stitched surface where
/// it folds most, the triangles of the junctions and the strips touching a fused or split loop
/// (caps and plain strips rarely fold, and caps are a large share of a big tree's triangles);
/// then the count of the self-intersecting pairs left, which the later steps start from.

#include <array>
#include <cstddef>
#include <vector>

#include <glm/glm.hpp>

#include "contours/contours.h"
#include "core/ids.h"
#include "core/mesh.h"
#include "core/report.h"
#include "meshing/meshing.h"
#include "skeleton/skeleton.h"

namespace sm {

struct RepairParams;

/// A self-intersecting pair of triangles: the mean of their six corners, and the skeleton node
/// whose edge or section made each corner (Mesh::vertex_node).
struct Crossing {
  glm::dvec3 at{0.0};
  std::array<NodeId, 6> nodes{};
};

/// The Crossing of triangles f and g of `mesh` (nodes left invalid without Mesh::vertex_node).
Crossing crossing_of(const Mesh& mesh, std::uint32_t f, std::uint32_t g);

/// The self-intersecting pairs of the mesh as far as they were counted. Counted when a later
/// step needs them (RepairParams::fork_retry, outer_surface, junction_fold_variants) and the
/// fold repair did not stop: over the whole mesh on meshes of at most
/// RepairParams::count_pairs_up_to triangles (`everywhere`), else those it left among the
/// triangles it examined (FoldRepairStats::left).
struct Crossings {
  std::vector<Crossing> pairs;
  bool counted = false;
  bool everywhere = true;
};

struct JunctionFoldStats {
  std::size_t found = 0;      ///< self-intersecting pairs found near the junctions
  std::size_t flips = 0;      ///< edge flips made
  std::size_t moves = 0;      ///< vertices moved
  std::size_t collapses = 0;  ///< edges collapsed
  std::size_t refills = 0;    ///< disks replaced by a triangulation of their boundary
};

/// Repairs the folds of `mesh` (stitch_mesh's result for `contours`, whose vertex numbering it
/// still has) in place and counts the pairs left into `crossings`; warnings go to `warnings`.
JunctionFoldStats repair_junction_folds(StitchedMesh& mesh, const Skeleton& skeleton, const ContourSet& contours,
                                        const RepairParams& params, Crossings& crossings, Warnings& warnings);

}  // namespace sm
