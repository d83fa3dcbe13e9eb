#include <glovepose/train/metrics_report.hpp>
#include <glovepose/train/metrics.hpp>
#include <glovepose/core/statistics.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <glovepose/io/json.hpp>

using namespace glovepose;
using namespace glovepose::train;

namespace {

// A frame whose DoF d is off by errors_deg[d] degrees, around true angles that are not zero (so the
// error is |predicted - true|, not |predicted|), alternating the sign of the error.
void frame_with_errors(const std::vector<double>& errors_deg, hand::Angles& predicted, hand::Angles& truth) {
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    truth[d] = 0.1 * static_cast<double>(d) - 1.0;
    const double sign = d % 2 ? -1.0 : 1.0;
    predicted[d] = truth[d] + sign * errors_deg[d] / core::kDegreesPerRadian;
  }
}

// Frame A: DoF d off by d + 0.5 degrees; frame B: every DoF off by 30.5 degrees. Half-degrees keep
// every error away from the whole-degree thresholds of the curve.
AngleErrorAccumulator two_hand_computed_frames() {
  AngleErrorAccumulator acc;
  std::vector<double> a(hand::kDofCount), b(hand::kDofCount, 30.5);
  for (std::size_t d = 0; d < hand::kDofCount; ++d) a[d] = static_cast<double>(d) + 0.5;
  hand::Angles predicted{}, truth{};
  frame_with_errors(a, predicted, truth);
  CHECK(acc.add(predicted, truth));
  frame_with_errors(b, predicted, truth);
  CHECK(acc.add(predicted.data(), truth.data()));
  return acc;
}

void check_equal(const AngleErrorReport& x, const AngleErrorReport& y) {
  CHECK(x.frames == y.frames);
  CHECK(x.skipped_frames == y.skipped_frames);
  CHECK(x.angles == y.angles);
  CHECK(x.overall.mean_deg == y.overall.mean_deg);
  CHECK(x.overall.rms_deg == y.overall.rms_deg);
  CHECK(x.overall.max_deg == y.overall.max_deg);
  CHECK(x.median_deg == y.median_deg);
  CHECK(x.p95_deg == y.p95_deg);
  CHECK(x.share_under_15deg == y.share_under_15deg);
  for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
    CHECK(x.fingers[f].error.mean_deg == y.fingers[f].error.mean_deg);
    CHECK(x.fingers[f].error.rms_deg == y.fingers[f].error.rms_deg);
    CHECK(x.fingers[f].error.max_deg == y.fingers[f].error.max_deg);
  }
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    CHECK(x.dofs[d].error.mean_deg == y.dofs[d].error.mean_deg);
    CHECK(x.dofs[d].error.rms_deg == y.dofs[d].error.rms_deg);
    CHECK(x.dofs[d].error.max_deg == y.dofs[d].error.max_deg);
  }
  for (std::size_t i = 0; i < kCurvePoints; ++i) CHECK(x.curve[i].share == y.curve[i].share);
  CHECK(to_json(x) == to_json(y));
}

// Frames x 25 angles, errors mostly a few degrees, some beyond 180 degrees, some frames non-finite.
void random_frames(std::size_t frames, std::vector<double>& predicted, std::vector<double>& truth) {
  std::mt19937_64 rng(20190731);
  std::normal_distribution<double> angle(0.5, 0.6), error(0.0, 0.15);
  std::uniform_int_distribution<int> rare(0, 99);
  predicted.resize(frames * hand::kDofCount);
  truth.resize(frames * hand::kDofCount);
  for (std::size_t i = 0; i < predicted.size(); ++i) {
    truth[i] = angle(rng);
    predicted[i] = truth[i] + error(rng);
    const int r = rare(rng);
    if (r == 0) predicted[i] = truth[i] + 4.0;  // 229 degrees: kept outside the histogram
    if (r == 1 && i % 7 == 0) truth[i] = std::numeric_limits<double>::quiet_NaN();
  }
}

}  // namespace

