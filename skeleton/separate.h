#pragma once
/// Separating branches that run into each other (a sanitizing step of build_skeleton).
///
/// Real skeletons (digitised, scanned, or made with Sapling) and random growers often have
/// branches whose round cones intersect far from any common fork: two branches crossing, or a
/// branch bending back into its parent. No surface can then be both free of self-intersections
/// and genus 0, so such collisions are repaired: the smaller of the two subtrees hanging below
/// their lowest common ancestor C is rotated rigidly about C, just far enough that the cones
/// clear each other by `clearance`. Edge lengths and radii are kept. Overlaps that start at the
/// common fork and never separate before (the normal overlap of two children leaving a fork)
/// are not collisions: the contour stage fuses those bundles.

#include <cstddef>

#include "core/report.h"
#include "skeleton/skeleton.h"

namespace sm {

struct SeparateParams {
  /// Required gap between two colliding cones, relative to the sum of their radii.
  double clearance = 0.15;
  /// Largest rotation of one subtree in one round (degrees).
  double max_step_degrees = 12.0;
  /// Rounds of detection and repair (a count); collisions left after them are reported.
  std::size_t max_rounds = 60;
};

struct SeparateReport {
  std::size_t collisions = 0;   ///< colliding edge pairs found in the first round
  std::size_t rotations = 0;    ///< subtree rotations applied
  std::size_t unresolved = 0;   ///< colliding pairs left at the end
  double max_displacement = 0;  ///< largest distance a node moved (metres)
  bool dense = false;           ///< left as it was: edges crowding each other by the hundred
};

/// Detects and repairs collisions in place (positions only; frames must be recomputed).
/// Deterministic. Precondition: `skeleton` is binary with parent[i] < i.
SeparateReport separate_branches(Skeleton& skeleton, const SeparateParams& params = {});

/// Colliding edge pairs (child node ids) with their penetration depth (metres), for tests.
struct Collision {
  NodeId a, b;
  double penetration = 0;
};
std::vector<Collision> find_collisions(const Skeleton& skeleton, double clearance = 0.0);

}  // namespace sm
