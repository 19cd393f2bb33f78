#pragma once
/// Quality measures of a particle field: what the tests assert, the benchmark and
/// `strandmesh particles` print, and the viewer can show per node.
///
/// Every measure is relative to the spacing s or to a cloud's own length
/// lambda_n = radius[n] / sqrt(count(n)) (= s at the nominal density; smaller in thin tips
/// packed with min_particles particles, larger in clouds that are sparse but not yet sparse
/// enough for new strands):
///  - containment: every particle lies inside its node's disc (|p| <= radius[n]);
///  - closest pair: the smallest distance between two particles of one cloud, relative to
///    min(s, lambda_n), i.e. to the local spacing where a cloud is denser than s;
///  - holes: the radius of the largest empty circle whose centre lies in the confining disc
///    (disc_radius[n]), relative to s; a hexagonal packing at the nominal density has 1.10 s;
///  - neighbourhoods: for each particle j of a non-root node n (an "event" = one strand on one
///    edge), its k nearest neighbours among n's particles are compared with the k nearest
///    neighbours of the same strand in the parent, among the same strands (the parent's block
///    of n's particles; strands of the sibling and new strands are not counted, they are not
///    lost neighbours). The event is a loss when more than half of the k are different.
///    With fewer than k + 1 particles k shrinks to count - 1.

#include <cstdint>
#include <limits>
#include <vector>

#include "core/ids.h"
#include "particles/particles.h"
#include "skeleton/skeleton.h"

namespace sm {

struct QualityParams {
  /// k of the neighbourhoods compared from node to parent (a count, default 6).
  std::uint32_t neighbours = 6;
  /// Compute the largest empty circles (the most expensive measure; default true).
  bool holes = true;
  /// Sampling step of the largest-empty-circle search before local refinement (relative to
  /// lambda_n, default 0.35; the refinement brings the error well below 0.01 s).
  double hole_sample = 0.35;
};

struct ParticleQuality {
  static constexpr double inf = std::numeric_limits<double>::infinity();
  double max_radius_ratio = 0;    ///< max over particles of |p| / radius[n] (< 1: all inside)
  double min_pair = inf;          ///< min over clouds of closest pair / min(s, lambda_n)
  NodeId min_pair_node;           ///< where min_pair occurs
  double min_pair_s = inf;        ///< min over clouds with lambda_n >= s of closest pair / s
  double median_nearest = 0;      ///< median over particles of the nearest-neighbour distance / s
  double max_hole = 0;            ///< max over clouds of the largest empty circle radius / s
  NodeId max_hole_node;           ///< where max_hole occurs
  std::size_t neighbour_events = 0;   ///< (strand, edge) pairs compared
  std::size_t neighbour_losses = 0;   ///< of those, how many lost more than half of their k
  std::size_t fork_events = 0;        ///< events on the child edges of forks
  std::size_t fork_losses = 0;        ///< losses among them
  std::size_t strands_with_loss = 0;  ///< strands with at least one loss anywhere on their path
  std::vector<double> node_min_pair;  ///< #N closest pair / min(s, lambda_n) (inf for one particle)
  std::vector<double> node_hole;      ///< #N largest empty circle radius / s (0 when not computed)
  std::vector<std::uint32_t> node_losses;  ///< #N losses on the edge from n to its parent

  [[nodiscard]] double loss_fraction() const {
    return neighbour_events ? double(neighbour_losses) / double(neighbour_events) : 0.0;
  }
  [[nodiscard]] double fork_loss_fraction() const {
    return fork_events ? double(fork_losses) / double(fork_events) : 0.0;
  }
};

/// Measures `field` (computed for `skeleton`). Parallel over nodes; the result does not depend
/// on the thread count.
ParticleQuality measure_particles(const Skeleton& skeleton, const ParticleField& field,
                                  const QualityParams& params = {});

}  // namespace sm
