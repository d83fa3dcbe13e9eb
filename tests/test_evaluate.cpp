// train::evaluate (train/evaluate.hpp), what `glovepose eval` and glovepose.evaluate() print: on a
// dataset whose predictions are known in closed form (a linear model reading a delayed copy of the
// labels), the angle errors, the lag (every frame and every K-th) and the per-frame predictions
// against the same figures computed here from the formula; the weight storages against the
// real-time network's own batch path; the zeroed-sensor report's typed run and glove names.
#include <glovepose/train/evaluate.hpp>
#include <glovepose/train/training_setup.hpp>
#include <glovepose/io/json.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/pose_model.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

// A namespace of its own: the unity build puts this file beside others with their own kPi, kRate.
namespace glovepose::evaluate_test {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRate = 60.0;
constexpr int kDelay = 3;      // frames the model's prediction trails the labels by
constexpr double kTruthShift = 0.02;  // radians the true angles sit above the labels

// Label of DoF d at frame f of run `run`: a sine within the joint limits (normalised 0.6 sin).
double normalized_label(int run, long f, std::size_t d) {
  return 0.6 * std::sin(2.0 * kPi * static_cast<double>(f) / (40.0 + 3.0 * static_cast<double>(d)) + 0.7 * static_cast<double>(d) + run);
}

double label(const hand::JointLimits& limits, int run, long f, std::size_t d) {
  return limits.min()[d] + (normalized_label(run, f, d) + 1.0) * 0.5 * (limits.max()[d] - limits.min()[d]);
}

constexpr long kPerRun = 240;  // frames of each of the two people

// Two people, kPerRun frames each, of the built-in glove; the cells hold the normalised labels
// kDelay frames back (the rest 0), no calibration sequence.
io::Dataset closed_form_data() {
  const grid::GloveDescription glove = grid::GloveDescription::glauser2019();
  const hand::JointLimits limits = glove.joint_limits();
  const std::size_t cells = static_cast<std::size_t>(glove.cell_count());
  const long per_run = kPerRun;
  io::Dataset data(cells, 0, glove.id(), kRate);
  for (int run = 0; run < 2; ++run)
    for (long f = 0; f < per_run; ++f) {
      for (std::size_t c = 0; c < cells; ++c)
        data.cells.push_back(c < hand::kDofCount ? static_cast<float>(normalized_label(run, f - kDelay, c)) : 0.0f);
      for (std::size_t d = 0; d < hand::kDofCount; ++d) {
        data.angles.push_back(static_cast<float>(label(limits, run, f, d)));
        data.true_angles.push_back(static_cast<float>(label(limits, run, f, d) + kTruthShift));
      }
      data.timestamps.push_back(static_cast<double>(f) / kRate);
      data.subject.push_back(run);
      data.session.push_back(0);
      data.glove.push_back(0);
      data.donning.push_back(0);
      data.kind.push_back(io::kKindRecording);
      data.outlier.push_back(0);
    }
  return data;
}

TEST_CASE("evaluate: errors, lag and predictions of a model known in closed form") {
  const grid::GloveDescription glove = grid::GloveDescription::glauser2019();
  const hand::JointLimits limits = glove.joint_limits();
  const std::size_t cells = static_cast<std::size_t>(glove.cell_count());
  const long per_run = kPerRun;
  const io::Dataset data = closed_form_data();
  // The model: output d = cell d (d < 25), no calibration of the inputs.
  std::vector<float> weight(hand::kDofCount * cells, 0.0f), bias(hand::kDofCount, 0.0f);
  for (std::size_t d = 0; d < hand::kDofCount; ++d) weight[d * cells + d] = 1.0f;
  const nn::LinearMap map(static_cast<int>(cells), train::kTargets, weight, bias);
  const std::string path = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/evaluate_linear.safetensors";
  train::save_model(path, train::make_model_info("linear", 0, glove, model::CalibrationMode::None, nullptr), train::linear_tensors(map));
  train::TrainedModel model = train::load_model(path);

  train::EvaluationOptions options;
  options.threads = 1;
  const train::EvaluationResult r = train::evaluate(model, data, options);
  REQUIRE(r.frames() == 2 * per_run);
  CHECK(r.calibration == "none");
  CHECK(!r.rows_replayed);
  CHECK(r.zeroed.empty());
  // Mean absolute error in degrees, against the labels and the truth, from the formula.
  const double degrees = core::kDegreesPerRadian;
  double sum = 0.0, truth_sum = 0.0, max_error = 0.0;
  for (int run = 0; run < 2; ++run)
    for (long f = 0; f < per_run; ++f)
      for (std::size_t d = 0; d < hand::kDofCount; ++d) {
        const double predicted = label(limits, run, f - kDelay, d), labelled = label(limits, run, f, d);
        const std::size_t i = (static_cast<std::size_t>(run * per_run + f)) * hand::kDofCount + d;
        REQUIRE(r.predicted[i] == doctest::Approx(predicted).epsilon(1e-5));
        CHECK(r.labels[i] == static_cast<float>(labelled));
        sum += std::abs(predicted - labelled);
        truth_sum += std::abs(predicted - labelled - kTruthShift);
        max_error = std::max(max_error, std::abs(predicted - labelled));
      }
  const double angles = 2.0 * per_run * hand::kDofCount;
  CHECK(r.vs_labels.overall.mean_deg == doctest::Approx(sum / angles * degrees).epsilon(1e-5));
  CHECK(r.vs_labels.overall.max_deg == doctest::Approx(max_error * degrees).epsilon(1e-4));
  REQUIRE(r.vs_truth.has_value());
  CHECK(r.vs_truth->overall.mean_deg == doctest::Approx(truth_sum / angles * degrees).epsilon(1e-5));
  CHECK(r.vs_truth->overall.mean_deg != doctest::Approx(r.vs_labels.overall.mean_deg).epsilon(1e-3));
  // The prediction trails by kDelay frames: the lag is that many frame periods (a constant offset
  // against the truth changes nothing).
  CHECK(r.lag_ms == doctest::Approx(kDelay * 1000.0 / kRate).epsilon(0.02));
  CHECK(r.truth_lag_ms == doctest::Approx(r.lag_ms).epsilon(1e-9));
  REQUIRE(r.fingertips.has_value());
  CHECK(r.fingertips->frames == static_cast<std::size_t>(2 * per_run));
  CHECK(r.fingertips_vs_truth);
  CHECK(r.hands == "the reference hand");

  // The JSON carries the same figures.
  const io::json::Value json = io::json::parse(train::to_json(r));
  CHECK(json.at("mean_deg").get<double>() == doctest::Approx(r.vs_labels.overall.mean_deg).epsilon(1e-12));
  CHECK(json.at("vs_truth").at("mean_deg").get<double>() == doctest::Approx(r.vs_truth->overall.mean_deg).epsilon(1e-12));
  CHECK(json.at("lag_ms").get<double>() == doctest::Approx(r.lag_ms).epsilon(1e-4));
  CHECK(json.at("calibration") == "none");
  CHECK(json.at("mean_window").is_null());
  CHECK(json.at("contact").is_null());
  CHECK(json.at("frames").get<long>() == 2 * per_run);

  // Every K-th frame (eval --stride K): the same lag in recording frames, measured between frames K
  // apart (it was refused: "no neighbouring frames"); the coarser shifts cost accuracy, not the unit.
  for (const int stride : {2, 7}) {
    CAPTURE(stride);
    options.stride = stride;
    const train::EvaluationResult strided = train::evaluate(model, data, options);
    CHECK(strided.frames() == 2 * ((per_run + stride - 1) / stride));
    CHECK(strided.lag_ms == doctest::Approx(kDelay * 1000.0 / kRate).epsilon(stride == 2 ? 0.05 : 0.25));
  }
  options.stride = 1;
  // A linear map has no real-time network to hold 16-bit weights.
  options.weights = nn::WeightStorage::F16;
  CHECK_THROWS_WITH_AS(train::evaluate(model, data, options), doctest::Contains("weights F16: the model is linear"), Error);
  options.weights = nn::WeightStorage::F32;

  // A selection scores only its frames: the second person alone.
  options.filter.subjects = {1};
  const train::EvaluationResult one = train::evaluate(model, data, options);
  CHECK(one.frames() == per_run);
  for (std::int64_t source : one.source) CHECK(data.subject[static_cast<std::size_t>(source)] == 1);
  // A calibration the data cannot give is refused by name.
  options.calibration = "sideways";
  CHECK_THROWS_WITH_AS(train::evaluate(model, data, options), doctest::Contains("expected none, training, onthefly, guided or continuous"), Error);
  options.calibration = "onthefly";
  CHECK_THROWS_WITH_AS(train::evaluate(model, data, options), doctest::Contains("has no calibration sequence (kind 1 frames), expected one for on-the-fly calibration: import the session's "
                                         "calibration take with it (glovepose import --calibration FILE, the same subject and session), or choose "
                                         "--calibration-mode training"), Error);
}

TEST_CASE("evaluate: weights held as the real-time network holds them, for both architectures") {
  const io::Dataset data = closed_form_data();  // cells in [-0.6, 0.6], read uncalibrated
  for (const char* name : {"glovepose_fcn512", "glovepose_unet64"}) {
    CAPTURE(name);
    const std::string path = std::string(GLOVEPOSE_SOURCE_DIR) + "/models/" + name + ".safetensors";
    train::TrainedModel model = train::load_model(path);
    train::EvaluationOptions options;
    options.threads = 1;
    options.calibration = "none";
    const train::EvaluationResult f32 = train::evaluate(model, data, options);
    CHECK(f32.weights == nn::WeightStorage::F32);
    const train::Samples samples = train::samples_for_model(model, data, options.filter, 1, "none").first;
    for (const nn::WeightStorage storage : {nn::WeightStorage::F16, nn::WeightStorage::BF16, nn::WeightStorage::Fixed16}) {
      CAPTURE(nn::storage_name(storage));
      options.weights = storage;
      const train::EvaluationResult r = train::evaluate(model, data, options);
      CHECK(r.weights == storage);
      // The reference: the model as PoseModel loads it with that storage, its batch path on the same cells.
      PoseModelOptions load;
      load.storage = storage;
      const auto runtime = PoseModel::load(path, load);
      const std::vector<hand::Angles> normalized =
          runtime->network().normalized_dofs_batch(runtime->glove().map(), samples.inputs.data(), samples.cells, samples.frames());
      REQUIRE(r.predicted.size() == normalized.size() * hand::kDofCount);
      double worst = 0.0, moved = 0.0;
      for (std::size_t f = 0; f < normalized.size(); ++f) {
        // Held within the joint limits, as the estimator holds a pose (the FCN overshoots them here).
        const hand::Angles angles = runtime->joint_limits().clamp(runtime->joint_limits().denormalize(runtime->model_outputs(normalized[f])));
        for (std::size_t d = 0; d < hand::kDofCount; ++d) {
          worst = std::max(worst, std::abs(r.predicted[f * hand::kDofCount + d] - angles[d]));
          moved =
              std::max(moved, std::abs(static_cast<double>(r.predicted[f * hand::kDofCount + d] - f32.predicted[f * hand::kDofCount + d])));
        }
      }
      CHECK(worst < 1e-6);  // radians: the same kernels on the same weights (float results)
      CHECK(moved > 0.0);   // the storage is in use: not the F32 predictions
      // 16-bit weights move the mean error by rounding only (BF16, 8 mantissa bits, the most).
      CHECK(std::abs(r.vs_labels.overall.mean_deg - f32.vs_labels.overall.mean_deg) < 0.2);
    }
    options.weights = nn::WeightStorage::Fixed16;
    CHECK(io::json::parse(train::to_json(train::evaluate(model, data, options))).at("weights") == "fixed16");
    CHECK(io::json::parse(train::to_json(f32)).at("weights") == "f32");
  }
}

TEST_CASE("evaluate: zeroed sensors name their run's fields and the glove's cells") {
  // A glove whose cells have names of their own (the built-in glove's are "cell_<i>").
  const grid::GloveDescription builtin = grid::GloveDescription::glauser2019();
  std::vector<std::string> names;
  for (std::size_t c = 0; c < builtin.cell_names().size(); ++c) names.push_back("strip" + std::to_string(c) + "_x");
  const grid::GloveDescription glove("named-44", names, builtin.map());
  io::Dataset data(44, 0, glove.id(), kRate);
  data.subject = {7};
  data.glove = {3};
  data.session = {12};
  train::Samples samples;
  samples.zeroed[train::run_key(data, 0)] = {"cell_5", "cell_43"};
  samples.zeroed[-1] = {"cell_0"};
  const std::vector<train::ZeroedSensors> zeroed = train::zeroed_sensors(samples, glove);
  REQUIRE(zeroed.size() == 2);
  CHECK(!zeroed[0].run.has_value());  // -1: the training range comes first
  CHECK(zeroed[0].sensors == std::vector<std::string>{glove.cell_names()[0]});
  REQUIRE(zeroed[1].run.has_value());
  CHECK(zeroed[1].run->subject == 7);
  CHECK(zeroed[1].run->glove == 3);
  CHECK(zeroed[1].run->session == 12);
  CHECK(zeroed[1].sensors == std::vector<std::string>{glove.cell_names()[5], glove.cell_names()[43]});
  CHECK(zeroed[1].text() == "calibration of subject 7, glove 3, session 12: 2 flat sensors read 0: " + glove.cell_names()[5] + ", " +
                                glove.cell_names()[43]);
  CHECK(zeroed[1].sensors.front() == "strip5_x");  // the glove's own names, not the samples' positions
}

// The fitted linear map written as a model file `name`, read back and evaluated on subject 1, as
// `glovepose train` and `eval` would.
train::EvaluationResult evaluate_saved(const model::ModelInfo& info, const train::LinearModelFit& fit, const io::Dataset& data,
                                       const std::string& name) {
  const std::string path = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/" + name + ".safetensors";
  train::save_model(path, info, train::linear_tensors(fit.map));
  train::TrainedModel model = train::load_model(path);
  train::EvaluationOptions options;
  options.threads = 1;
  options.filter.subjects = {1};
  return train::evaluate(model, data, options);
}

TEST_CASE("evaluate: a linear model fitted on one person keeps the other's angles within the joint limits, and counts those it clamped") {
  const grid::GloveDescription glove = grid::GloveDescription::glauser2019();
  const hand::JointLimits limits = glove.joint_limits();
  io::Dataset data = closed_form_data();
  const std::size_t cells = data.cell_count;
  // The second person's cells swing three times as far: the map fitted on the first extrapolates.
  for (std::size_t i = static_cast<std::size_t>(kPerRun) * cells; i < data.cells.size(); ++i) data.cells[i] *= 3.0f;
  train::FrameFilter first;
  first.subjects = {0};
  const train::TrainingSetup setup = train::prepare_training(data, first, 1, "linear", 0, glove, model::CalibrationMode::None);
  const train::LinearModelFit fit = train::fit_linear_model(setup.samples, 0.1, limits);
  const train::EvaluationResult r = evaluate_saved(setup.info, fit, data, "evaluate_linear_clamped");
  REQUIRE(r.frames() == kPerRun);
  // What the map gives unclamped, computed here from its weights; then clamped into [-1, 1].
  std::size_t outside = 0;
  std::vector<float> raw(hand::kDofCount);
  for (long f = 0; f < kPerRun; ++f) {
    const float* x = data.cells.data() + static_cast<std::size_t>(kPerRun + f) * cells;
    REQUIRE(fit.map.predict(x, raw.data()) == Status::Ok);
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const double v = raw[d];
      outside += v > 1.0 || v < -1.0;
      const double kept = std::min(1.0, std::max(-1.0, v));
      const double expected = limits.min()[d] + 0.5 * (kept + 1.0) * (limits.max()[d] - limits.min()[d]);
      const float predicted = r.predicted[static_cast<std::size_t>(f) * hand::kDofCount + d];
      CHECK(predicted >= static_cast<float>(limits.min()[d]) - 1e-6f);
      CHECK(predicted <= static_cast<float>(limits.max()[d]) + 1e-6f);
      CHECK(predicted == doctest::Approx(expected).epsilon(1e-6));
    }
  }
  CHECK(outside > 1000);  // the case this guards: 0.6 x 3 reaches 1.8
  CHECK(r.outside_limits == outside);
  CHECK(io::json::parse(train::to_json(r)).at("outside_limits").get<long>() == static_cast<long>(outside));
  CHECK(train::format_text(r).find("Outside the joint limits: " + std::to_string(outside) + " of " +
                                   std::to_string(kPerRun * static_cast<long>(hand::kDofCount))) != std::string::npos);
}

