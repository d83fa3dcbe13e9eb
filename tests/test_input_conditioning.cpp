// Input conditioning (sensor/input_conditioning.hpp, a glove description's demean_seconds): the
// rolling demean against a mean computed here over each input's last readings; the description's
// key read, written and refused; a dataset conditioned for training equal, bit for bit, to the
// cells the estimator computes from the same readings; and on a simulated device whose channels
// drift, the error on a session no model saw with and without it.
#include <glovepose/estimator.hpp>
#include <glovepose/sensor/input_conditioning.hpp>
#include <glovepose/sim/wearable_device.hpp>
#include <glovepose/train/evaluate.hpp>
#include <glovepose/train/model_file.hpp>
#include <glovepose/train/training_setup.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace glovepose::input_conditioning_test {
namespace {

constexpr std::size_t kChannels = sim::kWearableChannels;
using sim::drifting_wearable_sessions;

// The example device of weights_format.md with every channel demeaned over `seconds` (0: none).
grid::GloveDescription device(double seconds) {
  const grid::GloveDescription example = grid::GloveDescription::read(std::string(GLOVEPOSE_SOURCE_DIR) + "/examples/wearable_device.glove.json");
  grid::GloveSettings settings = example.settings();
  settings.demean_seconds.assign(seconds > 0.0 ? example.cell_count() : 0, seconds);
  return grid::GloveDescription(example.id(), example.cell_names(), example.map(), settings);
}

}  // namespace

TEST_CASE("input conditioning: each input less the mean of its last readings, as computed here") {
  const std::vector<int> windows{0, 2, 5, 30};
  sensor::InputConditioner conditioner(windows);
  CHECK(conditioner.active());
  std::mt19937 rng(3);
  std::normal_distribution<double> reading(10.0, 2.0);
  std::vector<std::vector<double>> seen(windows.size());
  for (int f = 0; f < 200; ++f) {
    if (f == 120) {  // a new stream: the means start over
      conditioner.reset();
      for (auto& s : seen) s.clear();
    }
    double in[4], out[4];
    for (double& x : in) x = reading(rng);
    conditioner.apply(in, out);
    for (std::size_t c = 0; c < windows.size(); ++c) {
      seen[c].push_back(in[c]);
      if (windows[c] == 0) {
        CHECK(out[c] == in[c]);
        continue;
      }
      const std::size_t n = std::min(seen[c].size(), static_cast<std::size_t>(windows[c]));
      double sum = 0.0;
      for (std::size_t k = seen[c].size() - n; k < seen[c].size(); ++k) sum += seen[c][k];
      CHECK(out[c] == doctest::Approx(in[c] - sum / static_cast<double>(n)).epsilon(1e-12));
    }
  }
  CHECK_FALSE(sensor::InputConditioner().active());
  CHECK_FALSE(sensor::InputConditioner(std::vector<int>{0, 0}).active());
  CHECK_THROWS_WITH_AS(sensor::InputConditioner(std::vector<int>{3, 1}), doctest::Contains("input 1 has a window of 1 frames"), Error);
}

TEST_CASE("input conditioning: a glove description's demean_seconds, written, read and refused") {
  const grid::GloveDescription conditioned = device(10.0);
  CHECK(conditioned.demean_frames() == std::vector<int>(kChannels, 300));
  CHECK(grid::GloveDescription::from_json(conditioned.to_json()) == conditioned);
  CHECK(conditioned.to_json().find("{\"name\": \"channel_00\", \"extra\": true, \"demean_seconds\": 10}") != std::string::npos);
  CHECK(conditioned != device(0.0));
  CHECK(device(0.0).demean_frames().empty());
  const std::string text = conditioned.to_json();
  const auto refused = [](const std::string& json, const std::string& message) {
    CHECK_THROWS_WITH_AS(grid::GloveDescription::from_json(json), doctest::Contains(message.c_str()), Error);
  };
  std::string no_rate = text;
  no_rate.erase(no_rate.find(",\n  \"rate_hz\""), std::string(",\n  \"rate_hz\": 30").size());
  refused(no_rate, "cells[0] ('channel_00') has 'demean_seconds' but the description has no 'rate_hz'");
  std::string zero = text;
  zero.replace(zero.find("\"demean_seconds\": 10"), 20, "\"demean_seconds\": 0");
  refused(zero, "cells[0] ('channel_00'): 'demean_seconds' is 0, expected a time > 0 s");
  // Windows the estimator would keep gigabytes for: 16 inputs x 600 s at 10 kHz.
  std::string huge = text;
  huge.replace(huge.find("\"rate_hz\": 30"), 13, "\"rate_hz\": 10000");
  for (std::size_t at = huge.find("\"demean_seconds\": 10"); at != std::string::npos; at = huge.find("\"demean_seconds\": 10", at))
    huge.replace(at, 20, "\"demean_seconds\": 600");
  refused(huge, "keep 96000000 readings in all, expected at most 16777216");
}

