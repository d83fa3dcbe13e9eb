// The trainer's numerics: forward in training mode, backward passes, batch-norm statistics and the
// Adam step against PyTorch autograd (fixtures made by tools/python/make_grad_fixtures.py, float64
// references), against finite differences, and the eval-mode forward against the inference U-Net.
#include <glovepose/io/tensor_file.hpp>
#include <glovepose/nn/unet.hpp>
#include <glovepose/train/augmentation.hpp>
#include <glovepose/train/optimizer.hpp>
#include <glovepose/train/trainable_fcn.hpp>
#include <glovepose/train/trainer.hpp>
#include <glovepose/train/trainable_unet.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

using namespace glovepose;

namespace {

struct Fixture {
  io::TensorFile file;
  std::vector<double> get(const std::string& name) const { return file.tensors.at(name).to<double>(); }
  std::vector<float> get_f32(const std::string& name) const { return file.tensors.at(name).to<float>(); }
  bool zero_grad(const std::string& name) const {  // biases right before a batch norm: exactly zero gradient
    return file.metadata.at("zero_grad_params").find("\"" + name + "\"") != std::string::npos;
  }
};

Fixture read_fixture(const std::string& path) { return Fixture{io::TensorFile::read(path, "gradient fixture")}; }

nn::TensorMap starting_tensors(const Fixture& fx) {
  nn::TensorMap map;
  for (const auto& [name, t] : fx.file.tensors)
    if (name.rfind("param.", 0) == 0) map[name.substr(6)] = nn::Tensor{t.shape, t.to<float>()};
  return map;
}

// max |a - b| / max |b| over one tensor (0 when both are 0).
double relative(const std::vector<float>& a, const std::vector<double>& b) {
  double diff = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    diff = std::max(diff, std::abs(a[i] - b[i]));
    scale = std::max(scale, std::abs(b[i]));
  }
  return scale > 0.0 ? diff / scale : diff;
}

// Runs one training step of `net` on the fixture's batch and compares everything it stores.
template <typename Net, typename Forward>
void check_against_fixture(Net& net, const Fixture& fx, Forward&& forward_and_backward) {
  net.parameters().load(starting_tensors(fx));
  core::ThreadPool pool(2);
  const std::vector<float> output = forward_and_backward(pool);
  const std::vector<double> expected_output = fx.get("output");
  REQUIRE(output.size() == expected_output.size());
  double worst_output = 0.0;
  for (std::size_t i = 0; i < output.size(); ++i) worst_output = std::max(worst_output, std::abs(output[i] - expected_output[i]));
  MESSAGE("output: max |C++ - PyTorch| = " << worst_output);
  CHECK(worst_output <= 1e-5);
  const nn::TensorMap grads = net.parameters().gradients();
  double worst_grad = 0.0;
  for (const auto& entry : grads) {  // no structured binding: C++17 lambdas (INFO) cannot capture one (clang 14 rejects it)
    const std::string& name = entry.first;
    const auto& g = entry.second;
    INFO("gradient of " << name);
    const std::vector<double> expected = fx.get("grad." + name);
    REQUIRE(expected.size() == g.values.size());
    if (fx.zero_grad(name)) {  // zero in exact arithmetic; rounding leaves tiny values
      for (std::size_t i = 0; i < expected.size(); ++i) CHECK(std::abs(g.values[i]) <= 1e-6);
      continue;
    }
    const double r = relative(g.values, expected);
    worst_grad = std::max(worst_grad, r);
    CHECK(r <= 1e-4);
  }
  MESSAGE("gradients: worst max|C++ - autograd| / max|autograd| per tensor = " << worst_grad);
  const nn::TensorMap after = net.parameters().to_tensors();
  for (const auto& entry : fx.file.tensors) {  // no structured binding, as above
    const std::string& name = entry.first;
    const auto& t = entry.second;
    if (name.rfind("after.", 0) == 0) {
      INFO("running statistic " << name);
      CHECK(relative(after.at(name.substr(6)).values, t.template to<double>()) <= 1e-5);
    }
  }
  train::Optimizer adam(net.parameters(), {});
  adam.step(net.parameters(), pool);
  const nn::TensorMap stepped = net.parameters().to_tensors();
  for (const auto& entry : grads) {  // no structured binding, as above
    const std::string& name = entry.first;
    INFO("Adam step of " << name);
    const std::vector<double> expected = fx.get("adam." + name);
    const std::vector<float> start = starting_tensors(fx).at(name).values;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      // The first Adam step moves each value by lr * g / (|g| + eps'): compare the step itself.
      const double ours = stepped.at(name).values[i] - start[i], theirs = expected[i] - start[i];
      CHECK(std::abs(ours - theirs) <= (fx.zero_grad(name) ? 2.1e-4 : 2e-4 * 1e-2));
    }
  }
}