TEST_CASE("evaluate: a network's angles beyond the joint limits are held at them, by eval and the estimator alike") {
  // An FCN whose output biases are +-3: every normalised output lies far outside [-1, 1] (a
  // network's last layer is linear). Eval and the real-time estimator give the limits exactly.
  const grid::GloveDescription glove = grid::GloveDescription::glauser2019();
  const hand::JointLimits limits = glove.joint_limits();
  const io::Dataset data = closed_form_data();
  const train::TrainingSetup setup =
      train::prepare_training(data, train::FrameFilter{}, 1, "fcn", 8, glove, model::CalibrationMode::Training);
  const std::unique_ptr<train::TrainableNetwork> net = train::make_network(setup.info, glove, 64);
  net->initialize(3);
  const auto high = [](std::size_t d) { return d % 2 == 0; };  // even DoFs above their maximum, odd below their minimum
  bool found = false;
  for (train::Parameter& p : net->parameters().all())
    if (p.shape == std::vector<std::int64_t>{static_cast<std::int64_t>(hand::kDofCount)}) {
      for (std::size_t d = 0; d < hand::kDofCount; ++d) p.value[d] = high(d) ? 3.0f : -3.0f;
      found = true;
    }
  REQUIRE(found);
  const std::string path = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/evaluate_fcn_held.safetensors";
  train::save_model(path, setup.info, net->parameters().to_tensors());

  train::TrainedModel model = train::load_model(path);
  train::EvaluationOptions options;
  options.threads = 1;
  const train::EvaluationResult r = train::evaluate(model, data, options);
  REQUIRE(r.frames() == 2 * kPerRun);
  CHECK(r.outside_limits == r.predicted.size());
  for (std::size_t i = 0; i < r.predicted.size(); ++i) {
    const std::size_t d = i % hand::kDofCount;
    CHECK(r.predicted[i] == doctest::Approx(high(d) ? limits.max()[d] : limits.min()[d]).epsilon(1e-6));
  }

  GlovePoseEstimator estimator(PoseModel::load(path));
  estimator.use_training_calibration();
  std::vector<double> cells(data.cells.begin(), data.cells.begin() + static_cast<long>(data.cell_count));
  REQUIRE(estimator.push_cells(cells.data(), static_cast<int>(cells.size()), 0.0) == Status::Solved);
  for (std::size_t d = 0; d < hand::kDofCount; ++d)
    CHECK(estimator.pose().angles[d] == doctest::Approx(high(d) ? limits.max()[d] : limits.min()[d]).epsilon(1e-12));
}