TEST_CASE("metrics: two hand-computed frames give the exact mean, per DoF, per finger, share, curve and percentiles") {
  const AngleErrorReport r = two_hand_computed_frames().report();
  CHECK(r.frames == 2);
  CHECK(r.skipped_frames == 0);
  CHECK(r.angles == 50);
  // (sum_d (d + 0.5) + 25 * 30.5) / 50 = (312.5 + 762.5) / 50; fixed-point sums make this exact.
  CHECK(r.overall.mean_deg == 21.5);
  double squares = 0.0;
  for (int d = 0; d < 25; ++d) squares += (d + 0.5) * (d + 0.5) + 30.5 * 30.5;
  CHECK(r.overall.rms_deg == doctest::Approx(std::sqrt(squares / 50.0)).epsilon(1e-14));
  CHECK(r.overall.max_deg == doctest::Approx(30.5).epsilon(1e-13));

  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    CHECK(std::string(r.dofs[d].name) == hand::kDofs[d].name);
    CHECK(r.dofs[d].theta == hand::kDofs[d].theta);
    CHECK(r.dofs[d].error.mean_deg == (static_cast<double>(d) + 31.0) / 2.0);
    const double e = static_cast<double>(d) + 0.5;
    CHECK(r.dofs[d].error.rms_deg == doctest::Approx(std::sqrt((e * e + 30.5 * 30.5) / 2.0)).epsilon(1e-14));
    CHECK(r.dofs[d].error.max_deg == doctest::Approx(30.5).epsilon(1e-13));
  }

  // Thumb DoFs 0-3 and 20: (0.5 + 1.5 + 2.5 + 3.5 + 20.5 + 5 * 30.5) / 10 = 18.1, and so on.
  CHECK(std::string(r.fingers[0].name) == "thumb");
  CHECK(std::string(r.fingers[4].name) == "pinky");
  CHECK(r.fingers[0].error.mean_deg == 18.1);
  CHECK(r.fingers[1].error.mean_deg == 19.8);
  CHECK(r.fingers[2].error.mean_deg == 21.5);
  CHECK(r.fingers[3].error.mean_deg == 23.2);
  CHECK(r.fingers[4].error.mean_deg == 24.9);

  // 0.5 .. 14.5 are the 15 errors below 15 degrees, of 50.
  CHECK(r.share_under_15deg == 0.3);
  for (int t = 0; t <= kCurveMaxDeg; ++t) {
    const auto& point = r.curve[static_cast<std::size_t>(t)];
    CHECK(point.threshold_deg == t);
    const double expected = t <= 25 ? t / 50.0 : (t <= 30 ? 0.5 : 1.0);
    CHECK(point.share == expected);
  }

  // Nearest rank: the 25th of 50 sorted errors is 24.5, the 48th is 30.5.
  CHECK(std::abs(r.median_deg - 24.5) <= kPercentileResolutionDeg / 2 + 1e-12);
  CHECK(std::abs(r.p95_deg - 30.5) <= kPercentileResolutionDeg / 2 + 1e-12);
  CHECK(r.percentile_resolution_deg == kPercentileResolutionDeg);
}

TEST_CASE("metrics: percentiles are nearest rank, clamped to the observed errors, exact beyond 180 degrees") {
  AngleErrorAccumulator acc;
  hand::Angles predicted{}, truth{};
  // 25 angles of exactly 10 degrees error (+ a little): every percentile is that one error.
  frame_with_errors(std::vector<double>(hand::kDofCount, 10.0), predicted, truth);
  acc.add(predicted, truth);
  CHECK(acc.percentile(0.0) == doctest::Approx(10.0).epsilon(1e-13));
  CHECK(acc.percentile(0.5) == doctest::Approx(10.0).epsilon(1e-13));
  CHECK(acc.percentile(1.0) == doctest::Approx(10.0).epsilon(1e-13));
  CHECK(acc.share_below(10.0 - 1e-9) == 0.0);
  CHECK(acc.share_below(11.0) == 1.0);

  // A second frame 200 degrees off everywhere: half the errors are beyond the histogram.
  frame_with_errors(std::vector<double>(hand::kDofCount, 200.0), predicted, truth);
  acc.add(predicted, truth);
  const AngleErrorReport r = acc.report();
  // Rank 25 of 50 is a 10-degree error, now histogram-resolved: the maximum no longer clamps it.
  CHECK(std::abs(r.median_deg - 10.0) <= kPercentileResolutionDeg / 2 + 1e-12);
  CHECK(r.p95_deg == doctest::Approx(200.0).epsilon(1e-13));
  CHECK(r.overall.mean_deg == doctest::Approx(105.0).epsilon(1e-13));
  CHECK(r.overall.max_deg == doctest::Approx(200.0).epsilon(1e-13));
  CHECK(r.curve.back().share == 0.5);
  CHECK(acc.share_below(199.0) == 0.5);
  CHECK(acc.share_below(201.0) == 1.0);
  CHECK(acc.percentile(0.51) == doctest::Approx(200.0).epsilon(1e-13));
}