double directional_error(train::TrainableNetwork& net, const std::vector<float>& x, const std::vector<float>& t, int frames,
                         unsigned seed) {
  core::ThreadPool pool(2);
  std::vector<float> grad(t.size());
  const auto loss = [&] {
    net.forward(x.data(), frames, true, pool);
    return train::mse_loss(net.output(), t.data(), static_cast<long>(t.size()), grad.data());
  };
  loss();
  net.backward(grad.data(), pool);
  core::Rng rng(seed);
  // A random unit direction in parameter space: small enough steps cross no ReLU kink.
  std::vector<std::vector<float>> direction;
  double norm = 0.0;
  for (train::Parameter& p : net.parameters().all()) {
    direction.emplace_back(p.size(), 0.0f);
    if (!p.trainable) continue;
    for (float& v : direction.back()) {
      v = static_cast<float>(rng.normal());
      norm += static_cast<double>(v) * v;
    }
  }
  double predicted = 0.0;
  for (std::size_t k = 0; k < direction.size(); ++k)
    for (std::size_t i = 0; i < direction[k].size(); ++i) {
      direction[k][i] = static_cast<float>(direction[k][i] / std::sqrt(norm));
      if (net.parameters()[k].trainable) predicted += static_cast<double>(direction[k][i]) * net.parameters()[k].grad[i];
    }
  const auto move = [&](float h) {
    for (std::size_t k = 0; k < direction.size(); ++k)
      for (std::size_t i = 0; i < direction[k].size(); ++i) net.parameters()[k].value[i] += h * direction[k][i];
  };
  const float h = 3e-3f;
  move(h);
  const double plus = loss();
  move(-2 * h);
  const double minus = loss();
  move(h);
  const double numeric = (plus - minus) / (2.0 * h);
  MESSAGE("directional derivative: backward " << predicted << ", central difference " << numeric);
  return std::abs(numeric - predicted) / std::abs(predicted);
}

}  // namespace

TEST_CASE(
    "train: U-Net training step equals PyTorch autograd (committed fixtures, width 4, the built-in glove and two extra input planes)") {
  for (const int extra : {0, 2}) {
    CAPTURE(extra);
    const Fixture fx =
        read_fixture(std::string(GLOVEPOSE_SOURCE_DIR) + "/tests/fixtures/grad_unet_w4" + (extra ? "_e2" : "") + ".safetensors");
    const std::vector<float> x = fx.get_f32("input"), t = fx.get_f32("target");
    REQUIRE(fx.file.tensors.at("input").shape[1] == 2 + extra);
    const int frames = static_cast<int>(fx.file.tensors.at("input").shape[0]);
    // The built-in glove's cells and `extra` inputs off the maps: the U-Net's planes 2, 3.
    const grid::GridMap paper = grid::GridMap::glauser2019();
    std::vector<grid::Slot> slots = paper.cell_slots();
    slots.insert(slots.end(), static_cast<std::size_t>(extra), grid::kOffMaps);
    train::TrainableUNet net(4, grid::GridMap(slots, paper.dof_slots()), frames);
    check_against_fixture(net, fx, [&](core::ThreadPool& pool) {
      std::vector<float> y(t.size()), g(t.size());
      net.forward_maps(x.data(), frames, true, pool, y.data());
      const double loss = train::mse_loss(y.data(), t.data(), static_cast<long>(t.size()), g.data());
      CHECK(loss == doctest::Approx(fx.get("loss")[0]).epsilon(1e-6));
      net.backward_maps(g.data(), pool);
      return y;
    });
  }
}

