/// @file checkpoint_file_fuzz.cpp
/// @brief Fuzz target: bytes read as a training checkpoint (train/checkpoint.hpp: `glovepose train
/// --resume`) and, when they hold one, resumed by a small FCN run on fixed frames, the state's run
/// identity set to that run's so that every accepted state reaches the resume's checks and restore.
///
/// Invariants: refusals are glovepose::Error only; an accepted checkpoint writes to bytes that read
/// back to the same state; a resumed run ends within its epochs with one record per epoch and, when
/// it kept a model, the network's tensors.
#include <cstdint>
#include <memory>
#include <string>

#include <glovepose/train/checkpoint.hpp>
#include <glovepose/train/trainable_fcn.hpp>

#include "fuzz_check.hpp"

namespace {

using namespace glovepose;

const train::Samples& frames(std::uint64_t seed) {
  static const auto make = [](std::uint64_t s) {
    train::Samples out;
    out.cells = 44;
    core::Rng rng(s);
    for (int f = 0; f < 48; ++f) {
      for (int c = 0; c < 44; ++c) out.inputs.push_back(static_cast<float>(rng.uniform(-1.0, 1.0)));
      for (int d = 0; d < 25; ++d) {
        out.targets.push_back(static_cast<float>(rng.uniform(-0.9, 0.9)));
        out.angles.push_back(out.targets.back());
      }
      out.run.push_back(0);
      out.source.push_back(f);
    }
    return out;
  };
  static const train::Samples training = make(1), validation = make(2);
  return seed == 1 ? training : validation;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  train::TrainingState state;
  try {
    state = train::checkpoint_state(io::TensorFile::parse(std::string(reinterpret_cast<const char*>(data), size)));
  } catch (const Error&) {
    return 0;
  }
  // An accepted checkpoint writes to bytes that read back to the same state (the same bytes again).
  const std::string bytes = train::checkpoint_file(state).serialize();
  GLOVEPOSE_FUZZ_REQUIRE(train::checkpoint_file(train::checkpoint_state(io::TensorFile::parse(bytes))).serialize() == bytes);
  train::TrainableFcn net(44, 8, 16);
  net.initialize(1);
  core::ThreadPool pool(1);
  train::TrainConfig config;
  config.epochs = 2;
  config.batch = 16;
  hand::Angles lo{}, hi{};
  lo.fill(-1.0);
  hi.fill(1.0);
  state.run = train::run_identity(net, frames(1), frames(2), config);
  config.resume = &state;
  try {
    const train::TrainResult r = train::train_network(net, frames(1), frames(2), hand::JointLimits(lo, hi), config, pool);
    GLOVEPOSE_FUZZ_REQUIRE(r.epochs.size() <= 2);
    GLOVEPOSE_FUZZ_REQUIRE(r.best_epoch < 2);
    if (r.best_epoch >= 0) GLOVEPOSE_FUZZ_REQUIRE(r.best.size() == net.parameters().to_tensors().size());
  } catch (const Error&) {
  }
  return 0;
}
