// DoFs without reference angles (a dataset labelling a subset): not trained (zero gradient, the
// output layer's rows for them untouched by training), not scored (metrics over the labelled ones,
// against a mean computed here), and read as the rest pose by a model trained without them.
#include <glovepose/train/metrics_report.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/train/metrics.hpp>
#include <glovepose/train/model_file.hpp>
#include <glovepose/train/samples.hpp>
#include <glovepose/train/trainer.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <vector>

using namespace glovepose;

namespace {

hand::DofSet without(std::initializer_list<const char*> names) {
  hand::DofSet set = hand::all_dofs();
  for (const char* name : names) set[hand::dof_from_name(name)] = false;
  return set;
}

const hand::DofSet kSubset = without({"thumb_base_abduction", "index_base_twist", "pinky_tip_flexion"});

}  // namespace

TEST_CASE("labelled DoFs: the set reads and writes as DoF names, and bad lists are refused") {
  CHECK(hand::parse_dof_set(hand::dof_set_text(kSubset), "t") == kSubset);
  CHECK(hand::dof_set_text(without({})).rfind("thumb_base_abduction,", 0) == 0);
  CHECK_THROWS_WITH_AS(hand::parse_dof_set("index_base_flexion,wrist", "metadata 'labelled_dofs'"),
                       "metadata 'labelled_dofs': 'wrist' is not a DoF, expected comma-separated names such as 'index_base_flexion'",
                       Error);
  CHECK_THROWS_WITH_AS(hand::parse_dof_set("index_base_flexion,index_base_flexion", "x"),
                       "x: 'index_base_flexion' is listed twice, expected each DoF once", Error);
  CHECK_THROWS_AS(hand::parse_dof_set("", "x"), Error);
  const hand::JointLimits limits;
  const hand::Angles rest = limits.rest();
  for (std::size_t d = 0; d < hand::kDofCount; ++d) CHECK(rest[d] == std::clamp(0.0, limits.min()[d], limits.max()[d]));
}

TEST_CASE("labelled DoFs: the masked loss is the mean over labelled values only, with no gradient for the others") {
  const long frames = 3;
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> y(frames * 25), t(frames * 25), grad(frames * 25, 7.0f), grad_all(frames * 25);
  for (float& v : y) v = u(rng);
  for (float& v : t) v = u(rng);
  double sum = 0.0;
  for (long f = 0; f < frames; ++f)
    for (std::size_t d = 0; d < 25; ++d)
      if (kSubset[d]) sum += std::pow(static_cast<double>(y[f * 25 + d]) - t[f * 25 + d], 2);
  const double loss = train::masked_mse_loss(y.data(), t.data(), frames, kSubset, grad.data());
  CHECK(loss == doctest::Approx(sum / (frames * 22)).epsilon(1e-14));
  for (long f = 0; f < frames; ++f)
    for (std::size_t d = 0; d < 25; ++d) {
      const std::size_t i = static_cast<std::size_t>(f) * 25 + d;
      if (kSubset[d])
        CHECK(grad[i] == doctest::Approx(2.0 * (y[i] - t[i]) / (frames * 22)).epsilon(1e-6));
      else
        CHECK(grad[i] == 0.0f);
    }
  // Every DoF labelled: the same bits as the plain loss.
  const double all = train::masked_mse_loss(y.data(), t.data(), frames, hand::all_dofs(), grad.data());
  CHECK(all == train::mse_loss(y.data(), t.data(), frames * 25, grad_all.data()));
  CHECK(grad == grad_all);
}

