// The inference FCN (nn/fcn.hpp) against PyTorch's forward (committed fixture) and against a
// double-precision forward written here from the tensors; every storage, both backends, the
// sparse (small batch) and dense (large batch) products, bad input and bad tensors.
#include <glovepose/estimator.hpp>
#include <glovepose/io/tensor_file.hpp>
#include <glovepose/nn/fcn.hpp>
#include <glovepose/train/model_file.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "alloc_counter.hpp"

using namespace glovepose;
using namespace glovepose::nn;

namespace {

// Random FCN tensors, scaled like a trained network's (He-uniform weights, small biases).
TensorMap random_fcn(int inputs, int hidden, unsigned seed) {
  std::mt19937 rng(seed);
  TensorMap tensors;
  for (const auto& [name, shape] : fcn_tensor_shapes(inputs, hidden)) {
    Tensor t{shape, std::vector<float>(static_cast<std::size_t>(Tensor{shape, {}}.element_count()))};
    const double a = shape.size() == 2 ? std::sqrt(6.0 / static_cast<double>(shape[1])) : 0.1;
    std::uniform_real_distribution<float> u(static_cast<float>(-a), static_cast<float>(a));
    for (float& v : t.values) v = u(rng);
    tensors[name] = std::move(t);
  }
  return tensors;
}

std::vector<float> random_inputs(int frames, int inputs, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> x(static_cast<std::size_t>(frames) * static_cast<std::size_t>(inputs));
  for (float& v : x) v = u(rng);
  return x;
}

// The definition, in double: y = W x + b per layer (W as torch stores it, [out][in]), ReLU between.
std::vector<double> reference(const TensorMap& tensors, const float* x, int inputs) {
  std::vector<double> v(x, x + inputs);
  for (int l = 1; l <= kFcnLayers; ++l) {
    const Tensor& w = tensors.at("fc" + std::to_string(l) + ".weight");
    const Tensor& b = tensors.at("fc" + std::to_string(l) + ".bias");
    const std::size_t out = static_cast<std::size_t>(w.shape[0]), in = static_cast<std::size_t>(w.shape[1]);
    std::vector<double> y(out);
    for (std::size_t o = 0; o < out; ++o) {
      double s = b.values[o];
      for (std::size_t i = 0; i < in; ++i) s += static_cast<double>(w.values[o * in + i]) * v[i];
      y[o] = l < kFcnLayers ? std::max(s, 0.0) : s;
    }
    v = std::move(y);
  }
  return v;
}

// max |ours - reference| / max |reference| over `frames` frames run as one call.
template <typename Backend>
double relative_error(const TensorMap& tensors, int inputs, int hidden, WeightStorage storage, int frames, unsigned seed) {
  const auto net = Fcn<Backend>::from_tensors(tensors, inputs, hidden, storage);
  auto ws = net.make_workspace(frames);
  const std::vector<float> x = random_inputs(frames, inputs, seed);
  std::vector<float> y(static_cast<std::size_t>(frames) * kFcnOutputs);
  REQUIRE(net.forward(x.data(), y.data(), frames, ws) == Status::Ok);
  double diff = 0.0, scale = 0.0;
  for (int f = 0; f < frames; ++f) {
    const std::vector<double> expected = reference(tensors, x.data() + static_cast<long>(f) * inputs, inputs);
    for (int o = 0; o < kFcnOutputs; ++o) {
      diff = std::max(diff, std::abs(expected[static_cast<std::size_t>(o)] - y[static_cast<std::size_t>(f * kFcnOutputs + o)]));
      scale = std::max(scale, std::abs(expected[static_cast<std::size_t>(o)]));
    }
  }
  return diff / scale;
}

}  // namespace