TEST_CASE("train: FCN training step equals PyTorch autograd (committed fixture, hidden 16)") {
  const Fixture fx = read_fixture(std::string(GLOVEPOSE_SOURCE_DIR) + "/tests/fixtures/grad_fcn_h16_c44.safetensors");
  const std::vector<float> x = fx.get_f32("input"), t = fx.get_f32("target");
  const int frames = static_cast<int>(fx.file.tensors.at("input").shape[0]);
  train::TrainableFcn net(44, 16, frames);
  check_against_fixture(net, fx, [&](core::ThreadPool& pool) {
    std::vector<float> g(t.size());
    net.forward(x.data(), frames, true, pool);
    std::vector<float> y(net.output(), net.output() + t.size());
    CHECK(train::mse_loss(y.data(), t.data(), static_cast<long>(t.size()), g.data()) == doctest::Approx(fx.get("loss")[0]).epsilon(1e-6));
    net.backward(g.data(), pool);
    return y;
  });
}

TEST_CASE("train: backward passes agree with central differences of the loss along random directions") {
  const int frames = 32;
  core::Rng rng(11);
  std::vector<float> x(static_cast<std::size_t>(frames) * 44), t(static_cast<std::size_t>(frames) * 25);
  for (float& v : x) v = static_cast<float>(rng.uniform(-1.0, 1.0));
  for (float& v : t) v = static_cast<float>(rng.uniform(-0.8, 0.8));
  train::TrainableUNet unet(6, grid::GridMap::glauser2019(), frames);
  unet.initialize(5);
  CHECK(directional_error(unet, x, t, frames, 1) <= 1e-2);
  CHECK(directional_error(unet, x, t, frames, 2) <= 1e-2);
  train::TrainableFcn fcn(44, 24, frames);
  fcn.initialize(6);
  CHECK(directional_error(fcn, x, t, frames, 3) <= 1e-2);
}

TEST_CASE("train: the evaluation-mode forward equals the inference U-Net on the same tensors") {
  const int frames = 16;
  train::TrainableUNet net(8, grid::GridMap::glauser2019(), frames);
  net.initialize(3);
  core::Rng rng(4);
  for (train::Parameter& p : net.parameters().all())  // move BN statistics and biases off their defaults
    if (p.layout == train::Layout::Plain)
      for (float& v : p.value)
        v += static_cast<float>(p.name.find("running_var") != std::string::npos ? rng.uniform(0.2, 1.0) : rng.uniform(-0.3, 0.3));
  std::vector<float> maps(static_cast<std::size_t>(frames) * 50), ours(static_cast<std::size_t>(frames) * 25), theirs(ours.size());
  for (float& v : maps) v = static_cast<float>(rng.uniform(-1.2, 1.2));
  core::ThreadPool pool(2);
  net.forward_maps(maps.data(), frames, false, pool, ours.data());
  const auto inference = nn::UNet<>::from_tensors(net.parameters().to_tensors(), 8);
  inference.forward_batch(maps.data(), theirs.data(), frames);
  double worst = 0.0;
  for (std::size_t i = 0; i < ours.size(); ++i) worst = std::max(worst, static_cast<double>(std::abs(ours[i] - theirs[i])));
  CHECK(worst <= 2e-6);
  CHECK_THROWS_WITH_AS(net.backward_maps(ours.data(), pool), doctest::Contains("expected training mode"), Error);
}

