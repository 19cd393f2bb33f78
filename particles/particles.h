#pragma once
/// Particles stage: one 2D particle cloud per skeleton node, computed bottom-up.
///
/// Every branch is a bundle of strands; every node's cross-section holds one particle per
/// strand passing through it (DESIGN.md particles/, seed 003 §2.3). Tips get a fresh cloud;
/// a node with one child carries the child's cloud into its own frame and fits it to its
/// radius; a fork projects both children's clouds onto its plane side by side and fits the
/// union; new strands start where a carried cloud is too sparse for the node's radius; each
/// cloud is then relaxed by a 2D repulsion simulation confined to the node's disc.
///
/// Particle order inside a node is part of the contract, so strands can be followed without
/// lookups: at node n with children c0 (main) and c1 (lateral), the particles are
///   [ the particles of c0, in c0's order | those of c1, in c1's order | new strands ].
/// Hence particle j of child c is particle `parent_index(c, j)` of its parent.

#include <cstdint>
#include <vector>

#include "core/ids.h"
#include "core/math.h"
#include "core/progress.h"
#include "core/report.h"
#include "skeleton/skeleton.h"

namespace sm {

struct ParticleParams {
  /// Particle spacing s in metres: the typical distance between neighbouring strands.
  /// 0 = derived from the skeleton (see `root_strands` and the .cpp for the rule).
  double spacing = 0.0;
  /// When `spacing` is 0 and this is > 0: choose s so that the root carries about this many
  /// strands (a count). 0 = derive s from the radius distribution alone.
  std::uint32_t root_strands = 0;
  /// Fewest particles in any tip cloud (a count, >= 3).
  std::uint32_t min_particles = 5;
  /// A node whose carried cloud is sparser than this many spacings (mean nearest-neighbour
  /// distance relative to s, after fitting) gets new strands to restore density.
  double new_strand_sparsity = 1.6;
  /// Relaxation: largest number of steps per node (a count).
  std::uint32_t max_steps = 40;
  /// Relaxation stops when the largest move of a step is below this (relative to s).
  double move_tolerance = 0.02;
  /// Largest distance a particle moves in one step (relative to s): the velocity cap.
  double max_velocity = 0.15;
  /// Velocity damping per step in [0, 1): 0 = no memory of the previous step.
  double damping = 0.3;
  /// Particles repel each other within this distance (relative to s).
  double repulsion_radius = 1.5;
  /// Neighbour lists are rebuilt every k steps (a count).
  std::uint32_t rebuild_every = 4;
  /// Extra gap between the two child clouds at a fork before fitting (relative to s).
  double fork_gap = 1.0;
  /// Random seed (tip patterns, new strands); per-node streams derive from (seed, node).
  std::uint64_t seed = 1;
};

struct ParticleStats {
  std::size_t nodes = 0;
  std::size_t strands = 0;
  std::size_t particles = 0;         ///< sum over nodes of the cloud sizes (as the paper counts)
  std::size_t new_strands = 0;       ///< strands started at interior nodes
  std::size_t relaxation_steps = 0;  ///< summed over nodes
  Warnings warnings;                 ///< degenerate forks, tiny nodes, ...
  Timings timings;                   ///< "tips", "projection", "relaxation", ...
};

/// The particle clouds of every node (structure of arrays; #N nodes, #P particles in total,
/// #S strands).
struct ParticleField {
  double spacing = 0;                       ///< the spacing s used (metres)
  std::vector<std::uint32_t> node_begin;    ///< #N+1: node n owns particles [node_begin[n], node_begin[n+1])
  std::vector<dvec2> position;              ///< #P 2D position in the node's frame (normal, binormal), metres
  std::vector<StrandId> strand;             ///< #P strand of each particle
  std::vector<std::uint32_t> new_begin;     ///< #N local index of the first new strand at node n
                                            ///< (= count(c0) + count(c1))
  std::vector<std::uint32_t> steps;         ///< #N relaxation steps taken at node n
  std::vector<NodeId> strand_start;         ///< #S node where each strand starts (a tip, or the
                                            ///< interior node where it was added)
  ParticleStats stats;

  [[nodiscard]] std::size_t node_count() const { return node_begin.empty() ? 0 : node_begin.size() - 1; }
  [[nodiscard]] std::uint32_t count(NodeId n) const { return node_begin[n.idx() + 1] - node_begin[n.idx()]; }
  /// Global particle index of local particle j of node n.
  [[nodiscard]] std::uint32_t global(NodeId n, std::uint32_t j) const { return node_begin[n.idx()] + j; }
};

/// Local index, in the parent of `child`, of local particle j of `child`.
/// Precondition: child is not the root.
std::uint32_t parent_index(const Skeleton& skeleton, const ParticleField& field, NodeId child, std::uint32_t j);

/// Computes the particle clouds of every node, bottom-up, in parallel over independent
/// subtrees; the result is bit-identical for any thread count.
/// Precondition: `skeleton` satisfies validate_binary_skeleton().
ParticleField compute_particles(const Skeleton& skeleton, const ParticleParams& params = {},
                                const ProgressFn& progress = {});

}  // namespace sm
