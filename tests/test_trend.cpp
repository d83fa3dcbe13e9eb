// filter::Trend (filter/trend.hpp): the running least-squares slope against a fit computed here
// from the samples themselves (two passes, about their means), over long irregular streams.
#include <glovepose/filter/trend.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <deque>
#include <limits>
#include <random>

#include "alloc_counter.hpp"

using namespace glovepose;

namespace {

constexpr std::size_t kChannels = 3;
using Sample = std::pair<double, std::array<double, kChannels>>;

// The slope of the samples of the last `window` seconds (at least the two newest, at most
// `capacity`), fitted about their means in extended precision.
std::array<double, kChannels> fitted_slope(const std::deque<Sample>& samples, double window, std::size_t capacity, std::size_t& used) {
  const double newest = samples.back().first;
  used = 0;
  for (auto it = samples.rbegin(); it != samples.rend() && used < capacity; ++it, ++used)
    if (used >= 2 && newest - it->first > window) break;
  const auto first = samples.end() - static_cast<std::ptrdiff_t>(used);
  long double mean_t = 0.0;
  std::array<long double, kChannels> mean_v{};
  for (auto it = first; it != samples.end(); ++it) {
    mean_t += static_cast<long double>(it->first) / used;
    for (std::size_t c = 0; c < kChannels; ++c) mean_v[c] += static_cast<long double>(it->second[c]) / used;
  }
  long double tt = 0.0;
  std::array<long double, kChannels> tv{};
  for (auto it = first; it != samples.end(); ++it) {
    const long double dt = it->first - mean_t;
    tt += dt * dt;
    for (std::size_t c = 0; c < kChannels; ++c) tv[c] += dt * (it->second[c] - mean_v[c]);
  }
  std::array<double, kChannels> slope{};
  for (std::size_t c = 0; c < kChannels; ++c) slope[c] = static_cast<double>(tv[c] / tt);
  return slope;
}

}  // namespace

TEST_CASE("trend: the slope is the least-squares fit over the window, sample after sample, for a long stream") {
  // Irregular intervals (0.5-4 ms, now and then a 60 ms gap), a clock that starts late in a
  // session, noisy ramps and a sine: the running sums must match a fresh fit at every sample.
  constexpr std::size_t kCapacity = 64;
  const double window = 0.05;
  filter::Trend<kChannels, kCapacity> trend(window);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> interval(0.0005, 0.004), noise(-0.01, 0.01), gap(0.0, 1.0);
  std::deque<Sample> samples;
  double t = 3600.0;
  double worst = 0.0;
  bool saw_capacity = false, saw_two = false;
  for (int n = 0; n < 20000; ++n) {
    t += gap(rng) < 0.01 ? 0.06 : interval(rng);
    const std::array<double, kChannels> v{0.3 * (t - 3600.0) + noise(rng), std::sin(7.0 * t) + noise(rng), -2.0 + noise(rng)};
    REQUIRE(trend.add(t, v) == Status::Ok);
    samples.emplace_back(t, v);
    if (samples.size() > kCapacity) samples.pop_front();
    if (samples.size() < 2) continue;
    std::size_t used = 0;
    const auto expected = fitted_slope(samples, window, kCapacity, used);
    CHECK(trend.fitted() == used);
    saw_capacity |= used == kCapacity;
    saw_two |= used == 2;
    const auto slope = trend.slope();
    for (std::size_t c = 0; c < kChannels; ++c) worst = std::max(worst, std::abs(slope[c] - expected[c]) / (1.0 + std::abs(expected[c])));
  }
  CHECK(saw_two);             // a gap left only the two newest samples in the window
  CHECK_FALSE(saw_capacity);  // 0.05 s never held 64 samples at these intervals
  CHECK(worst < 1e-10);
}

TEST_CASE("trend: a window longer than the ring fits the newest Capacity samples") {
  filter::Trend<kChannels, 16> trend(10.0);
  std::deque<Sample> samples;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (int n = 0; n < 500; ++n) {
    const double t = 0.001 * n;
    const std::array<double, kChannels> v{noise(rng), 5.0 * t + noise(rng), 1e3 + noise(rng)};
    trend.add(t, v);
    samples.emplace_back(t, v);
    if (samples.size() > 16) samples.pop_front();
    if (samples.size() < 2) continue;
    std::size_t used = 0;
    const auto expected = fitted_slope(samples, 10.0, 16, used);
    REQUIRE(trend.fitted() == std::min<std::size_t>(samples.size(), 16));
    const auto slope = trend.slope();
    for (std::size_t c = 0; c < kChannels; ++c) CHECK(slope[c] == doctest::Approx(expected[c]).epsilon(1e-9).scale(1.0));
  }
}

TEST_CASE("trend: a clock restart starts over, bad samples are refused, overflowing times give no slope") {
  filter::Trend<1, 8> trend(1.0);
  CHECK_FALSE(trend.has_slope());
  CHECK(trend.slope()[0] == 0.0);
  trend.add(1.0, {1.0});
  trend.add(2.0, {3.0});
  CHECK(trend.slope()[0] == doctest::Approx(2.0));
  trend.add(0.5, {10.0});  // not after the newest: a new clock, earlier than every sample so far
  CHECK(trend.size() == 1);
  CHECK_FALSE(trend.has_slope());
  trend.add(0.75, {9.0});
  CHECK(trend.slope()[0] == doctest::Approx(-4.0));
  CHECK(trend.add(3.0, {std::nan("")}) == Status::NonFinite);
  CHECK(trend.add(std::numeric_limits<double>::infinity(), {1.0}) == Status::NonFinite);
  CHECK(trend.size() == 2);
  // Times at both ends of the double range: the sums overflow; the slope is 0, not NaN, and an
  // ordinary stream after a restart fits again.
  trend.reset();
  trend.add(-1.7e308, {0.0});
  trend.add(1.7e308, {1.0});
  CHECK(trend.slope()[0] == 0.0);
  for (int n = 0; n < 20; ++n) trend.add(0.1 * n, {0.5 * n});
  CHECK(trend.size() == 8);
  CHECK(trend.slope()[0] == doctest::Approx(5.0));
}

TEST_CASE("trend: adding and fitting never allocate") {
  filter::Trend<25> trend;
  std::array<double, 25> v{};
  const std::size_t allocations = test::allocations_during([&] {
    for (int n = 0; n < 1000; ++n) {
      v[0] = 0.01 * n;
      trend.add(0.0015 * n, v);
      v = trend.slope();
    }
  });
  CHECK(allocations == 0);
  CHECK(v[0] == doctest::Approx(0.01 / 0.0015));
}