TEST_CASE("train: a step is reproducible for a thread count and close across thread counts") {
  const int frames = 40;
  core::Rng rng(8);
  std::vector<float> x(static_cast<std::size_t>(frames) * 44), t(static_cast<std::size_t>(frames) * 25), g(t.size());
  for (float& v : x) v = static_cast<float>(rng.uniform(-1.0, 1.0));
  for (float& v : t) v = static_cast<float>(rng.uniform(-0.8, 0.8));
  // Three Adam steps; returns the tensors and the training-mode output on the batch. Biases right
  // before a batch norm have zero gradient up to rounding, which Adam scales up to +-lr per step, so
  // across thread counts the outputs are compared (they do not depend on those biases).
  const auto step = [&](int threads) {
    train::TrainableUNet net(8, grid::GridMap::glauser2019(), frames);
    net.initialize(2);
    core::ThreadPool pool(threads);
    train::Optimizer adam(net.parameters(), {});
    for (int i = 0; i < 3; ++i) {
      net.forward(x.data(), frames, true, pool);
      train::mse_loss(net.output(), t.data(), static_cast<long>(t.size()), g.data());
      net.backward(g.data(), pool);
      adam.step(net.parameters(), pool);
    }
    net.forward(x.data(), frames, true, pool);
    return std::make_pair(net.parameters().to_tensors(), std::vector<float>(net.output(), net.output() + t.size()));
  };
  const auto one = step(1), two = step(2), two_again = step(2), three = step(3);
  for (const auto& entry : two.first) {  // no structured binding, as above
    const std::string& name = entry.first;
    const auto& t2 = entry.second;
    INFO(name);
    CHECK(t2.values == two_again.first.at(name).values);
  }
  for (std::size_t i = 0; i < one.second.size(); ++i) {
    CHECK(std::abs(two.second[i] - one.second[i]) <= 1e-4);
    CHECK(std::abs(three.second[i] - one.second[i]) <= 1e-4);
  }
}

TEST_CASE("train: gradients equal PyTorch autograd for a wider U-Net and FCN (fixtures regenerated when PyTorch is installed)") {
  const std::string python = "/usr/bin/python3";
  if (std::system((python + " -c 'import torch' > /dev/null 2>&1").c_str()) != 0) {
    const char* required = std::getenv("GLOVEPOSE_REQUIRE_TORCH");
    if (required && std::string(required) == "1") FAIL("PyTorch is not installed and GLOVEPOSE_REQUIRE_TORCH=1");
    MESSAGE("NOT CHECKED: PyTorch (Debian python3-torch) is not installed, so gradients were not compared with it");
    return;
  }
  const std::string base = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/grad_";
  const std::string script = python + " " + GLOVEPOSE_SOURCE_DIR + "/tools/python/make_grad_fixtures.py";
  REQUIRE(std::system((script + " --arch unet:16 --batch 24 --seed 21 --out " + base + "unet.safetensors > /dev/null").c_str()) == 0);
  REQUIRE(std::system((script + " --arch fcn:64:44 --batch 24 --seed 22 --out " + base + "fcn.safetensors > /dev/null").c_str()) == 0);
  {
    const Fixture fx = read_fixture(base + "unet.safetensors");
    const std::vector<float> x = fx.get_f32("input"), t = fx.get_f32("target");
    train::TrainableUNet net(16, grid::GridMap::glauser2019(), 24);
    check_against_fixture(net, fx, [&](core::ThreadPool& pool) {
      std::vector<float> y(t.size()), g(t.size());
      net.forward_maps(x.data(), 24, true, pool, y.data());
      train::mse_loss(y.data(), t.data(), static_cast<long>(t.size()), g.data());
      net.backward_maps(g.data(), pool);
      return y;
    });
  }
  {
    const Fixture fx = read_fixture(base + "fcn.safetensors");
    const std::vector<float> x = fx.get_f32("input"), t = fx.get_f32("target");
    train::TrainableFcn net(44, 64, 24);
    check_against_fixture(net, fx, [&](core::ThreadPool& pool) {
      std::vector<float> g(t.size());
      net.forward(x.data(), 24, true, pool);
      std::vector<float> y(net.output(), net.output() + t.size());
      train::mse_loss(y.data(), t.data(), static_cast<long>(t.size()), g.data());
      net.backward(g.data(), pool);
      return y;
    });
  }
  std::remove((base + "unet.safetensors").c_str());
  std::remove((base + "fcn.safetensors").c_str());
}

