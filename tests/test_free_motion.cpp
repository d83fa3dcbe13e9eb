// Calibration without a calibration step (calibration/free_motion.hpp): the motion's histograms
// against percentiles computed here from the frames themselves, the range map's stages, its JSON,
// its fit against people whose ranges are a known function of their motion, and the estimator
// that starts from it.
#include <glovepose/calibration/free_motion.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/model/unet_model.hpp>
#include <glovepose/train/model_file.hpp>
#include <glovepose/train/range_map_fit.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "test_files.hpp"
#include "unet_reference.hpp"

using namespace glovepose;
using calibration::ContinuousRange;
using calibration::MotionHistogram;
using calibration::MotionHistogramConfig;
using calibration::RangeMap;

namespace {

// The q-th percentile of `values` with weights `weights`: the value where the weights below reach
// q% of their sum (the histogram's definition, without bins).
double weighted_percentile(std::vector<double> values, std::vector<double> weights, double q) {
  std::vector<std::size_t> order(values.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return values[a] < values[b]; });
  const double target = q / 100.0 * std::accumulate(weights.begin(), weights.end(), 0.0);
  double below = 0.0;
  for (std::size_t i : order) {
    below += weights[i];
    if (below >= target) return values[i];
  }
  return values[order.back()];
}

Eigen::VectorXd values_of(std::initializer_list<double> v) { return Eigen::Map<const Eigen::VectorXd>(v.begin(), static_cast<Eigen::Index>(v.size())); }

MotionHistogramConfig keep_all(double memory = 1e12) {
  MotionHistogramConfig c;
  c.novelty = 0.0;
  c.memory = memory;
  return c;
}

constexpr int kFeatures = calibration::kRangeFeatures;
constexpr int kMedian = 1 + static_cast<int>(std::size(calibration::kMotionPercentiles)) / 2;  // the P50 feature

// Features 1 and then the percentiles of a spread from `lowest` to `highest`, evenly.
std::vector<double> spread(double lowest, double highest) {
  std::vector<double> f(kFeatures, 1.0);
  for (int k = 1; k < kFeatures; ++k) f[static_cast<std::size_t>(k)] = lowest + (highest - lowest) * (k - 1) / (kFeatures - 2);
  return f;
}

// A map over `cells` cells with prior [0, 1] and stages at 100 and 400 frames whose weights are known.
RangeMap two_stage_map(int cells) {
  std::vector<RangeMap::Stage> stages;
  for (double frames : {100.0, 400.0}) {
    RangeMap::Stage s{frames, Eigen::MatrixXd::Zero(cells, kFeatures), Eigen::MatrixXd::Zero(cells, kFeatures)};
    for (int c = 0; c < cells; ++c) {
      s.low(c, 0) = -0.1 * frames / 100.0;  // min ~ 1.2 x the lowest percentile - 0.1 x the median - a stage's shift
      s.low(c, 1) = 1.2;
      s.low(c, kMedian) = -0.1;
      s.high(c, 0) = 0.1;
      s.high(c, kMedian) = -0.1;
      s.high(c, kFeatures - 1) = 1.2 + 0.01 * c;
    }
    stages.push_back(s);
  }
  return RangeMap(Eigen::VectorXd::Zero(cells), Eigen::VectorXd::Ones(cells), stages, keep_all(1000.0));
}

}  // namespace