TEST_CASE(
    "labelled DoFs: samples train toward the rest pose where there is no angle, and training leaves those outputs' weights untouched") {
  // A dataset of 6 cells labelling 22 DoFs: angles a fixed linear function of the cells.
  const std::size_t cells = 6, n = 300;
  io::Dataset data(cells, 0, "six", 60.0);
  data.set_labelled_dofs(kSubset);
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(1.0f, 2.0f);
  for (std::size_t i = 0; i < n; ++i) {
    float sum = 0.0f;
    for (std::size_t c = 0; c < cells; ++c) {
      data.cells.push_back(u(rng));
      sum += data.cells.back();
    }
    for (std::size_t d = 0; d < 25; ++d) data.angles.push_back(kSubset[d] ? 0.05f * sum + 0.01f * static_cast<float>(d) : NAN);
    data.timestamps.push_back(static_cast<double>(i) / 60.0);
    data.subject.push_back(0);
    data.session.push_back(0);
    data.glove.push_back(0);
    data.donning.push_back(0);
    data.kind.push_back(io::kKindRecording);
    data.outlier.push_back(0);
  }
  data.validate();
  const hand::JointLimits limits;
  const train::Samples samples = train::make_samples(data, {}, model::CalibrationMode::None, nullptr, limits);
  CHECK(samples.labelled == kSubset);
  const hand::Angles rest = limits.normalize(limits.rest());
  for (long f = 0; f < samples.frames(); ++f)
    for (std::size_t d = 0; d < 25; ++d) {
      const std::size_t i = static_cast<std::size_t>(f) * 25 + d;
      if (kSubset[d]) continue;
      CHECK(std::isnan(samples.angles[i]));
      CHECK(samples.targets[i] == static_cast<float>(rest[d]));
    }

  train::TrainableFcn net(static_cast<int>(cells), 16, 64);
  net.initialize(3);
  const nn::TensorMap before = net.parameters().to_tensors();
  core::ThreadPool pool(1);
  train::TrainConfig config;
  config.epochs = 3;
  config.batch = 32;
  const train::ValidationParts parts = train::split_validation(samples, 0.2);
  const train::TrainResult result = train::train_network(net, parts.training, parts.validation, limits, config, pool);
  CHECK(std::isfinite(result.best_validation_error_deg));  // scored over the labelled DoFs only
  const nn::TensorMap after = net.parameters().to_tensors();
  // The output layer: one row of weights and one bias per DoF.
  std::string last;
  for (const auto& [name, tensor] : after)
    if (tensor.shape.size() == 2 && tensor.shape[0] == 25) last = name.substr(0, name.find('.'));
  REQUIRE(!last.empty());
  const nn::Tensor &w0 = before.at(last + ".weight"), &w1 = after.at(last + ".weight");
  const nn::Tensor &b0 = before.at(last + ".bias"), &b1 = after.at(last + ".bias");
  const std::size_t width = static_cast<std::size_t>(w0.shape[1]);
  for (std::size_t d = 0; d < 25; ++d) {
    CAPTURE(d);
    const bool same_row = std::equal(w0.values.begin() + d * width, w0.values.begin() + (d + 1) * width, w1.values.begin() + d * width);
    CHECK(same_row == !kSubset[d]);
    CHECK((b0.values[d] == b1.values[d]) == !kSubset[d]);
  }
}

TEST_CASE("labelled DoFs: only scored DoFs count in the error figures (a mean computed here), NaN truth elsewhere skips no frame") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  train::AngleErrorAccumulator errors(kSubset);
  double sum = 0.0, thumb = 0.0;
  int thumb_count = 0;
  for (int f = 0; f < 40; ++f) {
    hand::Angles p{}, t{};
    for (std::size_t d = 0; d < 25; ++d) {
      p[d] = u(rng);
      t[d] = kSubset[d] ? u(rng) : NAN;
      if (!kSubset[d]) continue;
      const double e = std::abs(p[d] - t[d]) * core::kDegreesPerRadian;
      sum += e;
      if (hand::kDofs[d].finger == hand::Finger::Thumb) thumb += e, ++thumb_count;
    }
    CHECK(errors.add(p, t));
  }
  const train::AngleErrorReport r = errors.report();
  CHECK(r.frames == 40);
  CHECK(r.skipped_frames == 0);
  CHECK(r.scored_dofs == 22);
  CHECK(r.angles == 40 * 22);
  CHECK(r.overall.mean_deg == doctest::Approx(sum / (40 * 22)).epsilon(1e-9));
  CHECK(r.fingers[0].error.mean_deg == doctest::Approx(thumb / thumb_count).epsilon(1e-9));
  CHECK(thumb_count == 40 * 4);
  for (std::size_t d = 0; d < 25; ++d) {
    CHECK(r.dofs[d].scored == kSubset[d]);
    CHECK(std::isnan(r.dofs[d].error.mean_deg) == !kSubset[d]);
  }
  const std::string json = train::to_json(r);
  CHECK(json.find("\"scored_dofs\": 22") != std::string::npos);
  CHECK(json.find("{\"dof\": \"thumb_base_abduction\", \"theta\": 9, \"scored\": false, \"mean_deg\": null") != std::string::npos);
  CHECK(train::format_table(r).find("40 frames x 22 angles (3 DoFs not labelled, not scored)") != std::string::npos);
  train::AngleErrorAccumulator all;
  CHECK_THROWS_AS(all.merge(errors), Error);
  CHECK_THROWS_AS(train::AngleErrorAccumulator(hand::DofSet{}), Error);
}