TEST_CASE("evaluate: train validates on a held-out run when there are two, with the error eval gives on that run") {
  const grid::GloveDescription glove = grid::GloveDescription::glauser2019();
  const hand::JointLimits limits = glove.joint_limits();
  io::Dataset data = closed_form_data();
  for (float& c : data.cells) c += 0.01f * std::sin(static_cast<float>(&c - data.cells.data()));  // not exactly linear
  const train::TrainingSetup setup = train::prepare_training(data, {}, 1, "linear", 0, glove, model::CalibrationMode::None);

  const train::ValidationParts parts = train::split_validation(setup.samples, 0.1);
  CHECK(parts.training.frames() == kPerRun);
  CHECK(parts.validation.frames() == kPerRun);
  for (std::int64_t source : parts.validation.source) CHECK(data.subject[static_cast<std::size_t>(source)] == 1);
  CHECK(parts.description.find("1 held-out run of 2") != std::string::npos);
  CHECK(parts.description.find("subject 1, glove 0, session 0") != std::string::npos);

  const train::LinearModelFit fit = train::fit_linear_model(setup.samples, 0.1, limits);
  CHECK(fit.training_frames == kPerRun);
  CHECK(fit.validation == parts.description);
  const train::EvaluationResult held = evaluate_saved(setup.info, fit, data, "evaluate_linear_held_out");
  CHECK(std::abs(held.vs_labels.overall.mean_deg - fit.validation_error_deg) <= 1e-6);

  // The last part of every run instead: 24 frames of each, the rest trains.
  const train::ValidationParts frames = train::split_validation(setup.samples, 0.1, train::ValidationSplit::Frames);
  CHECK(frames.validation.frames() == 2 * 24);
  CHECK(frames.description.find("the last 10% of the frames of each of 2 runs") != std::string::npos);
  // One run: Auto falls back to frames; Runs is refused, naming the way out.
  train::FrameFilter one;
  one.subjects = {0};
  const train::TrainingSetup single = train::prepare_training(data, one, 1, "linear", 0, glove, model::CalibrationMode::None);
  CHECK(train::split_validation(single.samples, 0.1).validation.frames() == 24);
  CHECK_THROWS_WITH_AS(train::split_validation(single.samples, 0.1, train::ValidationSplit::Runs),
                       doctest::Contains("expected two or more (each take its own session)"), Error);
  CHECK(train::split_validation(setup.samples, 0.0).validation.frames() == 0);
}

}  // namespace
}  // namespace glovepose::evaluate_test