TEST_CASE("free motion: the histograms' percentiles are the frames' own within a bin, and spikes do not move them") {
  const Eigen::VectorXd low = Eigen::VectorXd::Zero(3), high = Eigen::VectorXd::Ones(3);
  MotionHistogram h(low, high, keep_all());
  const double bin = 3.0 / 256.0;  // the prior range widened by one range on each side, in 256 bins
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal(0.5, 0.1);
  std::exponential_distribution<double> skewed(8.0);
  std::vector<std::vector<double>> values(3);
  for (int f = 0; f < 20000; ++f) {
    Eigen::VectorXd cells = values_of({uniform(rng), normal(rng), 0.1 + skewed(rng)});
    if (f % 100 == 7) cells(1) = 50.0;  // a spike in 1% of the frames: the min-max range would end at 50
    for (int c = 0; c < 3; ++c) values[static_cast<std::size_t>(c)].push_back(cells(c));
    CHECK(h.add(cells));
  }
  CHECK(h.taken() == 20000);
  for (int c = 0; c < 3; ++c)
    for (double q : calibration::kMotionPercentiles) {
      const std::vector<double> ones(values[static_cast<std::size_t>(c)].size(), 1.0);
      CHECK(std::abs(h.percentile(c, q) - weighted_percentile(values[static_cast<std::size_t>(c)], ones, q)) <= bin);
    }
  // The spikes moved the 95th percentile of cell 1 by about the 1% they take, not toward 50.
  CHECK(h.percentile(1, 95.0) < 0.5 + 1.7 * 0.1 + bin);
  double features[calibration::kRangeFeatures];
  for (int c = 0; c < 3; ++c) {  // the one-pass features are the percentiles one by one
    h.features(c, features);
    CHECK(features[0] == 1.0);
    for (int k = 1; k < kFeatures; ++k) CHECK(features[k] == h.percentile(c, calibration::kMotionPercentiles[k - 1]));
  }
  CHECK(features[kMedian] == h.percentile(2, 50.0));
}

TEST_CASE("free motion: older frames weigh less by the memory, as a weighted percentile computed here") {
  const double memory = 1000.0;
  MotionHistogram h(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), keep_all(memory));
  std::mt19937 rng(5);
  std::normal_distribution<double> before(0.2, 0.05), after(0.7, 0.05);
  std::vector<double> values, weights;
  const int frames = 8000;
  for (int f = 0; f < frames; ++f) {
    const double v = f < 5000 ? before(rng) : after(rng);
    values.push_back(v);
    (void)h.add(values_of({v}));
  }
  for (int f = 0; f < frames; ++f) weights.push_back(std::pow(1.0 - 1.0 / memory, frames - 1 - f));
  const double bin = 3.0 / 256.0;
  for (double q : {5.0, 50.0, 95.0}) CHECK(std::abs(h.percentile(0, q) - weighted_percentile(values, weights, q)) <= bin);
  // 3000 frames later, the first 5000 weigh e^-3 of their share: the 5th percentile has moved up.
  CHECK(h.percentile(0, 5.0) > 0.45);
  CHECK(h.effective_frames() == doctest::Approx(std::accumulate(weights.begin(), weights.end(), 0.0)).epsilon(1e-9));
}

TEST_CASE("free motion: a held pose is taken once, and a moving hand frame by frame") {
  MotionHistogramConfig config;
  config.novelty = 0.02;
  MotionHistogram h(Eigen::VectorXd::Zero(4), Eigen::VectorXd::Ones(4), config);
  std::mt19937 rng(6);
  std::normal_distribution<double> noise(0.0, 0.002);  // a sensor's noise, well below 2% of the range
  const Eigen::VectorXd held = values_of({0.3, 0.4, 0.5, 0.6});
  for (int f = 0; f < 600; ++f) (void)h.add(Eigen::VectorXd(held + values_of({noise(rng), noise(rng), noise(rng), noise(rng)})));
  CHECK(h.taken() == 1);
  CHECK(h.percentile(0, 50.0) == doctest::Approx(0.3).epsilon(0.05));
  for (int f = 1; f <= 100; ++f) CHECK(h.add(Eigen::VectorXd(held.array() + 0.03 * f)));  // 3% of the range a frame
  CHECK(h.taken() == 101);
}

