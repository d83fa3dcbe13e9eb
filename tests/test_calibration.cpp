#include <glovepose/sensor/calibration.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>

#include "alloc_counter.hpp"

using namespace glovepose;
using namespace glovepose::sensor;

namespace {
std::vector<std::string> names(int n) {
  std::vector<std::string> out;
  for (int i = 0; i < n; ++i) out.push_back("cell " + std::to_string(i));
  return out;
}
std::string temp_path(const std::string& name) { return std::string(GLOVEPOSE_TEST_TMP_DIR) + "/" + name; }
void write_file(const std::string& path, const std::string& text) { std::ofstream(path) << text; }
}  // namespace

TEST_CASE("calibration: on-the-fly min/max are the extremes of the 20-frame running median") {
  const int sensors = 6, frames = 300;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.3);
  Eigen::MatrixXd data(frames, sensors);
  for (int f = 0; f < frames; ++f)
    for (int s = 0; s < sensors; ++s) data(f, s) = 20.0 + s + 5.0 * std::sin(0.05 * f + s) + noise(rng);
  data(100, 2) = 500.0;  // single-frame spikes: a median over 20 frames never lets them through
  data(150, 4) = 0.0;

  OnTheFlyCalibrator calibrator(names(sensors), 20);
  for (int f = 0; f < frames; ++f) {
    const Status s = calibrator.add(data.row(f).transpose());
    CHECK(s == (f < 19 ? Status::NotReady : Status::Ok));
  }
  const CalibrationRange range = calibrator.finish();
  // Independent: sort each window and take its median (mean of the two middle values).
  for (int s = 0; s < sensors; ++s) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (int end = 19; end < frames; ++end) {
      std::vector<double> w;
      for (int k = end - 19; k <= end; ++k) w.push_back(data(k, s));
      std::sort(w.begin(), w.end());
      const double median = 0.5 * (w[9] + w[10]);
      lo = std::min(lo, median);
      hi = std::max(hi, median);
    }
    CHECK(range.min()(s) == doctest::Approx(lo).epsilon(1e-12));
    CHECK(range.max()(s) == doctest::Approx(hi).epsilon(1e-12));
  }
  CHECK(range.max()(2) < 40.0);  // the spike did not reach the range
  CHECK(range.min()(4) > 10.0);
  CHECK(range.flat_sensors().empty());
}

TEST_CASE("calibration: finishing early, bad frames and bad settings") {
  OnTheFlyCalibrator calibrator(names(3), 20);
  for (int f = 0; f < 10; ++f) CHECK(calibrator.add(Eigen::Vector3d(1.0, 2.0, 3.0 + f)) == Status::NotReady);
  CHECK_THROWS_WITH_AS((void)calibrator.finish(), doctest::Contains("10 frames, expected at least 20"), Error);
  CHECK(calibrator.add(Eigen::Vector3d(1.0, std::nan(""), 3.0)) == Status::NonFinite);
  CHECK(calibrator.add(Eigen::Vector2d(1.0, 2.0)) == Status::SizeMismatch);
  CHECK(calibrator.frames() == 10);  // rejected frames were not counted
  CHECK_THROWS_WITH_AS(OnTheFlyCalibrator(names(3), 0), doctest::Contains("median window 0"), Error);
  CHECK_THROWS_AS(OnTheFlyCalibrator({}, 20), Error);
}

TEST_CASE("calibration: normalisation to [-1, 1], clamping, and flat sensors reported by name") {
  Eigen::VectorXd lo(3), hi(3);
  lo << 10.0, 20.0, 30.0;
  hi << 20.0, 40.0, 30.1;  // sensor 2 moves by 0.3%: too small a range
  const CalibrationRange range(lo, hi, {"index base", "index middle", "pinky tip"});
  REQUIRE(range.flat_sensors() == std::vector<std::string>{"pinky tip"});
  Eigen::Vector3d out;
  REQUIRE(range.normalize(Eigen::Vector3d(10.0, 40.0, 30.05), out) == Status::Ok);
  CHECK(out(0) == doctest::Approx(-1.0));
  CHECK(out(1) == doctest::Approx(1.0));
  CHECK(out(2) == 0.0);  // flat: not divided by
  REQUIRE(range.normalize(Eigen::Vector3d(15.0, 25.0, 31.0), out) == Status::Ok);
  CHECK(out(0) == doctest::Approx(0.0));
  CHECK(out(1) == doctest::Approx(-0.5));
  REQUIRE(range.normalize(Eigen::Vector3d(100.0, -100.0, 30.0), out) == Status::Ok);
  CHECK(out(0) == doctest::Approx(1.5));  // clamped at clamp_limit
  CHECK(out(1) == doctest::Approx(-1.5));
  out.setConstant(9.0);
  CHECK(range.normalize(Eigen::Vector3d(1.0, std::nan(""), 2.0), out) == Status::NonFinite);
  CHECK(range.normalize(Eigen::Vector2d(1.0, 2.0), out) == Status::SizeMismatch);
  CHECK(out.isConstant(9.0));
  Eigen::Vector3f as_float;  // the network's input precision
  REQUIRE(range.normalize(Eigen::Vector3d(15.0, 30.0, 30.0), as_float) == Status::Ok);
  CHECK(as_float(1) == doctest::Approx(0.0f));

  Eigen::VectorXd bad_hi = hi;
  bad_hi(1) = 10.0;
  CHECK_THROWS_WITH_AS(CalibrationRange(lo, bad_hi, {"a", "b", "c"}), doctest::Contains("b has min 20.000000 above max 10.000000"), Error);
  CHECK_THROWS_WITH_AS(CalibrationRange(lo, hi, {"a", "b"}), doctest::Contains("expected one of each per sensor"), Error);
}

