#pragma once
/// Particles stage: one 2D particle cloud per skeleton node, computed bottom-up.
///
/// Every branch is a bundle of strands; every node's cross-section holds one particle per
/// strand passing through it (as in Interactive Invigoration, Li et al.). Tips get a fresh cloud;
/// a node with one child carries the child's cloud into its own frame and fits it to its
/// radius; a fork places both children's clouds side by side in its plane, each in the part
/// of the disc on its child's side, and fits the union; new strands start where a carried
/// cloud is too sparse for the node's radius; each cloud is then relaxed by a 2D repulsion
/// simulation confined to the node's disc.
///
/// Particle order inside a node is part of the contract, so strands can be followed without
/// lookups: at node n with children c0 (main) and c1 (lateral), the particles are
///   [ the particles of c0, in c0's order | those of c1, in c1's order | new strands ].
/// Hence particle j of child c is particle `parent_index(c, j)` of its parent.
///
/// Units. The spacing s is a density length: a cloud at the nominal density holds one
/// particle per pi s^2 of cross-section, so a tip of radius r gets (r / s)^2 particles
/// In a relaxed cloud neighbouring particles are then about 1.7 to
/// 1.9 s apart (a hexagonal packing at that density has its neighbours 1.905 s apart); the
/// field `neighbour_distance` gives the typical value for later stages. Every cloud is
/// simulated in units of its own length lambda = r / sqrt(count) (= s at the nominal
/// density), which makes the simulation scale-invariant: a relaxed cloud that is only
/// rotated and scaled into the next node is still relaxed there.
///
/// Strand ids are numbered by start node index, then by local index at the start node:
/// strand ids [strand_begin(n), strand_begin(n) + new strands of n) start at node n.
///
/// Determinism: the output (everything but `stats.timings`) is bit-identical for any thread
/// count and across runs: each node reads only its children's finished clouds and its own
/// random stream derive_seed(seed, node).

#include <cstdint>
#include <vector>

#include "core/param_table.h"
#include "core/ids.h"
#include "core/math.h"
#include "core/progress.h"
#include "core/report.h"
#include "skeleton/skeleton.h"

namespace sm {

struct ParticleParams {
  /// Largest root_strands and max_root_strands accepted (a count): 100,000 strands at the
  /// root is 25 times the default; 1e8 on a 4-node tree grew past 5 GB before.
  static constexpr std::uint32_t kMaxRootStrands = 100'000;
  /// Largest min_particles accepted (a count).
  static constexpr std::uint32_t kMaxMinParticles = 10'000;
  /// Particle spacing s (metres): a cloud at the nominal density holds one particle per
  /// pi s^2 of cross-section. 0 = derived (default): the median tip radius over
  /// sqrt(min_particles), raised when needed so the root carries at most `max_root_strands`.
  double spacing = 0.0;
  /// When `spacing` is 0 and this is > 0: choose s so that the root carries about this many
  /// strands (a count; bisection on s). 0 = use the derived rule above (default).
  std::uint32_t root_strands = 0;
  /// Upper bound on the root's strand count for the derived spacing (a count, default 4000);
  /// keeps big real trees fast. Ignored when `spacing` or `root_strands` is set.
  std::uint32_t max_root_strands = 4000;
  /// Fewest particles in any tip cloud (a count, >= 3; default 5).
  std::uint32_t min_particles = 5;
  /// A node whose carried cloud is sparser than this (its length r / sqrt(count) relative to
  /// s) gets new strands up to its nominal count max(min_particles, round((r / s)^2))
  /// (default 1.15; must be >= 1; keeps the largest empty circle of any cloud near 2 s).
  double new_strand_sparsity = 1.15;
  /// Gap between the confining disc and the node radius, relative to the cloud length lambda
  /// (default 0): no particle is ever farther than r - wall_margin * lambda from the node
  /// centre (disc_radius).
  double wall_margin = 0.0;
  /// Soft wall: a particle is repelled by its mirror image across a circle this far outside
  /// the confining disc (relative to lambda, default 0.5); the outer ring of a relaxed cloud
  /// then settles about 0.5 lambda inside the confining disc.
  double wall_offset = 0.5;
  /// Relaxation: largest number of steps per node (a count, default 40).
  std::uint32_t max_steps = 40;
  /// Relaxation stops when the largest move of a step is below this (relative to lambda,
  /// default 0.05).
  double move_tolerance = 0.05;
  /// Largest distance a particle moves in one step (relative to lambda): the velocity cap
  /// (default 0.15).
  double max_velocity = 0.15;
  /// Velocity damping per step in [0, 1): the fraction of the previous step's velocity that
  /// is kept; 0 = no memory of the previous step (default 0.3).
  double damping = 0.3;
  /// Displacement per step per unit of repulsion force (relative to lambda, default 0.2). The
  /// pair force is (h^2 / d - d) / 2h for d < h (h = repulsion_radius): zero at h, about
  /// (1 - d/h) near it, unbounded as d -> 0.
  double step_size = 0.2;
  /// Particles repel each other within this distance (relative to lambda, default 2.7; the
  /// hexagonal neighbour distance is 1.905, so every particle feels its ring of neighbours
  /// firmly, and a hole is never wide enough to go unnoticed).
  double repulsion_radius = 2.7;
  /// Neighbour lists hold the pairs within repulsion_radius + neighbour_skin (relative to
  /// lambda, default 0.75) and are rebuilt as soon as the particles may have closed the skin
  /// (twice the summed largest moves since the last rebuild), so no pair is ever missed.
  double neighbour_skin = 0.75;
  /// ... and at the latest every k steps (a count, default 16).
  std::uint32_t rebuild_every = 16;
  /// Empty band between the two child bundles at a fork before relaxation (relative to the
  /// parent's lambda, default 0: the bundles are placed adjacent; a band is left as a hole
  /// when the relaxation settles early).
  double fork_gap = 0.0;
  /// Upper bound on the total particle count (sum over nodes) before anything is allocated;
  /// more throws InvalidInputError (a count, default 500 million).
  std::uint64_t max_total_particles = 500'000'000;
  /// Random seed (tip patterns, new strands); per-node streams derive from (seed, node).
  std::uint64_t seed = 1;
};

/// The config key, accepted range, unit and help of each field of ParticleParams, in header order
/// (core/param_table.h; the defaults are the initializers above).
const ParamTable<ParticleParams>& param_table(std::type_identity<ParticleParams>);

struct ParticleStats {
  std::size_t nodes = 0;
  std::size_t strands = 0;
  std::size_t particles = 0;          ///< sum over nodes of the cloud sizes (as the paper counts)
  std::size_t new_strands = 0;        ///< strands started at interior nodes
  std::size_t relaxation_steps = 0;   ///< summed over nodes
  std::size_t relaxed_nodes = 0;      ///< nodes that ran at least one relaxation step
  std::size_t relaxed_particles = 0;  ///< sum of the cloud sizes of those nodes
  std::size_t unconverged_nodes = 0;  ///< nodes that used the whole step budget
  Warnings warnings;                  ///< degenerate forks, thin tips, ...
  /// "spacing", "layout", "clouds" (wall clock, seconds), and the per-phase CPU time summed
  /// over worker threads inside "clouds": "tips_cpu", "placement_cpu", "relaxation_cpu".
  Timings timings;
};

/// The particle clouds of every node (structure of arrays; #N nodes, #P particles in total,
/// #S strands).
struct ParticleField {
  double spacing = 0;                       ///< the spacing s used (metres)
  double neighbour_distance = 0;            ///< typical distance between neighbouring particles
                                            ///< at the nominal density (metres, 1.9 s)
  std::vector<std::uint32_t> node_begin;    ///< #N+1: node n owns particles [node_begin[n], node_begin[n+1])
  std::vector<dvec2> position;              ///< #P 2D position in the node's frame (normal, binormal), metres
  std::vector<StrandId> strand;             ///< #P strand of each particle
  std::vector<std::uint32_t> new_begin;     ///< #N local index of the first new strand at node n
                                            ///< (= count(c0) + count(c1))
  std::vector<std::uint32_t> steps;         ///< #N relaxation steps taken at node n
  std::vector<double> disc_radius;          ///< #N radius of the disc the particles of n are
                                            ///< confined to (metres, < radius[n])
  std::vector<std::uint32_t> strand_begin;  ///< #N+1: strands [strand_begin[n], strand_begin[n+1])
                                            ///< start at node n
  std::vector<NodeId> strand_start;         ///< #S node where each strand starts (a tip, or the
                                            ///< interior node where it was added)
  ParticleStats stats;