TEST_CASE("metrics: the cumulative curve starts at 0, never falls, and reaches 1 at a large threshold") {
  std::vector<double> predicted, truth;
  random_frames(400, predicted, truth);
  AngleErrorAccumulator acc;
  acc.add_batch(predicted.data(), truth.data(), 400);
  const AngleErrorReport r = acc.report();
  CHECK(r.curve.front().share == 0.0);
  for (std::size_t i = 1; i < kCurvePoints; ++i) CHECK(r.curve[i].share >= r.curve[i - 1].share);
  CHECK(r.curve[15].share == r.share_under_15deg);
  CHECK(r.curve.back().share < 1.0);  // the 229-degree errors are not below 45
  CHECK(acc.share_below(1e6) == 1.0);
  CHECK(r.median_deg <= r.p95_deg);
  CHECK(r.p95_deg <= r.overall.max_deg);
  CHECK(r.overall.mean_deg <= r.overall.rms_deg);
}

TEST_CASE("metrics: merged accumulators equal one sequential accumulator exactly, whatever the split") {
  const std::size_t frames = 1000;
  std::vector<double> predicted, truth;
  random_frames(frames, predicted, truth);

  AngleErrorAccumulator sequential;
  for (std::size_t f = 0; f < frames; ++f) sequential.add(predicted.data() + f * 25, truth.data() + f * 25);
  const AngleErrorReport expected = sequential.report();
  REQUIRE(expected.skipped_frames > 0);                    // the split covers skipped frames
  REQUIRE(expected.overall.max_deg > kHistogramLimitDeg);  // and errors kept outside the histogram

  // Three uneven parts, merged in two different orders.
  const std::size_t cut1 = 137, cut2 = 731;
  AngleErrorAccumulator a, b, c;
  a.add_batch(predicted.data(), truth.data(), cut1);
  b.add_batch(predicted.data() + cut1 * 25, truth.data() + cut1 * 25, cut2 - cut1);
  c.add_batch(predicted.data() + cut2 * 25, truth.data() + cut2 * 25, frames - cut2);

  AngleErrorAccumulator abc;
  abc.merge(a);
  abc.merge(b);
  abc.merge(c);
  AngleErrorAccumulator cba = c;
  cba.merge(b);
  cba.merge(a);
  CHECK(abc.frames() + abc.skipped_frames() == frames);
  check_equal(abc.report(), expected);
  check_equal(cba.report(), expected);

  // Merging an accumulator into itself counts its frames twice.
  AngleErrorAccumulator twice = sequential;
  twice.merge(twice);
  AngleErrorAccumulator added_twice = sequential;
  added_twice.add_batch(predicted.data(), truth.data(), frames);
  check_equal(twice.report(), added_twice.report());

  // Adding in reverse frame order changes nothing either.
  AngleErrorAccumulator reversed;
  for (std::size_t f = frames; f-- > 0;) reversed.add(predicted.data() + f * 25, truth.data() + f * 25);
  check_equal(reversed.report(), expected);
}

TEST_CASE("metrics: float blocks give the same report as the same angles added as doubles") {
  std::vector<double> predicted, truth;
  random_frames(300, predicted, truth);
  const std::vector<float> predicted_f(predicted.begin(), predicted.end()), truth_f(truth.begin(), truth.end());
  const std::vector<double> predicted_d(predicted_f.begin(), predicted_f.end()), truth_d(truth_f.begin(), truth_f.end());
  AngleErrorAccumulator from_float, from_double;
  const std::size_t skipped = from_float.add_batch(predicted_f.data(), truth_f.data(), 300);
  for (std::size_t f = 0; f < 300; ++f) from_double.add(predicted_d.data() + f * 25, truth_d.data() + f * 25);
  CHECK(skipped == from_float.skipped_frames());
  check_equal(from_float.report(), from_double.report());
}