TEST_CASE("fcn: the F32 forward equals PyTorch's (committed fixture: 44 inputs, hidden 16, 8 frames)") {
  const io::TensorFile fx =
      io::TensorFile::read(std::string(GLOVEPOSE_SOURCE_DIR) + "/tests/fixtures/grad_fcn_h16_c44.safetensors", "fixture");
  TensorMap tensors;
  for (const auto& [name, t] : fx.tensors)
    if (name.rfind("param.", 0) == 0) tensors[name.substr(6)] = Tensor{t.shape, t.to<float>()};
  const std::vector<float> x = fx.tensors.at("input").to<float>();
  const std::vector<double> expected = fx.tensors.at("output").to<double>();  // torch, float64
  const int frames = static_cast<int>(fx.tensors.at("input").shape[0]);
  const auto check = [&](const auto& net, int per_call) {
    auto ws = net.make_workspace(per_call);
    std::vector<float> y(expected.size());
    for (int f = 0; f < frames; f += per_call)
      REQUIRE(net.forward(x.data() + f * 44, y.data() + f * kFcnOutputs, std::min(per_call, frames - f), ws) == Status::Ok);
    double worst = 0.0;
    for (std::size_t i = 0; i < y.size(); ++i) worst = std::max(worst, std::abs(y[i] - expected[i]));
    return worst;
  };
  const auto simd = Fcn<>::from_tensors(tensors, 44, 16);
  const auto scalar = Fcn<kernels::ScalarBackend>::from_tensors(tensors, 44, 16);
  CHECK(simd.parameter_count() == 44 * 16 + 16 + 3 * (16 * 16 + 16) + 16 * 8 + 8 + 8 * 25 + 25);
  CHECK(check(simd, 1) < 1e-5);
  CHECK(check(simd, 8) < 1e-5);
  CHECK(check(scalar, 1) < 1e-5);
}

TEST_CASE("fcn: every storage and both backends against the double-precision definition") {
  const int inputs = 44, hidden = 96;  // 96 and 48: not multiples of a pair of AVX-512 vectors (padding)
  const TensorMap tensors = random_fcn(inputs, hidden, 7);
  // Bounds: F32 the accumulation's rounding; Fixed16 codes round within 2^-16 of a channel's
  // largest weight; binary16 keeps 11 significant bits, bfloat16 8.
  const std::vector<std::pair<WeightStorage, double>> bounds = {
      {WeightStorage::F32, 1e-5}, {WeightStorage::Fixed16, 2e-4}, {WeightStorage::F16, 3e-3}, {WeightStorage::BF16, 3e-2}};
  for (const auto& entry : bounds) {
    const WeightStorage storage = entry.first;  // named copies: clang's lambdas (CAPTURE) cannot capture bindings
    const double bound = entry.second;
    CAPTURE(storage_name(storage));
    for (int frames : {1, 5, kSparseMaxFrames, kSparseMaxFrames + 9}) {  // sparse products up to 32 frames, dense beyond
      CAPTURE(frames);
      CHECK(relative_error<kernels::SimdBackend>(tensors, inputs, hidden, storage, frames, 100 + frames) < bound);
      CHECK(relative_error<kernels::ScalarBackend>(tensors, inputs, hidden, storage, frames, 100 + frames) < bound);
    }
  }
  // The bounds are tight enough to see a storage's rounding: BF16 is measurably coarser than F32.
  CHECK(relative_error<kernels::SimdBackend>(tensors, inputs, hidden, WeightStorage::BF16, 8, 3) > 1e-4);
}

TEST_CASE("fcn: forward_batch on threads equals frame-by-frame forwards") {
  const TensorMap tensors = random_fcn(44, 64, 9);
  const auto net = Fcn<>::from_tensors(tensors, 44, 64, WeightStorage::Fixed16);
  const int frames = 77;
  const std::vector<float> x = random_inputs(frames, 44, 4);
  std::vector<float> batch(static_cast<std::size_t>(frames) * kFcnOutputs), single(batch.size());
  net.forward_batch(x.data(), batch.data(), frames, 2, 16);
  auto ws = net.make_workspace(1);
  for (int f = 0; f < frames; ++f) REQUIRE(net.forward(x.data() + f * 44, single.data() + f * kFcnOutputs, 1, ws) == Status::Ok);
  double worst = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < batch.size(); ++i) {
    worst = std::max(worst, static_cast<double>(std::abs(batch[i] - single[i])));
    scale = std::max(scale, static_cast<double>(std::abs(single[i])));
  }
  CHECK(worst <= 1e-6 * scale);
  std::vector<float> bad = x;
  bad[5 * 44 + 3] = std::nanf("");
  CHECK_THROWS_WITH_AS(net.forward_batch(bad.data(), batch.data(), frames, 2), doctest::Contains("frame 5 has a non-finite input"), Error);
}

