#include "tests/stage_fixtures.h"

#include "tests/fixtures.h"

namespace sm::test {

UpToContours up_to_contours(const RawSkeleton& raw, std::uint64_t seed, const ContourParams& contours,
                            const SkeletonParams& skeleton) {
  UpToContours r;
  r.skeleton = built(raw, skeleton);
  ParticleParams pp;
  pp.seed = seed;
  r.particles = compute_particles(r.skeleton, pp);
  r.strands = build_strands(r.skeleton, r.particles);
  r.contours = compute_contours(r.skeleton, r.particles, r.strands, contours);
  return r;
}

}  // namespace sm::test