TEST_CASE("metrics: frames with a non-finite angle are skipped and counted, not averaged") {
  AngleErrorAccumulator clean = two_hand_computed_frames();
  AngleErrorAccumulator dirty = two_hand_computed_frames();
  hand::Angles predicted{}, truth{};
  truth[3] = std::numeric_limits<double>::quiet_NaN();
  CHECK_FALSE(dirty.add(predicted, truth));
  truth[3] = 0.0;
  predicted[24] = -std::numeric_limits<double>::infinity();
  CHECK_FALSE(dirty.add(predicted, truth));
  predicted[24] = 0.0;
  predicted[0] = 1e308;  // finite, but the error in degrees overflows
  truth[0] = -1e308;
  CHECK_FALSE(dirty.add(predicted, truth));

  std::vector<float> block(2 * 25, 0.0f), block_truth(2 * 25, 0.0f);
  block_truth[25 + 7] = std::numeric_limits<float>::quiet_NaN();  // second frame only
  CHECK(dirty.add_batch(block.data(), block_truth.data(), 2) == 1);
  clean.add_batch(block.data(), block_truth.data(), 1);

  const AngleErrorReport r = dirty.report();
  CHECK(r.frames == 3);
  CHECK(r.skipped_frames == 4);
  CHECK(std::isfinite(r.overall.mean_deg));
  AngleErrorReport expected = clean.report();
  expected.skipped_frames = 4;
  check_equal(r, expected);
  CHECK(to_json(r).find("\"skipped_frames\": 4,") != std::string::npos);
  CHECK(format_table(r).find("4 frames skipped (non-finite angles)") != std::string::npos);
}

TEST_CASE("metrics: misuse and empty reports throw glovepose::Error naming the problem") {
  AngleErrorAccumulator acc;
  CHECK(acc.empty());
  CHECK_THROWS_WITH_AS(acc.report(), doctest::Contains("no valid frames (0 skipped"), Error);
  hand::Angles good{}, bad{};
  bad[0] = std::numeric_limits<double>::quiet_NaN();
  acc.add(bad, good);
  CHECK_THROWS_WITH_AS(acc.report(), doctest::Contains("no valid frames (1 skipped"), Error);
  CHECK_THROWS_AS(acc.percentile(0.5), Error);
  const double* null = nullptr;
  CHECK_THROWS_WITH_AS(acc.add(null, good.data()), doctest::Contains("predicted is null"), Error);
  CHECK_THROWS_WITH_AS(acc.add_batch(good.data(), null, 1), doctest::Contains("truth is null"), Error);
  CHECK(acc.add_batch(null, null, 0) == 0);  // nothing to read
  acc.add(good, good);
  CHECK_FALSE(acc.empty());
  CHECK_THROWS_WITH_AS(acc.percentile(1.5), doctest::Contains("expected a share in [0, 1]"), Error);
  CHECK_THROWS_AS(acc.share_below(std::nan("")), Error);
  CHECK(acc.report().overall.mean_deg == 0.0);
  acc.clear();
  CHECK(acc.empty());
  CHECK(acc.skipped_frames() == 0);
}

TEST_CASE("metrics: JSON carries the figures with stable keys and round-trip digits") {
  const AngleErrorReport r = two_hand_computed_frames().report();
  const std::string text = to_json(r);
  CHECK(text.find("\"mean_deg\": 21.5,") != std::string::npos);
  CHECK(text.find("\"share_under_15deg\": 0.3,") != std::string::npos);
  CHECK(text.find("{\"dof\": \"index_base_flexion\", \"theta\": 14, \"scored\": true, \"mean_deg\": 18,") != std::string::npos);
  CHECK(text.find("{\"finger\": \"thumb\", \"mean_deg\": 18.1,") != std::string::npos);

  const io::json::Value json = io::json::parse(text);
  REQUIRE(json.is_object());
  CHECK(json.at("format").get<std::string>() == "glovepose-angle-errors");
  CHECK(json.at("frames").get<double>() == 2);
  CHECK(json.at("angles").get<double>() == 50);
  CHECK(json.at("rms_deg").get<double>() == r.overall.rms_deg);  // shortest round-trip text reads back exactly
  CHECK(json.at("median_deg").get<double>() == r.median_deg);
  CHECK(json.at("p95_deg").get<double>() == r.p95_deg);
  CHECK(json.at("percentile_resolution_deg").get<double>() == kPercentileResolutionDeg);
  const io::json::Value& dofs = json.at("dofs");
  REQUIRE(dofs.size() == hand::kDofCount);
  CHECK(dofs[24].at("dof").get<std::string>() == "pinky_base_twist");
  CHECK(dofs[24].at("rms_deg").get<double>() == r.dofs[24].error.rms_deg);
  const io::json::Value& fingers = json.at("fingers");
  REQUIRE(fingers.size() == hand::kFingerCount);
  CHECK(fingers[3].at("mean_deg").get<double>() == 23.2);
  const io::json::Value& curve = json.at("cumulative");
  REQUIRE(curve.at("threshold_deg").size() == kCurvePoints);
  REQUIRE(curve.at("share").size() == kCurvePoints);
  CHECK(curve.at("threshold_deg")[15].get<double>() == 15);
  CHECK(curve.at("share")[15].get<double>() == 0.3);
  CHECK(curve.at("share")[45].get<double>() == 1.0);

  AngleErrorReport hand_made = r;
  hand_made.overall.mean_deg = std::numeric_limits<double>::quiet_NaN();
  CHECK(to_json(hand_made).find("\"mean_deg\": null,") != std::string::npos);
}

