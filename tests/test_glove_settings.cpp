// A glove description's own joint limits, frame rate and calibration settings (glove_description.hpp)
// reach everything that calibrates and normalises: the training samples, a new model's metadata,
// the import's flat check (test_recording_import.cpp) and the estimator. Expected values are
// computed here from the definitions (a sorted window's median, 2 (x - lo) / (hi - lo) - 1).
#include <glovepose/estimator.hpp>
#include <glovepose/grid/glove_description.hpp>
#include <glovepose/train/model_file.hpp>
#include <glovepose/train/samples.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

using namespace glovepose;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Two cells of the built-in glove's map, with the settings given.
grid::GloveDescription two_cell_glove(const grid::GloveSettings& settings) {
  const grid::GridMap paper = grid::GridMap::glauser2019();
  std::vector<grid::Slot> slots(paper.cell_slots().begin(), paper.cell_slots().begin() + 2);
  return grid::GloveDescription("two-cell", {"a", "b"}, grid::GridMap(slots, paper.dof_slots()), settings);
}

grid::GloveSettings own_settings() {
  grid::GloveSettings s;
  s.rate_hz = 20.0;
  s.calibration.median_seconds = 0.5;         // 10 frames at 20 Hz
  s.calibration.flat_relative_range = 0.001;  // a 0.5% range is not flat
  s.limits_degrees[hand::dof_from_name("index_base_flexion")] = grid::DofLimitsDegrees{-30.0, 110.0};
  return s;
}

// One subject's calibration run (40 frames) then 5 recording frames, at 20 Hz. Cell "a" moves
// between -1 and 3, cell "b" only 0.5% of its value (a resistive sensor on a DC offset), each with a
// little noise (a cell whose readings were noise alone would be named noise only, whatever its range).
io::Dataset twenty_hertz_session() {
  io::Dataset data(2, 0, "two-cell", 20.0);
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> noise(-0.01f, 0.01f), angle(-0.5f, 1.2f);
  for (int i = 0; i < 45; ++i) {
    data.cells.push_back(1.0f + 2.0f * static_cast<float>(std::sin(2.0 * kPi * i / 16.0)) + 5.0f * noise(rng));
    data.cells.push_back(100.25f - 0.25f * static_cast<float>(std::cos(2.0 * kPi * i / 20.0)) + 0.5f * noise(rng));
    for (std::size_t d = 0; d < hand::kDofCount; ++d) data.angles.push_back(angle(rng));
    data.timestamps.push_back(i / 20.0);
    data.subject.push_back(1);
    data.session.push_back(0);
    data.glove.push_back(0);
    data.donning.push_back(0);
    data.kind.push_back(i < 40 ? io::kKindCalibration : io::kKindRecording);
    data.outlier.push_back(0);
  }
  data.validate();
  return data;
}

// Min and max over the calibration frames of the median of each `window` consecutive frames.
std::pair<double, double> median_range(const io::Dataset& data, std::size_t cell, std::size_t window) {
  std::vector<double> values;
  for (std::size_t i = 0; i < data.frames(); ++i)
    if (data.kind[i] == io::kKindCalibration) values.push_back(data.cells[i * 2 + cell]);
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (std::size_t end = window; end <= values.size(); ++end) {
    std::vector<double> w(values.begin() + static_cast<long>(end - window), values.begin() + static_cast<long>(end));
    std::sort(w.begin(), w.end());
    const double median = window % 2 ? w[window / 2] : 0.5 * (w[window / 2 - 1] + w[window / 2]);
    lo = std::min(lo, median);
    hi = std::max(hi, median);
  }
  return {lo, hi};
}

}  // namespace