TEST_CASE("fcn: bad input gets a status, the output is untouched and a frame allocates nothing") {
  TensorMap tensors = random_fcn(44, 32, 1);
  std::fill(tensors["fc1.weight"].values.begin(), tensors["fc1.weight"].values.end(), 1.0f);  // large inputs overflow fc1
  const auto net = Fcn<>::from_tensors(tensors, 44, 32, realtime_storage());
  auto ws = net.make_workspace(1);
  std::vector<float> x = random_inputs(1, 44, 2), y(kFcnOutputs, 42.0f);
  x[10] = std::numeric_limits<float>::infinity();
  CHECK(net.forward(x.data(), y.data(), 1, ws) == Status::NonFinite);
  CHECK(std::all_of(y.begin(), y.end(), [](float v) { return v == 42.0f; }));
  std::vector<float> huge(x.size(), 3e38f);  // finite, but 44 of them overflow fc1's sums
  CHECK(net.forward(huge.data(), y.data(), 1, ws) == Status::NonFinite);
  CHECK(std::all_of(y.begin(), y.end(), [](float v) { return v == 42.0f; }));
  x[10] = 0.5f;
  CHECK(net.forward(x.data(), y.data(), 2, ws) == Status::SizeMismatch);  // more frames than the workspace holds
  const auto other = Fcn<>::from_tensors(random_fcn(44, 16, 1), 44, 16);
  auto other_ws = other.make_workspace(1);
  CHECK(net.forward(x.data(), y.data(), 1, other_ws) == Status::SizeMismatch);
  CHECK(test::allocations_during([&] { (void)net.forward(x.data(), y.data(), 1, ws); }) == 0);
  CHECK(net.forward(x.data(), y.data(), 1, ws) == Status::Ok);
}

TEST_CASE("fcn: tensors that do not make the FCN are refused, naming the tensor") {
  const TensorMap good = random_fcn(44, 16, 3);
  TensorMap missing = good;
  missing.erase("fc3.bias");
  CHECK_THROWS_WITH_AS(Fcn<>::from_tensors(missing, 44, 16), doctest::Contains("tensor 'fc3.bias' is missing, expected shape [16]"), Error);
  TensorMap extra = good;
  extra["fc7.weight"] = Tensor{{1}, {0.0f}};
  CHECK_THROWS_WITH_AS(Fcn<>::from_tensors(extra, 44, 16), doctest::Contains("tensor 'fc7.weight' is not part of"), Error);
  CHECK_THROWS_WITH_AS(Fcn<>::from_tensors(good, 44, 32), doctest::Contains("tensor 'fc1.bias' has shape [16], expected [32]"), Error);
  TensorMap nan = good;
  nan["fc2.weight"].values[3] = std::nanf("");
  CHECK_THROWS_WITH_AS(Fcn<>::from_tensors(nan, 44, 16), doctest::Contains("'fc2.weight' contains NaN"), Error);
  TensorMap huge = good;
  huge["fc4.weight"].values[0] = 1e6f;  // beyond binary16's range
  CHECK_THROWS_WITH_AS(Fcn<>::from_tensors(huge, 44, 16, WeightStorage::F16), doctest::Contains("Fcn: layer fc4 has a weight of"), Error);
  CHECK_NOTHROW(Fcn<>::from_tensors(huge, 44, 16, WeightStorage::F32));
  CHECK_THROWS_AS(Fcn<>::from_tensors(good, 0, 16), Error);
}

