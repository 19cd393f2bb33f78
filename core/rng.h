#pragma once
/// Deterministic random numbers.
///
/// Randomness is always passed in: a stage takes a `seed` in its Params and derives one
/// sub-seed per node or branch with `derive_seed(seed, id, ...)`, so results never depend on
/// thread scheduling and changing one parameter does not reshuffle unrelated randomness
/// (one stream per purpose). The generator is xoshiro256** and the distributions are our own, so
/// output is bit-identical across compilers and standard libraries (std:: distributions are
/// implementation-defined).

#include <cstdint>

namespace sm {

/// Mixes a seed with up to three stream ids into a new, well-distributed 64-bit seed.
std::uint64_t derive_seed(std::uint64_t seed, std::uint64_t a, std::uint64_t b = 0, std::uint64_t c = 0);

class Rng {
 public:
  explicit Rng(std::uint64_t seed);

  /// Next raw 64-bit value.
  std::uint64_t next();
  /// Uniform double in [0, 1).
  double uniform();
  /// Uniform double in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Uniform integer in [0, n). Precondition: n > 0.
  std::uint64_t below(std::uint64_t n);
  /// Standard normal variate (Box–Muller, no cached second value so streams stay simple).
  double normal();
  /// Normal variate with the given mean and standard deviation.
  double normal(double mean, double sigma) { return mean + sigma * normal(); }
  /// True with probability p.
  bool chance(double p) { return uniform() < p; }

 private:
  std::uint64_t s_[4];
};

}  // namespace sm