TEST_CASE("range map: the prior, a stage, between stages in log frames, and a crossed pair") {
  const RangeMap map = two_stage_map(2);
  const std::vector<double> spread_features = spread(0.2, 0.8);
  const double* features = spread_features.data();
  const auto stage = [&](std::size_t s, Eigen::Index c) {
    const RangeMap::Stage& st = map.stages()[s];
    double lo = 0.0, hi = 0.0;
    for (int k = 0; k < kFeatures; ++k) lo += st.low(c, k) * features[k], hi += st.high(c, k) * features[k];
    return std::pair<double, double>{lo, hi};
  };
  CHECK(map.range(1, features, 0.0) == std::pair<double, double>{0.0, 1.0});
  // Half way to the first stage: half the prior and half the stage.
  const auto half = map.range(1, features, 50.0);
  CHECK(half.first == doctest::Approx(0.5 * stage(0, 1).first));
  CHECK(half.second == doctest::Approx(0.5 + 0.5 * stage(0, 1).second));
  CHECK(map.range(1, features, 100.0).first == doctest::Approx(stage(0, 1).first));
  // 200 frames: the geometric middle of 100 and 400.
  const auto middle = map.range(1, features, 200.0);
  CHECK(middle.first == doctest::Approx(0.5 * (stage(0, 1).first + stage(1, 1).first)));
  CHECK(middle.second == doctest::Approx(0.5 * (stage(0, 1).second + stage(1, 1).second)));
  CHECK(map.range(1, features, 1e6).second == doctest::Approx(stage(1, 1).second));  // past the last stage: the last
  // Features that put the minimum above the maximum: both at their middle.
  const std::vector<double> crossed = spread(0.9, 0.1);
  const auto [lo, hi] = map.range(0, crossed.data(), 400.0);
  CHECK(lo == hi);
}

TEST_CASE("range map: its JSON keeps every number, and a malformed one is refused by name") {
  const RangeMap map = two_stage_map(3);
  const RangeMap back = RangeMap::parse(map.to_json(), "test");
  const std::vector<double> features = spread(0.13, 0.77);
  for (double frames : {0.0, 30.0, 100.0, 250.0, 5000.0})
    for (Eigen::Index c = 0; c < 3; ++c) CHECK(back.range(c, features.data(), frames) == map.range(c, features.data(), frames));
  CHECK(back.histogram().memory == map.histogram().memory);
  CHECK(back.histogram().novelty == map.histogram().novelty);
  const std::string text = map.to_json();
  const auto refused = [](const std::string& json, const std::string& says) {
    try {
      (void)RangeMap::parse(json, "test");
      return false;
    } catch (const Error& e) {
      return std::string(e.what()).find(says) != std::string::npos;
    }
  };
  const auto with = [&](const std::string& from, const std::string& to) {
    std::string s = text;
    const std::size_t at = s.find(from);
    REQUIRE(at != std::string::npos);
    return s.replace(at, from.size(), to);
  };
  CHECK(refused(with("\"glovepose-range-map\"", "\"other\""), "format"));
  CHECK(refused(with("\"percentiles\":[", "\"percentiles\":[3.0,"), "percentiles"));
  CHECK(refused(with("\"frames\":400.0", "\"frames\":50.0"), "stage 1 starts at 50"));
  CHECK(refused(with("\"prior_max\":[1.0,1.0,1.0]", "\"prior_max\":[1.0,0.0,1.0]"), "cell 1 has prior range"));
  CHECK(refused(with("\"prior_max\":[1.0,1.0,1.0]", "\"prior_max\":[1.0,1.0]"), "expected one of each per cell"));
  CHECK(refused(with("\"memory\":1000.0", "\"memory\":0.5"), "memory"));
  CHECK(refused(text.substr(0, text.size() / 2), "range map 'test'"));
}