TEST_CASE("glove settings: training calibrates with the glove's median window (seconds x rate) and flat rule") {
  const io::Dataset data = twenty_hertz_session();
  const grid::GloveDescription own = two_cell_glove(own_settings());

  const auto described = train::onthefly_ranges(data, own.calibration());
  REQUIRE(described.size() == 1);
  const sensor::CalibrationRange& range = described.begin()->second;
  for (std::size_t c = 0; c < 2; ++c) {
    const auto [lo, hi] = median_range(data, c, 10);  // 0.5 s at 20 Hz
    CHECK(range.min()(static_cast<Eigen::Index>(c)) == doctest::Approx(lo).epsilon(1e-12));
    CHECK(range.max()(static_cast<Eigen::Index>(c)) == doctest::Approx(hi).epsilon(1e-12));
  }
  CHECK(range.flat_sensors().empty());  // 0.5% > 0.1%

  // The defaults: a third of a second (7 frames at 20 Hz) and the 1% rule, which zeroes "b".
  const auto plain = train::onthefly_ranges(data);
  REQUIRE(plain.size() == 1);
  const auto [lo7, hi7] = median_range(data, 0, 7);
  CHECK(plain.begin()->second.min()(0) == doctest::Approx(lo7).epsilon(1e-12));
  CHECK(plain.begin()->second.max()(0) == doctest::Approx(hi7).epsilon(1e-12));
  CHECK(plain.begin()->second.flat_sensors() == std::vector<std::string>{"cell_1"});

  // make_samples: the same, and Samples::zeroed reports the flat sensor only under the 1% rule.
  const hand::JointLimits limits = own.joint_limits();
  const train::Samples with_own =
      train::make_samples(data, train::FrameFilter{}, model::CalibrationMode::OnTheFly, nullptr, limits, 1, own.calibration());
  const train::Samples with_default = train::make_samples(data, train::FrameFilter{}, model::CalibrationMode::OnTheFly, nullptr, limits);
  REQUIRE(with_own.frames() == 5);
  bool b_moves = false;
  for (long f = 0; f < with_own.frames(); ++f) {
    b_moves = b_moves || with_own.inputs[static_cast<std::size_t>(f) * 2 + 1] != 0.0f;
    CHECK(with_default.inputs[static_cast<std::size_t>(f) * 2 + 1] == 0.0f);
  }
  CHECK(b_moves);

  // The training calibration (min-max over all kept frames) takes the flat rule too.
  CHECK(train::training_range(data, train::FrameFilter{}).flat_sensors().size() == 1);
  CHECK(train::training_range(data, train::FrameFilter{}, own.calibration()).flat_sensors().empty());
}

TEST_CASE("glove settings: a model for the glove records and normalises by the glove's joint limits") {
  const grid::GloveDescription own = two_cell_glove(own_settings());
  const std::size_t index = hand::dof_from_name("index_base_flexion");
  const model::ModelInfo info = train::make_model_info("linear", 0, own, model::CalibrationMode::OnTheFly, nullptr);
  const hand::JointLimits reference;
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    INFO(hand::kDofs[d].name);
    CHECK(info.joint_limits_min[d] == (d == index ? -30.0 * kPi / 180.0 : reference.min()[d]));
    CHECK(info.joint_limits_max[d] == (d == index ? 110.0 * kPi / 180.0 : reference.max()[d]));
  }
  // Targets: 2 (angle - min) / (max - min) - 1 with the glove's limits.
  const io::Dataset data = twenty_hertz_session();
  const train::Samples s =
      train::make_samples(data, train::FrameFilter{}, model::CalibrationMode::OnTheFly, nullptr, info.joint_limits(), 1, own.calibration());
  for (long f = 0; f < s.frames(); ++f) {
    const double angle = data.angles[static_cast<std::size_t>(s.source[static_cast<std::size_t>(f)]) * hand::kDofCount + index];
    const double lo = -30.0 * kPi / 180.0, hi = 110.0 * kPi / 180.0;
    CHECK(s.targets[static_cast<std::size_t>(f) * hand::kDofCount + index] ==
          doctest::Approx(2.0 * (angle - lo) / (hi - lo) - 1.0).epsilon(1e-6));
  }
  // The model file carries the description (with its settings) and the limits.
  nn::WeightFile file;
  info.to(file);
  const model::ModelInfo back = model::ModelInfo::from(file);
  CHECK(back.joint_limits_max[index] == 110.0 * kPi / 180.0);
  CHECK(back.glove_description == own);
}

TEST_CASE("glove settings: the estimator takes the glove's median window and flat rule unless told otherwise") {
  const grid::GloveDescription own = two_cell_glove(own_settings());
  const std::string path = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/two_cell_linear.safetensors";
  const model::ModelInfo info = train::make_model_info("fcn", 16, own, model::CalibrationMode::OnTheFly, nullptr);
  train::TrainableFcn fcn(2, 16, 1);
  fcn.initialize(3);
  train::save_model(path, info, fcn.parameters().to_tensors());
  const auto model = PoseModel::load(path);
  REQUIRE(model->glove() == own);
  CHECK(model->joint_limits().max()[hand::dof_from_name("index_base_flexion")] == 110.0 * kPi / 180.0);

  {
    GlovePoseEstimator estimator(model);                        // defaults: the glove's
    CHECK(estimator.config().calibration_median_window == 10);  // 0.5 s at the glove's 20 Hz (slower than the 60 Hz sample period)
    CHECK(estimator.config().calibration.min_relative_range == 0.001);
    CHECK(estimator.config().calibration_sample_period == 1.0 / 20.0);  // frames taken at the glove's rate
    // A calibration of cells where "b" moves 0.5% of its value: not flat by the glove's rule.
    estimator.start_calibration();
    const io::Dataset data = twenty_hertz_session();
    // Sized from the data: a count GCC 12 sees as the constant 2 trips -Warray-bounds in Eigen's
    // AVX-512 copy loop, a branch that only runs for 8 or more values.
    const int count = static_cast<int>(data.cell_count);
    std::vector<double> cells(data.cell_count);
    for (std::size_t i = 0; i < 40; ++i) {
      for (std::size_t c = 0; c < data.cell_count; ++c) cells[c] = data.cells[i * data.cell_count + c];
      (void)estimator.push_cells(cells.data(), count, data.timestamps[i]);
    }
    CHECK(estimator.calibration_progress().frames_needed == 10);
    CHECK(estimator.calibration_progress().frames == 40);
    const sensor::CalibrationRange& range = estimator.finish_calibration();
    CHECK(range.flat_sensors().empty());
    const auto [lo, hi] = median_range(data, 1, 10);
    CHECK(range.min()(1) == doctest::Approx(lo).epsilon(1e-6));
    CHECK(range.max()(1) == doctest::Approx(hi).epsilon(1e-6));
  }
  {
    EstimatorConfig config;
    config.calibration_median_window = 5;
    config.calibration.min_relative_range = 0.01;
    GlovePoseEstimator estimator(model, config);  // given values are kept
    CHECK(estimator.config().calibration_median_window == 5);
    CHECK(estimator.config().calibration.min_relative_range == 0.01);
  }
  {
    EstimatorConfig config;
    config.calibration_sample_period = 0.1;  // slower than the glove: 0.5 s is 5 frames taken
    CHECK(GlovePoseEstimator(model, config).config().calibration_median_window == 5);
  }
  // The built-in glove: 20 frames of the 60 Hz sample period, the 1% rule.
  const auto builtin = PoseModel::load(std::string(GLOVEPOSE_SOURCE_DIR) + "/models/glovepose_fcn512.safetensors");
  GlovePoseEstimator estimator(builtin);
  CHECK(estimator.config().calibration_median_window == 20);
  CHECK(estimator.config().calibration.min_relative_range == 0.01);
}

