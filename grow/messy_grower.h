#pragma once
/// The messy-tree generator: seeded skeletons with what real inputs bring and the other growers
/// avoid, for tests and sweeps of the mesher on trees nobody tuned it on.
///
/// A zigzagging trunk carries limbs of three kinds: ordinary ones, drooping ones (leaving
/// near horizontal and hanging, as a willow's) and crossing ones (aimed through another limb,
/// as in large procedural trees). Limbs carry twigs; one limb node is a hub of many twigs,
/// some twigs turn back on themselves (hairpins), some twig nodes have radius 0 (as Sapling's
/// conifers write them), some children are thicker than their parent (as measured trees are),
/// and the whole tree may sit at georeferenced coordinates. Same parameters and seed, the same
/// skeleton, bit for bit.

#include <cstdint>

#include "skeleton/skeleton.h"

namespace sm {

struct MessyGrowParams {
  std::uint64_t seed = 1;           ///< random seed
  double height = 6.0;              ///< trunk height (metres)
  double trunk_radius = 0.15;       ///< radius at the root (metres)
  int limbs = 8;                    ///< limbs on the trunk (a count)
  double zigzag = 0.25;             ///< sideways jitter of nodes, relative to the edge length
  double droop_share = 0.3;         ///< share of limbs that hang (0..1)
  double crossing_share = 0.3;      ///< share of limbs aimed through another limb (0..1)
  double twig_chance = 0.5;         ///< chance of a twig at each limb node (0..1)
  int hub_twigs = 12;               ///< twigs of the one hub node (0 = no hub)
  int hairpins = 2;                 ///< twigs that turn back by more than 120 degrees (a count)
  double zero_radius_share = 0.1;   ///< share of twig nodes written with radius 0 (0..1)
  double thick_child_share = 0.15;  ///< share of limb nodes up to 25 % thicker than their parent (0..1)
  dvec3 origin{0.0};                ///< position of the root (e.g. UTM metres for a georeferenced tree)
};

/// Grows a messy tree (up axis z). Throws InvalidInputError for parameters out of range.
RawSkeleton grow_messy(const MessyGrowParams& params = {});

}  // namespace sm