TEST_CASE("fcn: a model file with an FCN runs in the estimator with the trainer's angles") {
  // The trainer's FCN (Eigen, F32) is the reference: a file it wrote, loaded by PoseModel, must give
  // its angles on the batch path and frame by frame through GlovePoseEstimator, every storage.
  const int frames = 40, hidden = 64;
  const grid::GloveDescription glove = grid::GloveDescription::glauser2019();
  train::TrainableFcn trainer(glove.cell_count(), hidden, frames);
  trainer.initialize(12);
  const model::ModelInfo info = train::make_model_info(model::Architecture::Fcn, hidden, glove, model::CalibrationMode::OnTheFly, nullptr);
  const std::string path = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/fcn_estimator.safetensors";
  train::save_model(path, info, trainer.parameters().to_tensors());

  // Cells C_c in pF and the calibration range 5..9 pF: normalised cells 2 (c - 5) / 4 - 1 in [-1.1, 1.1].
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1.1, 1.1);
  const Eigen::VectorXd lo = Eigen::VectorXd::Constant(glove.cell_count(), 5.0), hi = Eigen::VectorXd::Constant(glove.cell_count(), 9.0);
  const sensor::CalibrationRange range(lo, hi, glove.cell_names());
  std::vector<float> normalized(static_cast<std::size_t>(frames * glove.cell_count())), cells(normalized.size());
  for (std::size_t i = 0; i < cells.size(); ++i) {
    normalized[i] = static_cast<float>(u(rng));
    cells[i] = static_cast<float>(5.0 + 2.0 * (normalized[i] + 1.0));
  }
  core::ThreadPool pool(1);
  trainer.forward(normalized.data(), frames, false, pool);
  const hand::JointLimits limits;
  std::vector<hand::Angles> expected(static_cast<std::size_t>(frames));
  for (int f = 0; f < frames; ++f) {
    hand::Angles n{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) n[d] = trainer.output()[static_cast<std::size_t>(f) * hand::kDofCount + d];
    expected[static_cast<std::size_t>(f)] = limits.denormalize(n);
  }
  const auto worst = [&](const std::vector<hand::Angles>& got) {
    double w = 0.0;
    for (int f = 0; f < frames; ++f)
      for (std::size_t d = 0; d < hand::kDofCount; ++d)
        w = std::max(w, std::abs(got[static_cast<std::size_t>(f)][d] - expected[static_cast<std::size_t>(f)][d]));
    return w * core::kDegreesPerRadian;  // degrees
  };
  for (const auto& entry : std::vector<std::pair<WeightStorage, double>>{{WeightStorage::F32, 1e-4}, {WeightStorage::Fixed16, 0.01}}) {
    const WeightStorage storage = entry.first;
    const double bound_deg = entry.second;
    CAPTURE(storage_name(storage));
    PoseModelOptions options;
    options.storage = storage;
    const std::shared_ptr<const PoseModel> model = PoseModel::load(path, options);
    CHECK(model->network().architecture() == model::Architecture::Fcn);
    CHECK(model->network().width() == hidden);
    CHECK(worst(model->predict(cells.data(), frames, range, 2)) < bound_deg);
    GlovePoseEstimator estimator(model);
    estimator.set_calibration(range);
    std::vector<hand::Angles> streamed(static_cast<std::size_t>(frames));
    std::vector<double> frame(static_cast<std::size_t>(glove.cell_count()));
    for (int f = 0; f < frames; ++f) {
      for (int c = 0; c < glove.cell_count(); ++c)
        frame[static_cast<std::size_t>(c)] = cells[static_cast<std::size_t>(f * glove.cell_count() + c)];
      REQUIRE(estimator.push_cells(frame.data(), glove.cell_count(), 0.01 * f) == Status::Solved);
      streamed[static_cast<std::size_t>(f)] = estimator.pose().raw_angles;
    }
    CHECK(worst(streamed) < bound_deg);
    CHECK(test::allocations_during([&] { (void)estimator.push_cells(frame.data(), glove.cell_count(), 1.0); }) == 0);
  }
  // The model's inputs must match the FCN's: a file whose tensors were cut for another glove is refused.
  train::TrainableFcn other(14, hidden, 1);
  other.initialize(1);
  train::save_model(path, info, other.parameters().to_tensors());
  CHECK_THROWS_WITH_AS(PoseModel::load(path), doctest::Contains("tensor 'fc1.weight' has shape [64, 14], expected [64, 44]"), Error);
  std::remove(path.c_str());
}