TEST_CASE("labelled DoFs: a model trained without some DoFs reads the rest pose for them, in training tools and the estimator") {
  const int cells = 44;
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> u(-0.3f, 0.3f);
  std::vector<float> w(25 * cells), b(25);
  for (float& v : w) v = u(rng);
  for (float& v : b) v = u(rng);
  train::TrainedModel model;
  model.info = train::make_model_info("linear", 0, grid::GloveDescription::glauser2019(), model::CalibrationMode::None, nullptr);
  model.info.labelled_dofs = kSubset;
  model.linear.emplace(cells, 25, w, b);
  train::Samples samples;
  samples.cells = cells;
  for (int i = 0; i < 2 * cells; ++i) samples.inputs.push_back(u(rng));
  samples.source = {0, 1};
  samples.run = {0, 0};
  core::ThreadPool pool(1);
  const std::vector<float> out = model.predict(samples, pool);
  const hand::JointLimits limits;
  const hand::Angles rest = limits.normalize(limits.rest());
  for (std::size_t f = 0; f < 2; ++f)
    for (std::size_t d = 0; d < 25; ++d) {
      double expected = b[d];
      for (int c = 0; c < cells; ++c)
        expected +=
            static_cast<double>(w[d * cells + static_cast<std::size_t>(c)]) * samples.inputs[f * cells + static_cast<std::size_t>(c)];
      CHECK(out[f * 25 + d] == doctest::Approx(kSubset[d] ? expected : rest[d]).epsilon(1e-5));
    }

  // The metadata round-trips through a model file and reaches the estimator's model.
  nn::WeightFile file;
  model.info.to(file);
  CHECK(file.metadata.at("labelled_dofs") == hand::dof_set_text(kSubset));
  CHECK(model::ModelInfo::from(file).labelled_dofs == kSubset);
  file.metadata["labelled_dofs"] = "index_base_flexion,elbow";
  CHECK_THROWS_WITH_AS(model::ModelInfo::from(file), doctest::Contains("metadata 'labelled_dofs': 'elbow' is not a DoF"), Error);

  auto loaded = PoseModel::load(std::string(GLOVEPOSE_SOURCE_DIR) + "/tests/fixtures/unet_w4.safetensors");
  CHECK(loaded->labelled_dofs() == hand::all_dofs());
  hand::Angles outputs{};
  for (double& v : outputs) v = 0.25;
  CHECK(loaded->model_outputs(outputs) == outputs);
  nn::WeightFile fixture = nn::WeightFile::read(std::string(GLOVEPOSE_SOURCE_DIR) + "/tests/fixtures/unet_w4.safetensors");
  fixture.metadata["labelled_dofs"] = hand::dof_set_text(kSubset);
  const std::string partial_file = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/unet_w4_partial.safetensors";
  fixture.write(partial_file);
  const auto partial = PoseModel::load(partial_file);
  CHECK(partial->labelled_dofs() == kSubset);
  const hand::Angles read = partial->model_outputs(outputs);
  for (std::size_t d = 0; d < 25; ++d) CHECK(read[d] == (kSubset[d] ? 0.25 : rest[d]));
}
