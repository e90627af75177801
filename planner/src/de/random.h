#pragma once
/// @file The solver's only random source. std::mt19937_64's output sequence is fixed by the C++
/// standard, but the standard distributions are not, so every draw is derived here from the raw
/// 64-bit words: the same seed gives the same numbers with every standard library.

#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>

namespace wj::planner::de {

/// Seeded generator with uniform, index, normal and Cauchy draws of our own.
class Random {
 public:
  /// A generator seeded with `seed`.
  explicit Random(std::uint64_t seed) : engine_(seed) {}

  /// Uniform in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * kTwoPowMinus53; }

  /// Uniform in the open interval (0, 1), for draws fed to log() or tan().
  double uniformOpen() { return (static_cast<double>(engine_() >> 11) + 0.5) * kTwoPowMinus53; }

  /// Uniform integer in [0, n) for n >= 1, without modulo bias (rejection of the top remainder).
  int index(int n) {
    const auto range = static_cast<std::uint64_t>(n);
    constexpr std::uint64_t kMax = std::numeric_limits<std::uint64_t>::max();
    const std::uint64_t limit = kMax - kMax % range;  // a multiple of range
    std::uint64_t r = engine_();
    while (r >= limit) r = engine_();
    return static_cast<int>(r % range);
  }

  /// Normal draw N(mean, sigma^2) by the Box-Muller transform (two uniforms per draw).
  double normal(double mean, double sigma) {
    const double u1 = uniformOpen();
    const double u2 = uniform();
    return mean + sigma * std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }

  /// Cauchy draw with location `location` and scale `scale` by inversion of the CDF.
  double cauchy(double location, double scale) {
    return location + scale * std::tan(std::numbers::pi * (uniformOpen() - 0.5));
  }

 private:
  static constexpr double kTwoPowMinus53 = 1.0 / 9007199254740992.0;  // 2^-53
  std::mt19937_64 engine_;
};

}  // namespace wj::planner::de
