#pragma once
/// Levels of detail: the same tree meshed again, coarser, by the whole pipeline, so that every
/// level is closed, manifold and free of self-intersections like the full mesh (simplifying
/// the finished mesh, e.g. with meshoptimizer's simplifier, can break both: a collapsed edge
/// may pinch the surface or push it through a neighbouring branch).
///
/// Level k (1, 2, ...) of a run with parameters P:
///  - twigs thinner than `prune_radius` x 4^(k-1) x the root's radius are pruned from the
///    skeleton (the node and all beyond it go; a branch ends, capped, at its last node that is
///    thick enough), so thin twigs vanish instead of collapsing into spikes;
///  - the root gets 1/4^k of P's strands (particles.max_root_strands and root_strands; the
///    particle spacing doubles per level) and slices 2^k times P's slice_step apart (at most
///    `max_slice_step`);
/// and the whole pipeline runs on that. Level 0 is P itself.
///
/// Where that run keeps self-intersecting pairs the repair stage could not remove (junctions
/// that fold at the coarser resolution), the level is instead the next finer level simplified
/// (lod/simplify.h: edge collapses that never make a crossing) to the same triangle count,
/// when that has fewer pairs: a level made from a clean finer level is clean.

#include <cstdint>
#include <vector>

#include "pipeline/pipeline.h"

namespace sm {

struct LodParams {
  std::uint32_t levels = 1;            ///< levels in all, the full mesh included (1 = no LODs)
  double prune_radius = 0.01;          ///< level 1 prunes twigs thinner than this x the root radius (relative)
  std::uint32_t min_root_strands = 24;  ///< fewest strands at the root of any level (a count)
  double max_slice_step = 4.0;         ///< coarsest slice step (x the local radius)
};

/// One coarser level's input: the pruned skeleton and the coarser parameters.
struct LodLevel {
  RawSkeleton skeleton;     ///< the input without its thinnest twigs
  PipelineParams params;    ///< the run's parameters, coarser
  double min_radius = 0;    ///< twigs thinner than this were pruned (metres)
  std::size_t pruned = 0;   ///< nodes pruned
  std::size_t rerun_pairs = 0;  ///< self-intersecting pairs the pipeline's run left (before any fallback)
  std::size_t pairs = 0;        ///< self-intersecting pairs of the level's mesh (counted over the whole mesh)
  bool simplified = false;  ///< the level is the finer level simplified (the run kept pairs)
};

/// The input of level `level` (>= 1) of `raw` meshed with `params`. Throws InvalidInputError
/// when the skeleton has no root.
LodLevel lod_level(const RawSkeleton& raw, const PipelineParams& params, std::uint32_t level, const LodParams& lod = {});

/// Meshes level `level` (>= 1): lod_level(), then the pipeline. Where the coarser slices leave
/// self-intersecting pairs the repair could not remove (RepairStats::pairs_left), the level is
/// meshed again with the run's own slice step (only fewer strands and the pruning), and the
/// result with fewer pairs is kept. Where that still has pairs and `finer` (the result of
/// level - 1: the full run for level 1) is given, `finer`'s mesh simplified to the same
/// triangle count (simplify_mesh) replaces it if it has fewer pairs; the result is then a
/// copy of `finer` (its skeleton, which the mesh's vertex nodes refer to) with that mesh.
/// `used` receives the input of the kept run.
PipelineResult mesh_lod(const RawSkeleton& raw, const PipelineParams& params, std::uint32_t level,
                        const LodParams& lod = {}, const ProgressFn& progress = {}, LodLevel* used = nullptr,
                        const PipelineResult* finer = nullptr);

/// `raw` without the nodes thinner than `min_radius` and everything beyond them (the root is
/// always kept, and so is the root's first child, so that a tree keeps an edge). Ids, order
/// and everything else are kept. `pruned` receives the number of nodes removed.
RawSkeleton prune_thin_branches(const RawSkeleton& raw, double min_radius, std::size_t* pruned = nullptr);

}  // namespace sm