  [[nodiscard]] std::size_t node_count() const { return node_begin.empty() ? 0 : node_begin.size() - 1; }
  [[nodiscard]] std::size_t strand_count() const { return strand_start.size(); }
  [[nodiscard]] std::uint32_t count(NodeId n) const { return node_begin[n.idx() + 1] - node_begin[n.idx()]; }
  /// Global particle index of local particle j of node n.
  [[nodiscard]] std::uint32_t global(NodeId n, std::uint32_t j) const { return node_begin[n.idx()] + j; }
  /// Local index of strand `s` at its start node (new strands follow new_begin in id order).
  [[nodiscard]] std::uint32_t start_local(StrandId s) const {
    const NodeId n = strand_start[s.idx()];
    return new_begin[n.idx()] + (s.value - strand_begin[n.idx()]);
  }
};

/// Local index, in the parent of `child`, of local particle j of `child`.
/// Precondition: child is not the root.
std::uint32_t parent_index(const Skeleton& skeleton, const ParticleField& field, NodeId child, std::uint32_t j);

/// The spacing s that compute_particles() would use for these parameters (metres), and the
/// strand count the root would then carry. Cheap: O(#N) per bisection step, no geometry.
/// Throws InvalidInputError for invalid parameters (see compute_particles).
struct SpacingChoice {
  double spacing = 0;
  std::size_t root_strands = 0;
};
SpacingChoice choose_spacing(const Skeleton& skeleton, const ParticleParams& params = {});

/// Computes the particle clouds of every node, bottom-up, in parallel over independent
/// subtrees; the result is bit-identical for any thread count.
/// Precondition: `skeleton` satisfies validate_binary_skeleton() and is not empty.
/// Throws InvalidInputError when a parameter is out of range (min_particles < 3, negative
/// spacing, new_strand_sparsity < 1, ...) or the particle count would exceed
/// max_total_particles (the message names the count and how to lower it).
/// Degenerate geometry (colinear or coincident fork children, children pointing back into
/// their parent, tips thinner than one spacing) gets a placement and a counted warning.
ParticleField compute_particles(const Skeleton& skeleton, const ParticleParams& params = {},
                                const ProgressFn& progress = {});

}  // namespace sm
