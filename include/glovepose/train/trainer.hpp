/// @file trainer.hpp
/// @brief The training loop: shuffled mini-batches, the L2 loss, an optimiser step per batch, and
/// model selection on a validation set (the paper keeps the model with the lowest validation
/// error). Reproducible for a seed and a thread count; stoppable between steps (Ctrl-C in the CLI)
/// with the best model so far handed to a callback whenever it improves.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <numeric>
#include <string>
#include <vector>

#include "../core/units.hpp"
#include "../config.hpp"
#include "../hand/dofs.hpp"
#include "../core/random.hpp"
#include "augmentation.hpp"
#include "network.hpp"
#include "optimizer.hpp"
#include "samples.hpp"
#include "../core/thread_pool.hpp"

namespace glovepose::train {

/// @brief Where training is, for progress bars.
struct Progress {
  int epoch = 0;                     ///< Current epoch (0-based).
  int epochs = 0;                    ///< Epochs planned.
  long step = 0;                     ///< Steps done in this epoch.
  long steps_per_epoch = 0;          ///< Steps per epoch.
  double loss = 0.0;                 ///< Mean training loss of this epoch so far.
  double samples_per_second = 0.0;   ///< Training throughput so far.
  double eta_seconds = 0.0;          ///< Estimated time to the end.
  double best_validation_deg = 0.0;  ///< Best validation error so far (NaN before the first).
};

/// @brief One epoch's figures.
struct EpochRecord {
  int epoch;                    ///< 0-based.
  double train_loss;            ///< Mean L2 loss over the epoch's batches.
  double validation_error_deg;  ///< Mean absolute angle error on the validation set (NaN if none).
  double seconds;               ///< Wall time since training started, at the epoch's end.
};

/// @brief Training settings.
struct TrainConfig {
  int epochs = 10;                                   ///< Passes over the training frames.
  int batch = 1024;                                  ///< Frames per step (the paper: 1024 generic, 256 personalised, 64 fine-tuning).
  OptimizerConfig optimizer;                         ///< Update rule (default: the paper's Adam).
  std::uint64_t seed = 1;                            ///< Shuffling (and augmentation) seed.
  Augmentation augmentation;                         ///< Perturbation of the training frames' inputs (default none).
  double max_seconds = 0.0;                          ///< Stop after this much wall time (0: no limit).
  const std::atomic<bool>* stop = nullptr;           ///< Set from elsewhere (a signal handler) to stop between steps.
  std::function<void(const Progress&)> on_progress;  ///< Called after every step.
  std::function<void(const TrainableNetwork&, const EpochRecord&)> on_best;  ///< Called when validation improves.
};

/// @brief Optimiser steps that the default number of epochs reaches at least (default_epochs()).
inline constexpr long kMinDefaultSteps = 2000;

/// @brief The default batch for `frames` training frames: the paper's 1024 from 102,400 frames on
/// (an epoch of at least 100 steps); below, the power of two nearest frames / 100, at least 32, so a
/// small data set still gets about 100 steps an epoch instead of a handful of large ones.
inline int default_batch(long frames) noexcept {
  int batch = 1024;
  while (batch > 32 && static_cast<double>(frames) / 100.0 < 0.75 * batch) batch /= 2;
  return batch;
}

/// @brief The default number of epochs: the paper's 10, or more when 10 epochs of `batch` would
/// take fewer than kMinDefaultSteps optimiser steps (at most 1000 epochs).
inline int default_epochs(long frames, int batch) noexcept {
  const long steps_per_epoch = std::max(1L, frames / std::max(1, batch));
  const long epochs = (kMinDefaultSteps + steps_per_epoch - 1) / steps_per_epoch;
  return static_cast<int>(std::clamp(epochs, 10L, 1000L));
}

/// @brief What training did.
struct TrainResult {
  std::vector<EpochRecord> epochs;         ///< Per finished epoch.
  int best_epoch = -1;                     ///< Epoch of the kept model.
  double best_validation_error_deg = NAN;  ///< Its validation error.
  nn::TensorMap best;                      ///< The kept model's tensors (PyTorch layout).
  long steps = 0;                          ///< Optimiser steps taken.
  double seconds = 0.0;                    ///< Wall time.
  double samples_per_second = 0.0;         ///< Training frames per second (forward + backward + step).
  bool stopped = false;                    ///< Stopped early (signal or time limit).
};

/// @brief The network's outputs (normalised, frames x 25) for every frame of `samples`, in
/// evaluation mode, in chunks of the network's max batch.
inline std::vector<float> predict(TrainableNetwork& net, const Samples& samples, core::ThreadPool& pool) {
  std::vector<float> out(static_cast<std::size_t>(samples.frames()) * kTargets);
  for (long f = 0; f < samples.frames(); f += net.max_batch()) {
    const int n = static_cast<int>(std::min<long>(net.max_batch(), samples.frames() - f));
    net.forward(samples.inputs.data() + f * samples.cells, n, false, pool);
    std::copy(net.output(), net.output() + static_cast<long>(n) * kTargets, out.begin() + f * kTargets);
  }
  return out;
}

/// @brief Mean absolute angle error in degrees of normalised predictions against true angles, over
/// the DoFs of `scored` (the labelled ones).
inline double mean_error_degrees(const std::vector<float>& predicted, const std::vector<float>& angles, const hand::JointLimits& limits,
                                 const hand::DofSet& scored = hand::all_dofs()) {
  double sum = 0.0;
  std::size_t count = 0;
  const std::size_t frames = angles.size() / hand::kDofCount;
  for (std::size_t f = 0; f < frames; ++f)
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      if (!scored[d]) continue;
      const double radians = limits.min()[d] + 0.5 * (predicted[f * hand::kDofCount + d] + 1.0) * (limits.max()[d] - limits.min()[d]);
      sum += std::abs(radians - angles[f * hand::kDofCount + d]);
      ++count;
    }
  return count ? sum / static_cast<double>(count) * core::kDegreesPerRadian : NAN;
}

