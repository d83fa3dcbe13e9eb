// A training run stopped anywhere and resumed from its state (in memory and through the checkpoint
// file) ends with the weights and the validation history of the run that never stopped, bit for
// bit; a state of another run is refused, naming what differs.
#include <glovepose/train/checkpoint.hpp>
#include <glovepose/train/trainable_fcn.hpp>
#include <glovepose/train/trainable_unet.hpp>
#include <glovepose/train/trainer.hpp>

#include <doctest/doctest.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "test_files.hpp"

using namespace glovepose;

namespace {

// Frames whose targets are a smooth function of the inputs, so that training improves and stalls.
train::Samples synthetic(int frames, std::uint64_t seed) {
  train::Samples s;
  s.cells = 44;
  core::Rng rng(seed);
  for (int f = 0; f < frames; ++f) {
    std::vector<float> x(44);
    for (float& v : x) v = static_cast<float>(rng.uniform(-1.0, 1.0));
    s.inputs.insert(s.inputs.end(), x.begin(), x.end());
    for (int d = 0; d < 25; ++d) {
      const float t = std::tanh(0.8f * x[static_cast<std::size_t>(d)] - 0.5f * x[static_cast<std::size_t>(d + 19)] * x[static_cast<std::size_t>(d)]);
      s.targets.push_back(t);
      s.angles.push_back(t);  // the limits below are [-1, 1]: normalised = radians
    }
    s.run.push_back(0);
    s.source.push_back(f);
  }
  return s;
}

hand::JointLimits unit_limits() {
  hand::Angles lo{}, hi{};
  lo.fill(-1.0);
  hi.fill(1.0);
  return hand::JointLimits(lo, hi);
}

struct Run {
  train::TrainResult result;
  std::vector<train::TrainingState> states;
};

// Trains a fresh network (initialised with `init_seed`) from `resume` (or the start) and records
// every checkpoint; `every_step` takes one between any two steps.
template <typename MakeNet>
Run train_from(MakeNet make_net, std::uint64_t init_seed, const train::TrainingState* resume, bool every_step = false,
               long stop_after_steps = -1) {
  const train::Samples training = synthetic(600, 1), validation = synthetic(120, 2);
  std::unique_ptr<train::TrainableNetwork> net = make_net();
  net->initialize(init_seed);
  core::ThreadPool pool(2);
  train::TrainConfig config;
  config.epochs = 4;
  config.batch = 64;
  config.seed = 5;
  config.optimizer.learning_rate = 3e-3;
  config.augmentation.noise = 0.01;  // the per-step draws must resume too
  config.resume = resume;
  config.checkpoint_seconds = every_step ? 0.0 : 600.0;
  std::atomic<bool> stop{false};
  config.stop = &stop;
  Run run;
  config.on_checkpoint = [&](const train::TrainingState& s) { run.states.push_back(s); };
  config.on_progress = [&](const train::Progress&) {
    if (stop_after_steps > 0 && --stop_after_steps == 0) stop.store(true);  // as Ctrl-C does, between two steps
  };
  run.result = train::train_network(*net, training, validation, unit_limits(), config, pool);
  return run;
}

void check_same_run(const train::TrainResult& resumed, const train::TrainResult& whole) {
  CHECK(resumed.steps == whole.steps);
  CHECK(resumed.best_epoch == whole.best_epoch);
  CHECK(resumed.best_validation_error_deg == whole.best_validation_error_deg);
  REQUIRE(resumed.epochs.size() == whole.epochs.size());
  for (std::size_t e = 0; e < whole.epochs.size(); ++e) {
    CAPTURE(e);
    CHECK(resumed.epochs[e].train_loss == whole.epochs[e].train_loss);
    CHECK(resumed.epochs[e].validation_error_deg == whole.epochs[e].validation_error_deg);
  }
  REQUIRE(resumed.best.size() == whole.best.size());
  for (const auto& entry : whole.best) {
    INFO(entry.first);
    CHECK(resumed.best.at(entry.first).values == entry.second.values);  // bit for bit
  }
}

const auto fcn = [] { return std::make_unique<train::TrainableFcn>(44, 32, 64); };
const auto unet = [] { return std::make_unique<train::TrainableUNet>(8, grid::GridMap::glauser2019(), 64); };

}  // namespace

TEST_CASE("checkpoint: an FCN resumed at an epoch's end and within an epoch ends as the run that never stopped") {
  const Run whole = train_from(fcn, 3, nullptr, true);
  REQUIRE(whole.result.epochs.size() == 4);
  REQUIRE(whole.states.size() > 20);  // every step: 9 steps an epoch
  // Resumed from the state after the fourth step of the second epoch, and from the end of the
  // second epoch, with a network initialised differently: everything comes from the state.
  const auto at = [&](int epoch, long step) {
    for (const train::TrainingState& s : whole.states)
      if (s.epoch == epoch && s.step == step) return &s;
    FAIL("no state at epoch " << epoch << ", step " << step);
    return &whole.states.front();
  };
  for (const train::TrainingState* from : {at(1, 4), at(2, 0)}) {
    CAPTURE(from->epoch);
    CAPTURE(from->step);
    const Run resumed = train_from(fcn, 99, from);
    check_same_run(resumed.result, whole.result);
  }
}

TEST_CASE("checkpoint: a U-Net (batch-norm statistics) stopped by a signal, saved to a file and resumed ends as the whole run") {
  const Run whole = train_from(unet, 3, nullptr);
  const Run stopped = train_from(unet, 3, nullptr, false, 13);  // stopped within the second epoch
  REQUIRE(stopped.result.stopped);
  REQUIRE_FALSE(stopped.states.empty());
  const train::TrainingState& last = stopped.states.back();
  CHECK(last.epoch == 1);
  CHECK(last.step == 4);  // 9 steps an epoch: 13 = 9 + 4
  const std::string path = test::temp_path("unet_run.checkpoint");
  train::write_checkpoint(path, last);
  const train::TrainingState read = train::read_checkpoint(path);
  CHECK(read.values == last.values);
  CHECK(read.run == last.run);
  const Run resumed = train_from(unet, 7, &read);
  check_same_run(resumed.result, whole.result);
}

TEST_CASE("checkpoint: a state of another run is refused, naming what differs, and a file that is not one is named") {
  const Run whole = train_from(fcn, 3, nullptr);
  train::TrainingState other = whole.states.front();
  other.run["seed"] = "6";
  CHECK_THROWS_WITH_AS(train_from(fcn, 3, &other), doctest::Contains("the checkpoint is of another run: its seed is 6, this run's 5"), Error);
  other = whole.states.front();
  other.values.pop_back();
  CHECK_THROWS_WITH_AS(train_from(fcn, 3, &other), doctest::Contains("tensors, expected"), Error);
  const std::string path = test::temp_path("not_a.checkpoint");
  io::TensorFile plain;
  plain.metadata["format"] = "glovepose-model";
  plain.write(path);
  CHECK_THROWS_WITH_AS(train::read_checkpoint(path),
                       doctest::Contains(("training checkpoint '" + path + "': not a training checkpoint").c_str()), Error);
}