TEST_CASE("calibration: the training-data alternative takes per-sensor min and max over all frames") {
  Eigen::MatrixXd frames(4, 2);
  frames << 1, 10, 5, 8, -2, 12, 3, 9;
  const CalibrationRange range = CalibrationRange::from_frames(frames, {"a", "b"});
  CHECK(range.min()(0) == -2.0);
  CHECK(range.max()(0) == 5.0);
  CHECK(range.min()(1) == 8.0);
  CHECK(range.max()(1) == 12.0);
  CHECK_THROWS_AS(CalibrationRange::from_frames(Eigen::MatrixXd(0, 2), {"a", "b"}), Error);
}

TEST_CASE("calibration: a user's calibration saves and loads exactly") {
  Eigen::VectorXd lo(3), hi(3);
  lo << 10.0 / 3.0, 20.000000000000004, 1e-7;
  hi << 20.0, 40.0 / 7.0 + 100.0, 2.0;
  const CalibrationRange range(lo, hi, {"a", "b", "c"});
  const std::string path = temp_path("user.calibration");
  range.save(path, "glauser2019-44");
  const CalibrationRange loaded = CalibrationRange::load(path, "glauser2019-44", {"a", "b", "c"});
  CHECK(loaded.min() == range.min());
  CHECK(loaded.max() == range.max());
}

TEST_CASE("calibration: a malformed calibration file names the line and what was expected") {
  const std::string path = temp_path("bad.calibration");
  const std::vector<std::string> n{"a", "b"};
  const auto load = [&] { return CalibrationRange::load(path, "glove-x", n); };
  write_file(path, "something else\n");
  CHECK_THROWS_WITH_AS(load(), doctest::Contains("line 1: header 'something else', expected 'glovepose-calibration 1'"), Error);
  write_file(path, "glovepose-calibration 1\nglove\tglove-y\n");
  CHECK_THROWS_WITH_AS(load(), doctest::Contains("line 2: 'glove\tglove-y', expected 'glove\tglove-x'"), Error);
  write_file(path, "glovepose-calibration 1\nglove\tglove-x\nsensors\t3\n");
  CHECK_THROWS_WITH_AS(load(), doctest::Contains("line 3: 'sensors\t3', expected 'sensors\t2'"), Error);
  write_file(path, "glovepose-calibration 1\nglove\tglove-x\nsensors\t2\na\t1\t2\n");
  CHECK_THROWS_WITH_AS(load(), doctest::Contains("line 5: file ends early"), Error);
  write_file(path, "glovepose-calibration 1\nglove\tglove-x\nsensors\t2\na\t1\t2\nz\t1\t2\n");
  CHECK_THROWS_WITH_AS(load(), doctest::Contains("line 5: sensor 'z', expected 'b'"), Error);
  write_file(path, "glovepose-calibration 1\nglove\tglove-x\nsensors\t2\na\t1\t2\nb\t1x\t2\n");
  CHECK_THROWS_WITH_AS(load(), doctest::Contains("line 5: '1x' is not a number"), Error);
  write_file(path, "glovepose-calibration 1\nglove\tglove-x\nsensors\t2\na\t1\nb\t1\t2\n");
  CHECK_THROWS_WITH_AS(load(), doctest::Contains("line 4: expected 'name<TAB>min<TAB>max'"), Error);
  write_file(path, "glovepose-calibration 1\nglove\tglove-x\nsensors\t2\na\t1\t2\nb\t3\t2\n");
  CHECK_THROWS_WITH_AS(load(), doctest::Contains("b has min 3.000000 above max 2.000000"), Error);
  CHECK_THROWS_WITH_AS(CalibrationRange::load(temp_path("missing.calibration"), "g", n), doctest::Contains("cannot open"), Error);
}

TEST_CASE("calibration: per-frame calls allocate nothing") {
  OnTheFlyCalibrator calibrator(names(44), 20);
  Eigen::VectorXd frame = Eigen::VectorXd::LinSpaced(44, 1.0, 2.0);
  Eigen::VectorXd out(44);
  const std::size_t allocations = test::allocations_during([&] {
    for (int f = 0; f < 40; ++f) {
      frame.array() += 0.01;
      (void)calibrator.add(frame);
    }
  });
  CHECK(allocations == 0);
  const CalibrationRange range = calibrator.finish();
  CHECK(test::allocations_during([&] { (void)range.normalize(frame, out); }) == 0);
}