TEST_CASE("free motion: the range follows the motion every period, also after the clock went back") {
  RangeMap::Stage stage{20.0, Eigen::MatrixXd::Zero(1, kFeatures), Eigen::MatrixXd::Zero(1, kFeatures)};
  stage.low(0, kMedian) = 1.0;  // both limits at the median: easy to predict
  stage.high(0, kMedian) = 1.0;
  const RangeMap map(values_of({0.0}), values_of({1.0}), {stage}, keep_all(50.0));
  ContinuousRange follow(map, 0.25);
  int updates = 0;
  for (int f = 0; f < 600; ++f) updates += follow.add(values_of({0.2 + 0.001 * (f % 3)}), 100.0 + f / 60.0);  // 10 s at 60 Hz
  CHECK(updates >= 39);  // one per 0.25 s
  CHECK(updates <= 41);
  CHECK(follow.min()(0) == doctest::Approx(0.201).epsilon(0.02));
  // The glove's clock restarts at 0: the updates go on at once (not from t = 110 s on).
  for (int f = 0; f < 300; ++f) (void)follow.add(values_of({0.7 + 0.001 * (f % 3)}), f / 60.0);
  CHECK(follow.min()(0) == doctest::Approx(0.701).epsilon(0.02));
}

TEST_CASE("range map: fitted on people whose range is a known function of their motion, it finds that function") {
  // Each person's cells sweep [a, a + b] in the calibration sequence; their free motion spreads over
  // the middle of it (uniform over [a + 0.2 b, a + 0.8 b]: the q-th percentile is a + (0.2 + 0.6 q)
  // b), so a and b, the range, are linear in any two percentiles. Fitted on 40 people, the map must
  // give a new person's range within 2%.
  const int cells = 2, people = 41;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  io::Dataset data;
  data.cell_count = cells;
  data.metadata["frame_rate"] = "60";
  data.metadata["glove_layout"] = "test";
  std::vector<std::pair<double, double>> truth;  // per person, cell 0's (a, b)
  for (int p = 0; p < people; ++p) {
    const double a0 = 1.0 + u(rng), b0 = 0.5 + u(rng), a1 = 2.0 + u(rng), b1 = 1.0 + u(rng);
    truth.emplace_back(a0, b0);
    double t = 0.0;
    const auto frame = [&](double s0, double s1, std::uint8_t kind) {
      data.cells.push_back(static_cast<float>(a0 + b0 * s0));
      data.cells.push_back(static_cast<float>(a1 + b1 * s1));
      data.timestamps.push_back(t);
      t += 1.0 / 60.0;
      data.subject.push_back(p);
      data.session.push_back(0);
      data.glove.push_back(0);
      data.kind.push_back(kind);
      data.outlier.push_back(0);
    };
    for (int f = 0; f < 600; ++f) {  // the sequence: slow sweeps from 0 to 1 and back
      const double s = 0.5 - 0.5 * std::cos(2.0 * 3.14159265358979 * f / 300.0);
      frame(s, 1.0 - s, io::kKindCalibration);
    }
    for (int f = 0; f < 3000; ++f) frame(0.2 + 0.6 * u(rng), 0.2 + 0.6 * u(rng), io::kKindRecording);
  }
  train::FrameFilter fit_people;
  for (int p = 0; p < people - 1; ++p) fit_people.subjects.push_back(p);
  const train::RangeMapFit fit = train::fit_range_map(data, fit_people, grid::GloveCalibration{}, keep_all(4000.0), {100, 1000});
  CHECK(fit.runs == people - 1);
  REQUIRE(fit.stages.size() == 2);
  for (const auto& s : fit.stages) CHECK(s.map_error < 0.1 * s.prior_error);
  // The new person, followed as the estimator follows them, ends within 2% of their own range.
  ContinuousRange follow(fit.map, 0.25);
  const std::size_t first = static_cast<std::size_t>(people - 1) * 3600 + 600;
  for (std::size_t i = first; i < first + 3000; ++i)
    (void)follow.add(values_of({data.cells[2 * i], data.cells[2 * i + 1]}), data.timestamps[i]);
  const auto [a, b] = truth.back();
  CHECK(follow.min()(0) == doctest::Approx(a).epsilon(0.02));
  CHECK(follow.max()(0) == doctest::Approx(a + b).epsilon(0.02));
}

