// The simple random grower; random_grower.h states its rules.

#include "grow/random_grower.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "core/rng.h"
#include "skeleton/build.h"

namespace sm {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

/// Rotates unit vector d by `angle` away from itself, in the azimuthal direction `phi`
/// around it.
dvec3 deflect(const dvec3& d, double angle, double phi) {
  const dvec3 u = any_perpendicular(d);
  const dvec3 v = glm::cross(d, u);
  const dvec3 side = std::cos(phi) * u + std::sin(phi) * v;
  return glm::normalize(std::cos(angle) * d + std::sin(angle) * side);
}

struct Bud {
  std::int64_t node;  // id of the node to grow from
  dvec3 dir;          // growth direction at that node
  std::uint32_t depth;
};

}  // namespace

RawSkeleton grow_random(const RandomGrowParams& p) {
  RawSkeleton raw;
  raw.up_axis = UpAxis::z;
  raw.grown = true;
  raw.source = "strandmesh random grower (seed " + std::to_string(p.seed) + ")";
  const dvec3 up(0, 0, 1);
  raw.add(0, -1, dvec3(0), p.trunk_radius);
  // Depth-first with an explicit stack: deterministic order, no recursion.
  std::vector<Bud> stack{{0, up, 0}};
  while (!stack.empty() && raw.size() < p.max_nodes) {
    const Bud bud = stack.back();
    stack.pop_back();
    const auto i = static_cast<std::size_t>(bud.node);
    const double r = raw.radius[i];
    if (r < p.min_radius) continue;
    Rng rng(derive_seed(p.seed, static_cast<std::uint64_t>(bud.node)));
    const double fork_chance = std::min(p.fork_chance_max, p.fork_chance_root + p.fork_chance_gain * bud.depth);
    const bool fork = bud.depth > 0 && rng.chance(fork_chance);

    auto child_length = [&](double rc) {
      const double j = std::clamp(1.0 + p.length_jitter * (2.0 * rng.uniform() - 1.0), 0.2, 2.0);
      return p.length_ratio * 0.5 * (r + rc) * j;
    };
    auto with_tropism = [&](dvec3 d) { return glm::normalize(d + p.tropism * up); };

    // Main continuation.
    const double main_ratio = fork ? p.fork_main_ratio : p.main_ratio;
    const double rm = r * std::clamp(main_ratio + p.ratio_jitter * rng.normal(), 0.5, 0.99);
    const double phi_main = rng.uniform(0, 2 * std::numbers::pi);
    double bend = std::abs(rng.normal(0, p.bend_degrees)) * kDeg;
    dvec3 dm = with_tropism(deflect(bud.dir, bend, phi_main));
    std::int64_t lateral_id = -1;
    dvec3 dl(0);
    double rl = 0;
    if (fork) {
      rl = r * std::clamp(p.lateral_ratio + p.ratio_jitter * rng.normal(), 0.3, 0.95);
      rl = std::min(rl, rm);
      const double angle = std::clamp(rng.normal(p.branch_degrees, 10.0), p.min_fork_degrees, 80.0) * kDeg;
      dl = with_tropism(deflect(bud.dir, angle, phi_main + std::numbers::pi + rng.normal(0, 0.4)));
      // Keep the two children apart: push the main child away if they are too close.
      const double sep = std::acos(std::clamp(glm::dot(dm, dl), -1.0, 1.0));
      if (sep < p.min_fork_degrees * kDeg) {
        dm = with_tropism(deflect(bud.dir, bend + (p.min_fork_degrees * kDeg - sep), phi_main));
      }
    }
    const auto next_id = [&] { return static_cast<std::int64_t>(raw.size()); };
    const std::int64_t main_id = next_id();
    raw.add(main_id, bud.node, raw.position[i] + dm * child_length(rm), rm);
    if (fork) {
      lateral_id = next_id();
      raw.add(lateral_id, bud.node, raw.position[i] + dl * child_length(rl), rl);
      stack.push_back({lateral_id, dl, bud.depth + 1});
    }
    stack.push_back({main_id, dm, bud.depth + 1});
  }
  // Random directions let branches run into one another; swing those apart here (the same
  // repair build_skeleton applies to imported skeletons), so the grown tree is clean.
  // (Laterals are raised by the pipeline's own skeleton stage, not baked into the file.)
  return raw_from_skeleton(build_skeleton(raw, {.max_lateral_angle = 0}).skeleton, raw.source);
}

}  // namespace sm
