/// @file random.hpp
/// @brief The simulator's random numbers: a counter-based seed derivation and a small generator
/// whose output is defined by this file alone, so a seed gives the same corpus with any compiler,
/// standard library and thread count (std::normal_distribution is implementation-defined).
#pragma once

#include <cmath>
#include <cstdint>
#include <initializer_list>

namespace glovepose::core {

/// @brief SplitMix64 step (Steele, Lea & Flood 2014): a bijective mixer of 64-bit words.
constexpr std::uint64_t splitmix64(std::uint64_t x) noexcept {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// @brief A seed for one independent stream, derived from the corpus seed and a path of integers
/// (e.g. subject, session, purpose): streams never depend on the order in which they are used.
inline std::uint64_t derive_seed(std::uint64_t seed, std::initializer_list<std::uint64_t> path) noexcept {
  std::uint64_t h = splitmix64(seed);
  for (std::uint64_t p : path) h = splitmix64(h ^ splitmix64(p + 0x632be59bd9b4e019ULL));
  return h;
}

/// @brief xoshiro256** (Blackman & Vigna 2018) with uniform and normal draws.
class Rng {
 public:
  /// @brief A generator whose state is filled from `seed` by SplitMix64 (never all zero).
  explicit Rng(std::uint64_t seed) noexcept {
    for (auto& s : state_) {
      seed = splitmix64(seed);
      s = seed;
    }
  }

  /// @brief The next 64 random bits.
  std::uint64_t next() noexcept {
    const std::uint64_t result = rotl(state_[1] * 5, 7) * 9;
    const std::uint64_t t = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = rotl(state_[3], 45);
    return result;
  }

  /// @brief Uniform in [0, 1), 53 random bits.
  double uniform() noexcept { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  /// @brief Uniform in [lo, hi).
  double uniform(double lo, double hi) noexcept { return lo + (hi - lo) * uniform(); }
  /// @brief Uniform integer in [0, n), n > 0 (multiply-shift; bias below 2^-32 for the sizes used here).
  int index(int n) noexcept { return static_cast<int>((next() >> 32) * static_cast<std::uint64_t>(n) >> 32); }
  /// @brief True with probability p.
  bool bernoulli(double p) noexcept { return uniform() < p; }
  /// @brief Standard normal (Box-Muller, both values used).
  double normal() noexcept {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u = 0.0;
    while (u <= 0.0) u = uniform();
    const double radius = std::sqrt(-2.0 * std::log(u));
    const double angle = 6.283185307179586 * uniform();
    spare_ = radius * std::sin(angle);
    has_spare_ = true;
    return radius * std::cos(angle);
  }
  /// @brief Normal with the given mean and standard deviation.
  double normal(double mean, double sd) noexcept { return mean + sd * normal(); }
  /// @brief Exponential with the given mean.
  double exponential(double mean) noexcept { return -mean * std::log(1.0 - uniform()); }

 private:
  static constexpr std::uint64_t rotl(std::uint64_t x, int k) noexcept { return (x << k) | (x >> (64 - k)); }
  std::uint64_t state_[4]{};
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace glovepose::core
