// Portable, seedable random numbers.
//
// std::*_distribution differs between standard libraries, so cumuli draws every random number
// from SplitMix64 with its own uniform and normal transforms: the same seed gives the same
// numbers with any compiler. Parallel code derives one stream per item (`Rng::stream`) so that
// results never depend on the thread count.
#pragma once

#include <cmath>
#include <cstdint>

namespace cumuli {

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}

  // An independent stream for item `index` of a computation seeded with `seed`.
  static Rng stream(std::uint64_t seed, std::uint64_t index) {
    Rng mixer(seed ^ (0x9E3779B97F4A7C15ULL * (index + 1)));
    return Rng(mixer.next_u64());
  }

  std::uint64_t next_u64() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }

  // Uniform in [0, 1) with 24 bits: exactly representable as float32.
  float uniform() { return static_cast<float>(next_u64() >> 40) * (1.0f / 16777216.0f); }

  // Uniform in [0, 1) with 53 bits.
  double uniform_double() {
    return static_cast<double>(next_u64() >> 11) * (1.0 / 9007199254740992.0);
  }

  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform_double(); }

  // Standard normal by Box-Muller (one value per call; simple and portable).
  double normal() {
    double u1 = uniform_double();
    while (u1 <= 0.0) u1 = uniform_double();
    const double u2 = uniform_double();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }

  double normal(double mean, double stddev) { return mean + stddev * normal(); }

 private:
  std::uint64_t state_;
};

}  // namespace cumuli
