#pragma once
/// The simple seeded random grower: the built-in default tree.
///
/// Grows from the root upwards; every node gets one or two children with random rotations
/// and random lengths. The chance of two children grows with depth, the angle between two
/// children is kept from being too small, main and lateral children draw their radii from
/// different distributions, and growth stops when a branch gets thinner than `min_radius`.
/// Same parameters and seed → the same skeleton, bit for bit (no global state; every node
/// draws from its own stream derived from (seed, node)).

#include <cstdint>

#include "skeleton/skeleton.h"

namespace sm {

struct RandomGrowParams {
  std::uint64_t seed = 1;          ///< random seed
  double trunk_radius = 0.12;      ///< radius at the root (metres)
  double min_radius = 0.006;       ///< branches thinner than this stop growing (metres)
  double length_ratio = 5.0;       ///< edge length relative to the local radius (mean)
  double length_jitter = 0.35;     ///< relative spread of edge lengths (0..1)
  double fork_chance_root = 0.08;  ///< chance of a fork at depth 0
  double fork_chance_gain = 0.035; ///< added to the fork chance per level of depth
  double fork_chance_max = 0.45;   ///< fork chance cap
  double main_ratio = 0.93;        ///< mean radius ratio main child / parent at a plain node
  double fork_main_ratio = 0.82;   ///< mean radius ratio main child / parent at a fork
  double lateral_ratio = 0.62;     ///< mean radius ratio lateral child / parent at a fork
  double ratio_jitter = 0.06;      ///< absolute spread of the radius ratios
  double bend_degrees = 9.0;       ///< random bend of a continuing branch (standard deviation)
  double branch_degrees = 42.0;    ///< mean angle between a lateral child and its parent
  double min_fork_degrees = 25.0;  ///< smallest angle allowed between the two children
  double tropism = 0.05;           ///< pull towards +up per edge (0 = none)
  std::uint32_t max_nodes = 200'000;  ///< hard cap on the node count
};

/// Grows a random tree (up axis z, root at the origin).
RawSkeleton grow_random(const RandomGrowParams& params = {});

}  // namespace sm