TEST_CASE("metrics: the table has the overall, finger, DoF and curve lines") {
  const std::string table = format_table(two_hand_computed_frames().report());
  CHECK(table.find("2 frames x 25 angles") != std::string::npos);
  CHECK(table.find("skipped") == std::string::npos);
  CHECK(table.find("all                        21.500") != std::string::npos);
  CHECK(table.find("30.0%") != std::string::npos);
  CHECK(table.find("thumb                      18.100") != std::string::npos);
  CHECK(table.find("middle_base_twist") != std::string::npos);
  CHECK(table.find("5 deg 10.0%  10 deg 20.0%  15 deg 30.0%  20 deg 40.0%  30 deg 50.0%") != std::string::npos);
}

TEST_CASE("metrics: the 128-bit fixed-point sum carries past 64 bits, also when merged") {
  // Reaching 2^64 units (2^32 degrees) takes about 17 million frames of 10-degree errors; test the
  // carry on the sum itself instead.
  train::detail::FixedSum a, b;
  a.add(~std::uint64_t{0});
  a.add(std::uint64_t{2});  // 2^64 + 1
  CHECK(a.high == 1);
  CHECK(a.low == 1);
  b.add(~std::uint64_t{0});  // 2^64 - 1
  a.add(b);                  // 2^65
  CHECK(a.high == 2);
  CHECK(a.low == 0);
  CHECK(a.value() == 0x1p33);  // 2^65 units of 2^-32
  CHECK(train::detail::to_fixed(1.5) == (std::uint64_t{3} << 31));
}

TEST_CASE("statistics: one percentile, the nearest rank, for samples and histograms alike") {
  // Hand-computed: the ceil(q n)-th smallest, the smallest for q = 0.
  CHECK(core::nearest_rank(1, 0.0) == 1);
  CHECK(core::nearest_rank(1, 1.0) == 1);
  CHECK(core::nearest_rank(4, 0.0) == 1);
  CHECK(core::nearest_rank(4, 0.25) == 1);
  CHECK(core::nearest_rank(4, 0.5) == 2);
  CHECK(core::nearest_rank(4, 0.95) == 4);
  CHECK(core::nearest_rank(4, 1.0) == 4);
  CHECK(core::nearest_rank(20, 0.95) == 19);  // 0.95 * 20 rounds above 19 in doubles: still rank 19
  CHECK(core::nearest_rank(0, 0.5) == 0);
  const std::vector<double> four{7.0, 1.0, 5.0, 3.0};
  CHECK(core::percentile(four, 0.0) == 1.0);
  CHECK(core::percentile(four, 0.25) == 1.0);
  CHECK(core::percentile(four, 0.5) == 3.0);
  CHECK(core::percentile(four, 0.95) == 7.0);
  CHECK(core::percentile(four, 1.0) == 7.0);
  CHECK(core::percentile({}, 0.5) == 0.0);
  // A histogram of whole numbers gives the bin of the same value as the sample itself.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> value(0, 29);
  std::vector<double> sample;
  std::vector<std::uint64_t> histogram(30, 0);
  for (int i = 0; i < 997; ++i) {
    const int v = value(rng);
    sample.push_back(v);
    ++histogram[static_cast<std::size_t>(v)];
  }
  for (double q : {0.0, 0.01, 0.25, 0.5, 0.95, 0.99, 1.0}) {
    INFO("q = " << q);
    CHECK(static_cast<double>(core::bin_of_rank(histogram, core::nearest_rank(sample.size(), q))) == core::percentile(sample, q));
  }
}
