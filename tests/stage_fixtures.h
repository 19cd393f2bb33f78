#pragma once
/// The stages before meshing run on a skeleton built in code, so that the contour and meshing
/// stages can be called directly on small inputs (tests/fixtures.h builds the skeletons).

#include "contours/contours.h"
#include "particles/particles.h"
#include "skeleton/build.h"
#include "skeleton/skeleton.h"
#include "strands/strands.h"

namespace sm::test {

/// The sanitized skeleton and every stage's result up to the contours, default parameters.
struct UpToContours {
  Skeleton skeleton;
  ParticleField particles;
  StrandSet strands;
  ContourSet contours;
};

/// Runs skeleton, particles, strands and contours on `raw` with default parameters (the
/// particle stage with `seed`).
UpToContours up_to_contours(const RawSkeleton& raw, std::uint64_t seed = 1, const ContourParams& contours = {},
                            const SkeletonParams& skeleton = {});

}  // namespace sm::test
