#include "grow/messy_grower.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "core/errors.h"
#include "core/math.h"
#include "core/rng.h"

namespace sm {
namespace {

constexpr double kPi = std::numbers::pi;

/// Unit vector at azimuth `a` and angle `polar` from +z (radians).
dvec3 direction(double a, double polar) {
  return {std::sin(polar) * std::cos(a), std::sin(polar) * std::sin(a), std::cos(polar)};
}

/// A random unit vector perpendicular to `t`.
dvec3 random_perpendicular(const dvec3& t, Rng& rng) {
  const dvec3 u = any_perpendicular(t), v = glm::cross(t, u);
  const double a = rng.uniform(0.0, 2 * kPi);
  return std::cos(a) * u + std::sin(a) * v;
}

class MessyGrower {
 public:
  explicit MessyGrower(const MessyGrowParams& p) : p_(p), rng_(derive_seed(p.seed, 0x6d657373)) {}

  RawSkeleton grow() {
    raw_.source = "messy grower, seed " + std::to_string(p_.seed);
    raw_.grown = true;
    trunk();
    for (int k = 0; k < p_.limbs; ++k) limb(k);
    for (int k = 0; k < p_.hairpins; ++k) hairpin();
    if (p_.hub_twigs > 0) hub();
    for (std::size_t i = 0; i < raw_.size(); ++i) raw_.position[i] += p_.origin;
    return std::move(raw_);
  }

 private:
  std::int64_t add(std::int64_t parent, const dvec3& pos, double r) {
    const auto id = static_cast<std::int64_t>(raw_.size());
    raw_.add(id, parent, pos, r);
    return id;
  }
  [[nodiscard]] const dvec3& pos(std::int64_t i) const { return raw_.position[std::size_t(i)]; }
  [[nodiscard]] double radius(std::int64_t i) const { return raw_.radius[std::size_t(i)]; }

  /// A polyline from `from` along `dir` (bent per edge by `bend`, a pull per edge added to the
  /// direction), radius tapering from r0 to r1; zigzag jitter sideways. Returns its nodes.
  std::vector<std::int64_t> polyline(std::int64_t from, dvec3 dir, int edges, double length, double r0, double r1,
                                     const dvec3& bend, bool thick_noise) {
    std::vector<std::int64_t> nodes;
    std::int64_t prev = from;
    dvec3 at = pos(from);
    for (int e = 1; e <= edges; ++e) {
      const double t = double(e) / edges;
      double r = r0 + (r1 - r0) * t;
      if (thick_noise && rng_.chance(p_.thick_child_share)) r = std::max(r, radius(prev)) * rng_.uniform(1.0, 1.25);
      at += dir * length;
      // Draws sequenced (C++ leaves the order of an operator's operands unspecified, and clang
      // chose another one than GCC: another tree from the same seed); this is GCC's order.
      const double amount = rng_.uniform(0.0, 1.0);
      const dvec3 jitter = random_perpendicular(dir, rng_) * (p_.zigzag * length * amount);
      prev = add(prev, at + jitter, r);
      nodes.push_back(prev);
      dir = normalize_or(dir + bend, dir);
    }
    return nodes;
  }

  void trunk() {
    const int edges = 12;
    add(-1, dvec3(0.0), p_.trunk_radius);
    trunk_ = polyline(0, dvec3(0, 0, 1), edges, p_.height / edges, p_.trunk_radius * 0.95, p_.trunk_radius * 0.35,
                      dvec3(0.0), false);
    trunk_.insert(trunk_.begin(), 0);
  }

  void limb(int k) {
    // On the upper three quarters of the trunk, spread by the golden angle.
    const std::size_t at = 3 + std::size_t(rng_.below(trunk_.size() - 4));
    const std::int64_t base = trunk_[at];
    const double a = 2.399963 * k + rng_.uniform(-0.3, 0.3);
    const double r0 = radius(base) * rng_.uniform(0.35, 0.6);
    const double u = rng_.uniform();
    dvec3 dir, bend(0.0);
    int edges = 6 + int(rng_.below(6));
    double length = rng_.uniform(5.0, 9.0) * r0;
    if (u < p_.droop_share) {  // leaves near horizontal, hangs
      dir = direction(a, rng_.uniform(0.45, 0.6) * kPi);
      bend = dvec3(0, 0, -0.25);
    } else if (u < p_.droop_share + p_.crossing_share && limb_tips_.size() > 0) {
      // Aimed through a point half-way along an earlier limb, and on beyond it.
      const std::vector<std::int64_t>& other = limbs_[std::size_t(rng_.below(limbs_.size()))];
      const dvec3 target = pos(other[other.size() / 2]);
      dir = normalize_or(target - pos(base), direction(a, 0.3 * kPi));
      length = glm::length(target - pos(base)) / (0.5 * edges);
    } else {
      dir = direction(a, rng_.uniform(0.15, 0.35) * kPi);
      bend = dvec3(0, 0, 0.05);
    }
    std::vector<std::int64_t> nodes = polyline(base, dir, edges, length, r0, r0 * 0.3, bend, true);
    for (const std::int64_t n : nodes) {
      if (rng_.chance(p_.twig_chance)) twig(n);
    }
    limb_tips_.push_back(nodes.back());
    limbs_.push_back(std::move(nodes));
  }