TEST_CASE("train: augmentation perturbs each value as (1 + g) x + o + n with the configured deviations") {
  const long frames = 4000;
  const int cells = 5;
  std::vector<float> base(static_cast<std::size_t>(frames * cells));
  for (long i = 0; i < frames * cells; ++i) base[static_cast<std::size_t>(i)] = (i % 2 == 0) ? 1.0f : 0.0f;  // x = 1 and x = 0
  train::Augmentation a;
  std::vector<float> x = base;
  core::Rng rng(3);
  train::augment(x.data(), frames, cells, a, rng);
  CHECK(x == base);  // inactive: untouched
  a.gain = 0.1;
  a.offset = 0.05;
  a.noise = 0.02;
  core::Rng first(3), second(3);
  train::augment(x.data(), frames, cells, a, first);
  std::vector<float> again = base;
  train::augment(again.data(), frames, cells, a, second);
  CHECK(x == again);  // the same draws for the same seed
  // Variance of the change: g^2 x^2 + o^2 + n^2, i.e. 0.0129 at x = 1 and 0.0029 at x = 0; mean 0.
  double sum1 = 0, sq1 = 0, sum0 = 0, sq0 = 0;
  for (long i = 0; i < frames * cells; ++i) {
    const double d = x[static_cast<std::size_t>(i)] - base[static_cast<std::size_t>(i)];
    (i % 2 == 0 ? sum1 : sum0) += d;
    (i % 2 == 0 ? sq1 : sq0) += d * d;
  }
  const double n = static_cast<double>(frames * cells) / 2.0;
  CHECK(std::abs(sum1 / n) < 4.0 * std::sqrt(0.0129 / n));
  CHECK(std::abs(sum0 / n) < 4.0 * std::sqrt(0.0029 / n));
  CHECK(sq1 / n == doctest::Approx(0.0129).epsilon(0.05));
  CHECK(sq0 / n == doctest::Approx(0.0029).epsilon(0.05));
  a.noise = -0.1;
  CHECK_THROWS_WITH_AS(a.validate(), doctest::Contains("augmentation noise deviation"), Error);
}

TEST_CASE(
    "train: default batch and epochs follow the data's size: the paper's 1024 x 10 on a large corpus, at least 2000 steps on a small one") {
  CHECK(train::default_batch(1'300'000) == 1024);
  CHECK(train::default_epochs(1'300'000, 1024) == 10);
  CHECK(train::default_batch(102'400) == 1024);
  CHECK(train::default_batch(20'000) == 256);       // the power of two nearest 200
  CHECK(train::default_epochs(20'000, 256) == 26);  // 78 steps an epoch: 26 x 78 = 2028 >= 2000
  CHECK(train::default_batch(5'000) == 64);
  CHECK(train::default_batch(500) == 32);
  CHECK(train::default_epochs(500, 32) == 134);  // 15 steps an epoch
  CHECK(train::default_epochs(10, 32) == 1000);  // capped
  for (long frames : {700L, 3'000L, 20'000L, 90'000L}) {
    const int batch = train::default_batch(frames), epochs = train::default_epochs(frames, batch);
    CAPTURE(frames);
    CHECK(epochs * (frames / batch) >= train::kMinDefaultSteps);
    CHECK(frames / batch >= 15);
  }
}
