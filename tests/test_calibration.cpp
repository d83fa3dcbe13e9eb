#include <glovepose/grid/glove_description.hpp>
#include <glovepose/sensor/calibration.hpp>

#include <doctest/doctest.h>

#include "test_files.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

#include "alloc_counter.hpp"

using namespace glovepose;
using namespace glovepose::sensor;

namespace {
std::vector<std::string> names(int n) {
  std::vector<std::string> out;
  for (int i = 0; i < n; ++i) out.push_back("cell " + std::to_string(i));
  return out;
}
using glovepose::test::temp_path;
void write_file(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

// A hand exploring its extreme poses, as a calibration asks: per finger, minimum-jerk moves of
// 0.4-1.2 s between a nearly open (0-0.15) and a nearly closed (0.85-1) pose, each held 0.1-0.6 s.
// Returns frames x fingers values in [0, 1] sampled at `rate` Hz.
Eigen::MatrixXd exploring_hand(int frames, double rate, int fingers, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::MatrixXd out(frames, fingers);
  for (int k = 0; k < fingers; ++k) {
    double from = 0.15 * u(rng), to = 0.85 + 0.15 * u(rng), start = -0.5 * u(rng), move = 0.4 + 0.8 * u(rng), hold = 0.1 + 0.5 * u(rng);
    for (int f = 0; f < frames; ++f) {
      const double t = f / rate;
      while (t > start + move + hold) {
        start += move + hold;
        from = to;
        to = from > 0.5 ? 0.15 * u(rng) : 0.85 + 0.15 * u(rng);
        move = 0.4 + 0.8 * u(rng);
        hold = 0.1 + 0.5 * u(rng);
      }
      const double s = std::clamp((t - start) / move, 0.0, 1.0);
      out(f, k) = from + (to - from) * s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
    }
  }
  return out;
}

// Names that are not substrings of each other: ch00 .. ch31.
std::vector<std::string> channel_names(int n) {
  std::vector<std::string> out;
  char buf[16];
  for (int i = 0; i < n; ++i) {
    std::snprintf(buf, sizeof buf, "ch%02d", i);
    out.push_back(buf);
  }
  return out;
}

// The on-the-fly range of `frames` with the median window a glove description gives by default at
// `rate` (a third of a second: 3 frames at 10 Hz, 20 at 60 Hz).
CalibrationRange onthefly(const Eigen::MatrixXd& frames, double rate, const std::vector<std::string>& names, CalibrationConfig config) {
  OnTheFlyCalibrator calibrator(names, grid::GloveCalibration{}.median_frames(rate), config);
  for (Eigen::Index f = 0; f < frames.rows(); ++f) REQUIRE(calibrator.add(frames.row(f).transpose()) != Status::NonFinite);
  return calibrator.finish();
}
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
  CHECK_THROWS_WITH_AS(load(), doctest::Contains("line 1: header 'something else', expected 'glovepose-calibration 2'"), Error);
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

TEST_CASE(
    "calibration: the noise estimate reads the SD of white noise, through glitches and slow movement, and fast movement is no noise") {
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 3.7);
  const int frames = 20000;
  NoiseEstimator still(1), slow(1), fast(1), spiky(1);
  for (int f = 0; f < frames; ++f) {
    const double n = noise(rng);
    still.add(Eigen::Matrix<double, 1, 1>(1000.0 + n));
    // Movements 40 times the noise's SD, over 2000 frames and over 60 (a second at 60 Hz).
    slow.add(Eigen::Matrix<double, 1, 1>(1000.0 + 150.0 * std::sin(2.0 * 3.14159265358979 * f / 2000.0) + n));
    fast.add(Eigen::Matrix<double, 1, 1>(1000.0 + 150.0 * std::sin(2.0 * 3.14159265358979 * f / 60.0) + n));
    // Single-frame glitches every 50 frames, 500 SDs high.
    spiky.add(Eigen::Matrix<double, 1, 1>(1000.0 + n + (f % 50 == 7 ? 1850.0 : 0.0)));
  }
  CHECK(still.sd()(0) == doctest::Approx(3.7).epsilon(0.03));
  CHECK(slow.sd()(0) == doctest::Approx(3.7).epsilon(0.05));
  // Where the reading moves by more than its noise per frame, three readings are in order and leave
  // no residual: the movement never counts as noise (the estimate reads low).
  CHECK(fast.sd()(0) < 3.7);
  CHECK(spiky.sd()(0) == doctest::Approx(3.7).epsilon(0.1));  // the RMS of the residuals: 70 times more
  CHECK(still.frames() == frames);
  NoiseEstimator few(2);
  few.add(Eigen::Vector2d(1.0, 2.0));
  few.add(Eigen::Vector2d(5.0, 2.0));
  few.add(Eigen::Vector2d(1.0, 9.0));
  few.add(Eigen::Vector2d(5.0, 2.0));
  CHECK(few.sd().isZero());  // four frames: no median of three residuals yet
  // The on-the-fly range carries the noise that passes its running median.
  OnTheFlyCalibrator calibrator({"a"}, 5);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (int f = 0; f < frames; ++f) (void)calibrator.add(Eigen::Matrix<double, 1, 1>(100.0 * std::sin(f / 200.0) + unit(rng)));
  CHECK(calibrator.finish().noise()(0) == doctest::Approx(median_noise_factor(5)).epsilon(0.05));
  CHECK(median_noise_factor(1) == 1.0);
  CHECK(median_noise_factor(3) == doctest::Approx(0.6686).epsilon(0.01));  // the SD of a median of 3 (simulated, 4e5 draws)
}

TEST_CASE("calibration: a resistive glove's dead channels (noise only, 0.8-1.5% range) are all named in one message, moving ones pass") {
  // The user's glove: 32 channels at 10 Hz, a 15 s calibration; 24 follow the fingers (a stretch
  // of 3-20% of their value) with the ADC's noise (SD 60 counts); 8 are dead: noise only around
  // 29,000 counts, their raw range 0.8-1.5% of the value.
  const double rate = 10.0;
  const int frames = 150, channels = 32;
  std::mt19937 rng(2026);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> adc(0.0, 60.0), unit(0.0, 1.0);
  const Eigen::MatrixXd hand = exploring_hand(frames, rate, 5, rng);
  const std::vector<int> dead{3, 7, 12, 13, 20, 26, 29, 31};
  const auto is_dead = [&](int c) { return std::find(dead.begin(), dead.end(), c) != dead.end(); };
  Eigen::MatrixXd readings(frames, channels);
  for (int c = 0; c < channels; ++c) {
    if (is_dead(c)) {
      Eigen::VectorXd z(frames);
      for (int f = 0; f < frames; ++f) z(f) = unit(rng);
      const double level = 29000.0 + 400.0 * (u(rng) - 0.5), range = (0.008 + 0.007 * u(rng)) * level;
      readings.col(c) = (level + (z.array() - z.mean()) * range / (z.maxCoeff() - z.minCoeff())).matrix();
      CHECK((readings.col(c).maxCoeff() - readings.col(c).minCoeff()) / readings.col(c).maxCoeff() ==
            doctest::Approx(0.0115).epsilon(0.32));
      continue;
    }
    const double base = 20000.0 + 20000.0 * u(rng), stretch = 0.03 + 0.17 * u(rng);
    for (int f = 0; f < frames; ++f) readings(f, c) = base * (1.0 + stretch * hand(f, c % 5)) + adc(rng);
  }
  const std::vector<std::string> names = channel_names(channels);
  std::vector<std::string> dead_names;
  for (int c : dead) dead_names.push_back(names[static_cast<std::size_t>(c)]);

  CalibrationConfig resistive;  // docs/own_glove.md's setting for resistive gloves
  resistive.min_relative_range = 0.001;
  for (const CalibrationConfig& config : {CalibrationConfig{}, resistive}) {
    CAPTURE(config.min_relative_range);
    const CalibrationRange range = onthefly(readings, rate, names, config);
    CHECK(range.flat_sensors() == dead_names);
    const std::string report = range.flat_report();
    INFO(report);
    CHECK(report.find("8 of 32 sensors read 0: ") == 0);
    for (int c = 0; c < channels; ++c) CHECK((report.find(names[static_cast<std::size_t>(c)] + " (") != std::string::npos) == is_dead(c));
    if (config.min_relative_range == 0.001) {  // not flat by their range: by their noise
      for (int c : dead) CHECK(range.flatness(c) == Flatness::NoiseOnly);
      MESSAGE(report);
    }
    CHECK(report.find("noise only: range ") != std::string::npos);
    Eigen::VectorXd out(channels);
    REQUIRE(range.normalize(readings.row(40).transpose(), out) == Status::Ok);
    for (int c : dead) CHECK(out(c) == 0.0);  // not stretched to full scale
  }
  // What the range rule alone did (the noise check off): with the resistive setting every dead
  // channel passed as moving, with the default some did.
  CalibrationConfig range_only = resistive;
  range_only.min_range_to_noise = 0.0;
  CHECK(onthefly(readings, rate, names, range_only).flat_sensors().empty());
  range_only.min_relative_range = 0.01;
  const std::size_t caught_by_range = onthefly(readings, rate, names, range_only).flat_sensors().size();
  CHECK(caught_by_range < dead.size());
  MESSAGE("the 1% range rule alone named " << caught_by_range << " of the 8 dead channels");
}

TEST_CASE("calibration: channels that move with the hand, with realistic noise, are not flagged at 10, 20 or 60 Hz") {
  // 100 calibrations of 32 channels each: a stretch of 3-20% of the value, noise SD 0.05-0.2% of
  // it, a 15 s (10, 20 Hz) or 30 s (60 Hz) calibration through the extreme poses.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double weakest = std::numeric_limits<double>::infinity();
  int flagged = 0;
  for (int calibration = 0; calibration < 100; ++calibration) {
    const double rate = calibration % 3 == 0 ? 60.0 : calibration % 3 == 1 ? 20.0 : 10.0;
    const int frames = static_cast<int>(rate * (rate == 60.0 ? 30.0 : 15.0)), channels = 32;
    const Eigen::MatrixXd hand = exploring_hand(frames, rate, 5, rng);
    Eigen::MatrixXd readings(frames, channels);
    for (int c = 0; c < channels; ++c) {
      const double base = 1000.0 + 39000.0 * u(rng), stretch = 0.03 + 0.17 * u(rng), sd = (0.0005 + 0.0015 * u(rng)) * base;
      std::normal_distribution<double> noise(0.0, sd);
      for (int f = 0; f < frames; ++f) readings(f, c) = base * (1.0 + stretch * hand(f, c % 5)) + noise(rng);
    }
    CalibrationConfig resistive;
    resistive.min_relative_range = 0.001;
    const CalibrationRange range = onthefly(readings, rate, channel_names(channels), resistive);
    flagged += static_cast<int>(range.flat_sensors().size());
    for (int c = 0; c < channels; ++c) weakest = std::min(weakest, (range.max()(c) - range.min()(c)) / range.noise()(c));
  }
  MESSAGE("weakest range / noise of a moving channel: " << weakest);
  CHECK(flagged == 0);
  CHECK(weakest > 1.5 * CalibrationConfig{}.min_range_to_noise);
}

TEST_CASE("calibration: a saved range keeps its noise and its noise-only sensors, and a file without noise reads as before") {
  Eigen::VectorXd lo(3), hi(3), noise(3);
  lo << 28900.0, 100.0, 5.0;
  hi << 29100.0, 180.0, 6.0;
  noise << 40.0, 0.5, 0.0;  // 200 / 40 = 5 noise SDs: noise only
  const CalibrationRange range(lo, hi, noise, {"dead", "moving", "unknown"}, CalibrationConfig{0.001});
  REQUIRE(range.flat_sensors() == std::vector<std::string>{"dead"});
  CHECK(range.flatness(0) == Flatness::NoiseOnly);
  CHECK(range.flatness(1) == Flatness::Moving);
  CHECK(range.flat_report().find("1 of 3 sensors read 0: dead (noise only: range 0.687% of its value, 5 x its noise SD)") == 0);
  const std::string path = temp_path("noise.calibration");
  range.save(path, "glove-x");
  std::ifstream file(path);
  std::string header, line;
  std::getline(file, header);
  CHECK(header == "glovepose-calibration 2");
  const CalibrationRange loaded = CalibrationRange::load(path, "glove-x", {"dead", "moving", "unknown"}, CalibrationConfig{0.001});
  CHECK(loaded.noise() == range.noise());
  CHECK(loaded.flat_sensors() == range.flat_sensors());
  write_file(path, "glovepose-calibration 1\nglove\tglove-x\nsensors\t1\ndead\t28900\t29100\n");
  const CalibrationRange old = CalibrationRange::load(path, "glove-x", {"dead"}, CalibrationConfig{0.001});
  CHECK(old.noise()(0) == 0.0);  // unknown: the range rule alone
  CHECK(old.flat_sensors().empty());
  write_file(path, "glovepose-calibration 2\nglove\tglove-x\nsensors\t1\ndead\t28900\t29100\n");
  CHECK_THROWS_WITH_AS(CalibrationRange::load(path, "glove-x", {"dead"}),
                       doctest::Contains("line 4: expected 'name<TAB>min<TAB>max<TAB>noise'"), Error);
  write_file(path, "glovepose-calibration 2\nglove\tglove-x\nsensors\t1\ndead\t28900\t29100\t-1\n");
  CHECK_THROWS_WITH_AS(CalibrationRange::load(path, "glove-x", {"dead"}), doctest::Contains("dead has noise SD -1"), Error);
}