TEST_CASE("glove settings: the description's noise rule reaches training and the estimator") {
  // Cell "b" reads noise alone around 100 (a dead channel): its range is several percent of its
  // value, so the flat rule keeps it, and the noise rule (range below 12 x its noise SD) names it.
  io::Dataset data = twenty_hertz_session();
  std::mt19937 rng(9);
  std::normal_distribution<float> noise(0.0f, 2.0f);
  for (std::size_t i = 0; i < data.frames(); ++i) data.cells[i * 2 + 1] = 100.0f + noise(rng);
  grid::GloveSettings off = own_settings();
  off.calibration.min_range_to_noise = 0.0;  // the rule off
  const grid::GloveDescription dead = two_cell_glove(own_settings()), ruled_off = two_cell_glove(off);
  CHECK(dead.calibration().min_range_to_noise == sensor::CalibrationConfig{}.min_range_to_noise);
  CHECK(ruled_off.calibration().config().min_range_to_noise == 0.0);

  const auto by_default = train::onthefly_ranges(data, dead.calibration());
  const auto without = train::onthefly_ranges(data, ruled_off.calibration());
  REQUIRE(by_default.size() == 1);
  REQUIRE(without.size() == 1);
  CHECK(by_default.begin()->second.flatness(0) == sensor::Flatness::Moving);
  CHECK(by_default.begin()->second.flatness(1) == sensor::Flatness::NoiseOnly);
  CHECK(without.begin()->second.flat_sensors().empty());

  // The estimator of a model for each glove takes the glove's rule; a given one is kept.
  const auto finished = [&](const grid::GloveDescription& glove, const EstimatorConfig& config) {
    const std::string path = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/noise_rule_" + glove.id() + ".safetensors";
    const model::ModelInfo info = train::make_model_info("fcn", 16, glove, model::CalibrationMode::OnTheFly, nullptr);
    train::TrainableFcn fcn(2, 16, 1);
    fcn.initialize(3);
    train::save_model(path, info, fcn.parameters().to_tensors());
    GlovePoseEstimator estimator(PoseModel::load(path), config);
    estimator.start_calibration();
    const int count = static_cast<int>(data.cell_count);
    std::vector<double> cells(data.cell_count);
    for (std::size_t i = 0; i < 40; ++i) {
      for (std::size_t c = 0; c < data.cell_count; ++c) cells[c] = data.cells[i * data.cell_count + c];
      (void)estimator.push_cells(cells.data(), count, data.timestamps[i]);
    }
    return std::make_pair(estimator.config().calibration.min_range_to_noise, estimator.finish_calibration().flatness(1));
  };
  CHECK(finished(dead, EstimatorConfig{}) == std::make_pair(12.0, sensor::Flatness::NoiseOnly));
  grid::GloveSettings renamed = off;  // another id: another model file
  const grid::GloveDescription off_glove("two-cell-off", {"a", "b"}, ruled_off.map(), renamed);
  CHECK(finished(off_glove, EstimatorConfig{}) == std::make_pair(0.0, sensor::Flatness::Moving));
  EstimatorConfig given;
  given.calibration.min_range_to_noise = 12.0;
  CHECK(finished(off_glove, given) == std::make_pair(12.0, sensor::Flatness::NoiseOnly));
}