TEST_CASE("estimator: with a range map it poses from the first frame, follows the motion, and gives way to a set range") {
  const grid::GloveDescription glove = grid::GloveDescription::glauser2019();
  const int cells = glove.cell_count();
  model::ModelInfo info = train::make_model_info(model::Architecture::UNet, 4, glove, model::CalibrationMode::OnTheFly, nullptr);
  std::vector<RangeMap::Stage> stages;
  RangeMap::Stage stage{50.0, Eigen::MatrixXd::Zero(cells, kFeatures), Eigen::MatrixXd::Zero(cells, kFeatures)};
  stage.low.col(1).setOnes();              // min: the lowest percentile
  stage.high.col(kFeatures - 1).setOnes();  // max: the highest
  stages.push_back(stage);
  info.range_map.emplace(Eigen::VectorXd::Constant(cells, 1.0), Eigen::VectorXd::Constant(cells, 3.0), stages, MotionHistogramConfig{});
  const std::string path = test::temp_path("range_map_model.safetensors");
  train::save_model(path, info, test::random_tensors(nn::UNet<>::expected_tensors(4), 12), {});
  const auto model = PoseModel::load(path);
  REQUIRE(model->range_map());

  GlovePoseEstimator estimator(model);
  CHECK(estimator.calibration_source() == CalibrationSource::Continuous);
  ContinuousRange reference(*model->range_map());  // what the estimator must keep, fed the same frames
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(1.5, 2.5);
  std::vector<double> frame(static_cast<std::size_t>(cells));
  const auto next = [&] {
    for (double& v : frame) v = u(rng);
    return Eigen::Map<const Eigen::VectorXd>(frame.data(), cells);
  };
  (void)next();
  CHECK(estimator.push_cells(frame.data(), cells, 0.0) == Status::Solved);  // the first frame, with the prior range
  (void)reference.add(Eigen::Map<const Eigen::VectorXd>(frame.data(), cells), 0.0);
  std::vector<std::vector<double>> frames(600, std::vector<double>(static_cast<std::size_t>(cells)));
  for (auto& f : frames)
    for (double& v : f) v = u(rng);
  std::vector<Status> statuses(frames.size());
  const std::size_t allocations = test::allocations_during([&] {
    for (std::size_t f = 1; f < frames.size(); ++f) statuses[f] = estimator.push_cells(frames[f].data(), cells, static_cast<double>(f) / 60.0);
  });
  CHECK(allocations == 0);
  for (std::size_t f = 1; f < frames.size(); ++f) {
    CHECK(statuses[f] == Status::Solved);
    (void)reference.add(Eigen::Map<const Eigen::VectorXd>(frames[f].data(), cells), static_cast<double>(f) / 60.0);
  }
  REQUIRE(estimator.calibration());
  CHECK((estimator.calibration()->min() - reference.min()).cwiseAbs().maxCoeff() < 1e-6);  // the frames as a float dataset rounds them
  const double lowest = calibration::kMotionPercentiles[0] / 100.0;  // of uniform [1.5, 2.5]
  CHECK(estimator.calibration()->min()(0) == doctest::Approx(1.5 + lowest).epsilon(0.02));
  CHECK(estimator.calibration()->max()(0) == doctest::Approx(2.5 - lowest).epsilon(0.02));

  // A range the caller sets stays put; use_continuous_calibration() starts over from the prior.
  const sensor::CalibrationRange own(Eigen::VectorXd::Constant(cells, 1.4), Eigen::VectorXd::Constant(cells, 2.6), glove.cell_names());
  estimator.set_calibration(own);
  CHECK(estimator.calibration_source() == CalibrationSource::User);
  for (int f = 600; f < 700; ++f) (void)estimator.push_cells((next(), frame.data()), cells, f / 60.0);
  CHECK(estimator.calibration()->min()(0) == 1.4);
  estimator.use_continuous_calibration();
  CHECK(estimator.calibration_source() == CalibrationSource::Continuous);
  CHECK(estimator.calibration()->min()(0) == 1.0);

  EstimatorConfig off;
  off.continuous_calibration = false;
  GlovePoseEstimator waiting(model, off);
  CHECK(waiting.calibration_source() == CalibrationSource::None);
  CHECK(waiting.push_cells(frame.data(), cells, 0.0) == Status::Uncalibrated);
}
