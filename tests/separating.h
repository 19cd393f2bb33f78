#pragma once
/// The parameters that were the defaults before the input was kept as given: the shape edits
/// (branches swung apart, hairpins re-attached, tight bends removed, thick children clamped,
/// collar nodes, raised lateral bases), the meshing stage's fork retry and outer surface, and the
/// rings they were tuned for (ring_edge 0: one vertex per boundary strand).
/// Tests of those mechanisms, and of the slicing on trees they made sound, use them
/// (configs/separate.json holds the same for users).

#include "pipeline/pipeline.h"

namespace sm::test {

inline SkeletonParams separating_skeleton() {
  SkeletonParams p;
  p.separate = true;
  p.thick_child_policy = ThickChildPolicy::clamp_child;
  p.collar_ratio = 0.7;
  p.max_lateral_angle = 60.0;
  return p;
}

inline PipelineParams separating() {
  PipelineParams p;
  p.skeleton = separating_skeleton();
  p.contours.ring_edge = 0.0;  // the rings of before 0.2 too (configs/separate.json)
  p.contours.min_ring_vertices = 6;
  p.contours.split_outside_tips = false;  // thin tips absorbed as before 0.2
  p.repair.count_pairs_up_to = 300'000;
  p.repair.fork_retry = true;
  p.repair.outer_surface = true;
  p.repair.patch_uncovered_thin = false;  // (it draws the input's cones; the mesh follows the moved skeleton)
  return p;
}

}  // namespace sm::test