  /// A twig of 2-4 edges from node n, some of its nodes with radius 0.
  void twig(std::int64_t n) {
    const dvec3 along = normalize_or(pos(n) - pos(raw_.parent_id[std::size_t(n)]), dvec3(0, 0, 1));
    const dvec3 dir = normalize_or(along + 1.2 * random_perpendicular(along, rng_), along);
    const double r0 = std::max(radius(n), 1e-3) * rng_.uniform(0.3, 0.6);
    const double length = rng_.uniform(4.0, 7.0) * r0;  // (drawn first: GCC's order of the arguments)
    const int edges = 2 + int(rng_.below(3));
    const auto nodes = polyline(n, dir, edges, length, r0, 0.4 * r0, dvec3(0, 0, 0.1), false);
    for (const std::int64_t t : nodes) {
      if (rng_.chance(p_.zero_radius_share)) raw_.radius[std::size_t(t)] = 0.0;
    }
  }

  /// A twig that runs out and turns back by 130-160 degrees.
  void hairpin() {
    const std::vector<std::int64_t>& l = limbs_[std::size_t(rng_.below(limbs_.size()))];
    const std::int64_t n = l[std::size_t(rng_.below(l.size()))];
    const dvec3 along = normalize_or(pos(n) - pos(raw_.parent_id[std::size_t(n)]), dvec3(0, 0, 1));
    const dvec3 side = random_perpendicular(along, rng_);
    const double r = std::max(radius(n), 1e-3) * 0.5, len = 6 * r;
    const std::int64_t a = add(n, pos(n) + side * len, r);
    const double turn = rng_.uniform(130.0, 160.0) * kPi / 180.0;  // from the incoming edge
    const dvec3 back = std::cos(turn) * side + std::sin(turn) * along;
    const std::int64_t b = add(a, pos(a) + back * len, 0.8 * r);
    add(b, pos(b) + back * len, 0.6 * r);
  }

  /// One limb node with many twigs radiating from it (a QSM's or an L-system's fan).
  void hub() {
    const std::vector<std::int64_t>& l = limbs_[std::size_t(rng_.below(limbs_.size()))];
    const std::int64_t n = l[l.size() / 2];
    const double r = std::max(radius(n), 1e-3) * 0.3;
    for (int k = 0; k < p_.hub_twigs; ++k) {
      const dvec3 dir = direction(2.399963 * k, rng_.uniform(0.1, 0.9) * kPi);
      const std::int64_t a = add(n, pos(n) + dir * (8 * r), r);
      add(a, pos(a) + dir * (6 * r), 0.5 * r);
    }
  }

  MessyGrowParams p_;
  Rng rng_;
  RawSkeleton raw_;
  std::vector<std::int64_t> trunk_, limb_tips_;
  std::vector<std::vector<std::int64_t>> limbs_;
};

void validate(const MessyGrowParams& p) {
  const ParamChecker check{"messy"};
  check.positive(p.height, "height");
  check.positive(p.trunk_radius, "trunk_radius");
  check.within(p.limbs, 1, 1000, "limbs");
  check.within(p.zigzag, 0, 1, "zigzag");
  check.within(p.droop_share, 0, 1, "droop_share");
  check.within(p.crossing_share, 0, 1, "crossing_share");
  check.within(p.twig_chance, 0, 1, "twig_chance");
  check.within(p.hub_twigs, 0, 10'000, "hub_twigs");
  check.within(p.hairpins, 0, 1000, "hairpins");
  check.within(p.zero_radius_share, 0, 1, "zero_radius_share");
  check.within(p.thick_child_share, 0, 1, "thick_child_share");
  for (int k = 0; k < 3; ++k) check.within(p.origin[k], -1e7, 1e7, "origin");
}

}  // namespace

RawSkeleton grow_messy(const MessyGrowParams& params) {
  validate(params);
  return MessyGrower(params).grow();
}

}  // namespace sm