TEST_CASE("input conditioning: the dataset training reads and the estimator's cells are the same, bit for bit") {
  const grid::GloveDescription glove = device(2.0);
  io::Dataset data = drifting_wearable_sessions(0.2, 5, 0.5);
  std::optional<io::Dataset> storage;
  const io::Dataset& trained_on = train::conditioned_for(data, glove, storage);
  REQUIRE(&trained_on != &data);
  CHECK(trained_on.metadata.at("conditioning") == "demean frames 60,60,60,60,60,60,60,60,60,60,60,60,60,60,60,60");
  CHECK(&train::conditioned_for(trained_on, glove, storage) == &trained_on);  // not twice
  std::optional<io::Dataset> other;
  CHECK_THROWS_WITH_AS(train::conditioned_for(trained_on, device(5.0), other), doctest::Contains("conditioned as 'demean frames 60"), Error);

  // A network for the device (untrained: only its inputs matter here) and an estimator of it.
  const model::ModelInfo info = train::make_model_info("fcn", 8, glove, model::CalibrationMode::OnTheFly, nullptr);
  const std::unique_ptr<train::TrainableNetwork> net = train::make_network(info, glove, 1);
  net->initialize(1);
  const std::string path = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/conditioned_device.safetensors";
  train::save_model(path, info, net->parameters().to_tensors());
  GlovePoseEstimator estimator(PoseModel::load(path));
  estimator.set_calibration(sensor::CalibrationRange(Eigen::VectorXd::Constant(kChannels, -1.0), Eigen::VectorXd::Constant(kChannels, 1.0),
                                                     glove.cell_names()));
  std::size_t compared = 0;
  for (std::size_t i = 0; i < data.frames(); ++i) {
    if (i > 0 && data.session[i] != data.session[i - 1]) estimator.reset();  // a new session: the glove put on again
    double frame[kChannels];
    for (std::size_t c = 0; c < kChannels; ++c) frame[c] = data.cells[i * kChannels + c];
    REQUIRE(estimator.push_cells(frame, static_cast<int>(kChannels), data.timestamps[i]) == Status::Solved);
    for (std::size_t c = 0; c < kChannels; ++c) {
      const double expected = trained_on.cells[i * kChannels + c];
      if (estimator.cells()[c] != expected) FAIL_CHECK("frame " << i << ", channel " << c << ": " << estimator.cells()[c] << " vs " << expected);
      ++compared;
    }
  }
  CHECK(compared == data.frames() * kChannels);
}

TEST_CASE("input conditioning: on a device whose channels drift, demeaned inputs cut the error on a session no model saw") {
  const io::Dataset data = drifting_wearable_sessions(0.05, 7, 3.0);
  double error[2] = {0.0, 0.0};
  for (const bool demean : {false, true}) {
    const grid::GloveDescription glove = device(demean ? 10.0 : 0.0);
    const train::TrainingSetup setup = train::prepare_training(data, {}, 1, "linear", 0, glove, model::CalibrationMode::None);
    const train::LinearModelFit fit = train::fit_linear_model(setup.samples, 0.1, glove.joint_limits());  // session 1 held out
    REQUIRE(fit.validation.find("1 held-out run of 2") == 0);
    error[demean] = fit.validation_error_deg;
    // eval on that session agrees: the model carries the glove, and with it the conditioning.
    const std::string path = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/drift_linear_" + std::to_string(demean) + ".safetensors";
    train::save_model(path, setup.info, train::linear_tensors(fit.map));
    train::TrainedModel model = train::load_model(path);
    CHECK(model.glove == glove);
    train::EvaluationOptions options;
    options.threads = 1;
    options.filter.sessions = {1};
    CHECK(std::abs(train::evaluate(model, data, options).vs_labels.overall.mean_deg - fit.validation_error_deg) <= 1e-6);
  }
  MESSAGE("unseen session, linear map: " << error[0] << " deg as read, " << error[1] << " deg demeaned over 10 s");
  CHECK(error[1] <= 0.8 * error[0]);
}

}  // namespace glovepose::input_conditioning_test
