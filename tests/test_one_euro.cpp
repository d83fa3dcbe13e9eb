#include <glovepose/filter/one_euro.hpp>
#include <glovepose/hand/dofs.hpp>

#include <doctest/doctest.h>

#include <fstream>
#include <limits>
#include <sstream>

#include "alloc_counter.hpp"
#include "reference_data.hpp"

using namespace glovepose;
using namespace glovepose::filter;

TEST_CASE("one euro: reproduces the authors' conformance vectors within 1e-4") {
  std::ifstream file(test::reference_file("one_euro_ground_truth.csv"));
  std::string line;
  REQUIRE(std::getline(file, line));
  REQUIRE(line.rfind("timestamp,signal,noisy,filtered", 0) == 0);
  // The reference run: freq 120, mincutoff 1.0, beta 0.1, dcutoff 1.0, timestamps given.
  OneEuroFilter<1> filter({120.0, 1.0, 0.1, 1.0});
  int rows = 0;
  double worst = 0.0;
  while (std::getline(file, line)) {
    if (line.empty()) continue;
    std::istringstream fields(line);
    double t = 0, signal = 0, noisy = 0, expected = 0;
    char comma = 0;
    REQUIRE((fields >> t >> comma >> signal >> comma >> noisy >> comma >> expected));
    std::array<double, 1> out{};
    REQUIRE(filter.filter({noisy}, t, out) == Status::Ok);
    worst = std::max(worst, std::abs(out[0] - expected));
    ++rows;
  }
  MESSAGE("1-euro: " << rows << " reference rows, largest difference " << worst);
  CHECK(rows == 1200);
  CHECK(worst <= 1e-4);
}

TEST_CASE("one euro: the first sample passes unchanged, noise is smoothed, a fast move is followed") {
  OneEuroFilter<2> filter({60.0, 1.0, 0.5, 1.0});
  std::array<double, 2> out{};
  REQUIRE(filter.filter({0.3, -0.2}, 0.0, out) == Status::Ok);
  CHECK(out[0] == 0.3);
  CHECK(out[1] == -0.2);
  // A step of 1 rad: channel 0 follows within a few frames at high speed (beta), channel 1 holds still.
  for (int k = 1; k <= 30; ++k) REQUIRE(filter.filter({1.3, -0.2}, k / 60.0, out) == Status::Ok);
  CHECK(out[0] == doctest::Approx(1.3).epsilon(0.01));
  CHECK(out[1] == doctest::Approx(-0.2));
}

TEST_CASE("one euro: NaN values and backwards timestamps are refused and not mixed in") {
  OneEuroFilter<hand::kDofCount> clean({60.0, 1.0, 0.1, 1.0}), dirty({60.0, 1.0, 0.1, 1.0});
  std::array<double, hand::kDofCount> in{}, a{}, b{};
  for (int k = 0; k < 50; ++k) {
    for (std::size_t i = 0; i < in.size(); ++i) in[i] = std::sin(0.1 * k + static_cast<double>(i));
    const double t = k / 60.0;
    if (k % 7 == 3) {
      auto bad = in;
      bad[4] = std::numeric_limits<double>::quiet_NaN();
      CHECK(dirty.filter(in, t - 0.5, b) == Status::TimestampBackwards);
      CHECK(dirty.filter(in, std::numeric_limits<double>::infinity(), b) == Status::NonFinite);
      // A NaN channel is refused alone; the others are filtered as usual.
      REQUIRE(clean.filter(in, t, a) == Status::Ok);
      CHECK(dirty.filter(bad, t, b) == Status::NonFinite);
      for (std::size_t i = 0; i < in.size(); ++i)
        if (i != 4) CHECK(b[i] == a[i]);
      CHECK(std::isfinite(b[4]));
      continue;
    }
    REQUIRE(clean.filter(in, t, a) == Status::Ok);
    REQUIRE(dirty.filter(in, t, b) == Status::Ok);
  }
  // Channel 4 skipped some samples, so only compare the rest exactly.
  for (std::size_t i = 0; i < in.size(); ++i)
    if (i != 4) CHECK(b[i] == a[i]);
  CHECK(std::isfinite(b[4]));
}

TEST_CASE("one euro: settings are validated, filtering allocates nothing") {
  CHECK_THROWS_WITH_AS(OneEuroFilter<1>({0.0, 1.0, 0.0, 1.0}), doctest::Contains("expected all finite and > 0"), Error);
  CHECK_THROWS_WITH_AS(OneEuroFilter<1>({60.0, 1.0, -1.0, 1.0}), doctest::Contains("beta -1.000000"), Error);
  OneEuroFilter<hand::kDofCount> filter;
  std::array<double, hand::kDofCount> in{}, out{};
  CHECK(test::allocations_during([&] {
          for (int k = 0; k < 10; ++k) (void)filter.filter(in, k / 60.0, out);
        }) == 0);
}