/// @brief Trains `net` on `train` (targets normalised by `limits`), keeps the tensors with the
/// lowest validation error (the last ones when `validation` is empty). Throws glovepose::Error for
/// mismatched sizes or a non-finite loss (naming the step).
inline TrainResult train_network(TrainableNetwork& net, const Samples& train, const Samples& validation, const hand::JointLimits& limits,
                                 const TrainConfig& config, core::ThreadPool& pool) {
  if (train.cells != net.inputs())
    throw Error("train: the samples have " + std::to_string(train.cells) + " cells per frame, the network takes " +
                std::to_string(net.inputs()));
  if (train.frames() < 1) throw Error("train: no training frames");
  if (config.epochs < 1 || config.batch < 1) throw Error("train: expected epochs >= 1 and batch >= 1");
  config.augmentation.validate();
  const int batch = static_cast<int>(std::min<long>({static_cast<long>(config.batch), train.frames(), static_cast<long>(net.max_batch())}));
  const long steps_per_epoch = train.frames() / batch;  // the remainder waits for the next shuffle
  Optimizer optimizer(net.parameters(), config.optimizer);
  std::vector<float> x(static_cast<std::size_t>(batch) * static_cast<std::size_t>(train.cells)),
      t(static_cast<std::size_t>(batch) * kTargets), grad(static_cast<std::size_t>(batch) * kTargets);
  std::vector<long> order(static_cast<std::size_t>(train.frames()));
  TrainResult result;
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  double train_seconds = 0.0;
  long trained_frames = 0;
  const auto keep = [&](const EpochRecord& record) {
    result.best_epoch = record.epoch;
    result.best_validation_error_deg = record.validation_error_deg;
    result.best = net.parameters().to_tensors();
    if (config.on_best) config.on_best(net, record);
  };
  for (int epoch = 0; epoch < config.epochs && !result.stopped; ++epoch) {
    std::iota(order.begin(), order.end(), 0L);
    core::Rng rng(core::derive_seed(config.seed, {0x5348554646ULL, static_cast<std::uint64_t>(epoch)}));
    for (long i = train.frames() - 1; i > 0; --i)
      std::swap(order[static_cast<std::size_t>(i)], order[rng.next() % static_cast<std::uint64_t>(i + 1)]);
    double loss_sum = 0.0;
    long step = 0;
    for (; step < steps_per_epoch; ++step) {
      if ((config.stop && config.stop->load()) || (config.max_seconds > 0.0 && elapsed() > config.max_seconds)) {
        result.stopped = true;
        break;
      }
      const auto step_start = std::chrono::steady_clock::now();
      for (int b = 0; b < batch; ++b) {
        const long i = order[static_cast<std::size_t>(step * batch + b)];
        std::copy(train.inputs.begin() + i * train.cells, train.inputs.begin() + (i + 1) * train.cells,
                  x.begin() + static_cast<long>(b) * train.cells);
        std::copy(train.targets.begin() + i * kTargets, train.targets.begin() + (i + 1) * kTargets,
                  t.begin() + static_cast<long>(b) * kTargets);
      }
      if (config.augmentation.active()) {
        core::Rng draw(
            core::derive_seed(config.seed, {0x4155474dULL, static_cast<std::uint64_t>(epoch), static_cast<std::uint64_t>(step)}));
        augment(x.data(), batch, train.cells, config.augmentation, draw);
      }
      net.forward(x.data(), batch, true, pool);
      const double loss = train.labelled == hand::all_dofs()
                              ? mse_loss(net.output(), t.data(), static_cast<long>(batch) * kTargets, grad.data())
                              : masked_mse_loss(net.output(), t.data(), batch, train.labelled, grad.data());
      if (!std::isfinite(loss))
        throw Error("train: the loss became " + std::to_string(loss) + " at epoch " + std::to_string(epoch) + ", step " +
                    std::to_string(step) + "; expected a finite loss (lower the learning rate?)");
      net.backward(grad.data(), pool);
      optimizer.step(net.parameters(), pool);
      ++result.steps;
      loss_sum += loss;
      train_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - step_start).count();
      trained_frames += batch;
      if (config.on_progress) {
        Progress p;
        p.epoch = epoch;
        p.epochs = config.epochs;
        p.step = step + 1;
        p.steps_per_epoch = steps_per_epoch;
        p.loss = loss_sum / static_cast<double>(step + 1);
        p.samples_per_second = trained_frames / std::max(train_seconds, 1e-9);
        const long remaining = static_cast<long>(config.epochs - epoch) * steps_per_epoch - (step + 1);
        p.eta_seconds = elapsed() / static_cast<double>(result.steps) * static_cast<double>(remaining);
        p.best_validation_deg = result.best_validation_error_deg;
        config.on_progress(p);
      }
    }
    if (step == 0) break;  // stopped before this epoch trained anything
    EpochRecord record{epoch, loss_sum / static_cast<double>(step), NAN, 0.0};
    if (validation.frames() > 0)
      record.validation_error_deg = mean_error_degrees(predict(net, validation, pool), validation.angles, limits, validation.labelled);
    record.seconds = elapsed();
    result.epochs.push_back(record);
    const bool better = validation.frames() == 0 || !(record.validation_error_deg >= result.best_validation_error_deg);
    if (better) keep(record);
  }
  result.seconds = elapsed();
  result.samples_per_second = trained_frames / std::max(train_seconds, 1e-9);
  return result;
}

}  // namespace glovepose::train
