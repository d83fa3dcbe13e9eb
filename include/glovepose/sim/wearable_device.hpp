/// @file wearable_device.hpp
/// @brief A made-up device that is not a glove: examples/wearable_device.glove.json's 16 channels
/// at 30 Hz, every channel an extra input, whose readings drift. It feeds the input-conditioning
/// tests and the walk-through of docs/own_glove.md ("A device that is not a glove", through
/// examples/example_device.cpp). Every figure here is an assumption of that set-up, not a fit to a
/// device.
#pragma once

#include "../hand/dofs.hpp"
#include "../io/dataset.hpp"

#include <cmath>
#include <random>
#include <vector>

namespace glovepose::sim {

/// The device's frame rate (Hz) and its channels, named channel_00 ... channel_15.
inline constexpr double kWearableRate = 30.0;
inline constexpr std::size_t kWearableChannels = 16;

/// @brief Two sessions of `minutes` each of one person (subject 0, sessions 0 and 1, recording
/// frames, the true angles as labels) wearing the device: each DoF a sum of three sines (0.2 to 1 Hz, within
/// the joint limits), each channel a fixed random mix of the normalised angles through a tanh (an
/// assumption: a stretch channel answers several joints, and saturates), plus its own drift: a
/// random walk of `drift` channel units per square-root second (an assumption; the mixed signal spans
/// about -1 to 1) from a random level (normal, SD 2) per session. The same seed gives the same data.
inline io::Dataset drifting_wearable_sessions(double drift, unsigned seed, double minutes) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const hand::JointLimits limits;
  std::vector<double> mix(kWearableChannels * hand::kDofCount);
  for (double& m : mix) m = normal(rng) / 5.0;
  const long frames = static_cast<long>(minutes * 60.0 * kWearableRate);
  io::Dataset data(kWearableChannels, 0, "wearable-16", kWearableRate);
  for (int session = 0; session < 2; ++session) {
    std::vector<double> frequency(hand::kDofCount * 3), phase(hand::kDofCount * 3), level(kWearableChannels);
    for (double& f : frequency) f = 0.2 + 0.8 * uniform(rng);
    for (double& p : phase) p = 6.283185307179586 * uniform(rng);
    for (double& l : level) l = 2.0 * normal(rng);
    for (long f = 0; f < frames; ++f) {
      const double t = static_cast<double>(f) / kWearableRate;
      hand::Angles n{};
      for (std::size_t d = 0; d < hand::kDofCount; ++d) {
        double v = 0.0;
        for (int k = 0; k < 3; ++k) v += std::sin(6.283185307179586 * frequency[d * 3 + k] * t + phase[d * 3 + k]) / 3.0;
        n[d] = 0.8 * v;
      }
      const hand::Angles angles = limits.denormalize(n);
      for (std::size_t c = 0; c < kWearableChannels; ++c) {
        level[c] += drift * normal(rng) / std::sqrt(kWearableRate);
        double signal = 0.0;
        for (std::size_t d = 0; d < hand::kDofCount; ++d) signal += mix[c * hand::kDofCount + d] * n[d];
        data.cells.push_back(static_cast<float>(std::tanh(signal) + level[c]));
      }
      for (const double a : angles) data.angles.push_back(static_cast<float>(a));
      data.timestamps.push_back(t);
      data.subject.push_back(0);
      data.session.push_back(session);
      data.glove.push_back(0);
      data.donning.push_back(session);
      data.kind.push_back(io::kKindRecording);
      data.outlier.push_back(0);
    }
  }
  return data;
}

}  // namespace glovepose::sim
