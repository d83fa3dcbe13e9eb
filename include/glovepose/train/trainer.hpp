/// @file trainer.hpp
/// @brief The training loop: shuffled mini-batches, the L2 loss, an optimiser step per batch, and
/// model selection on a validation set (the paper keeps the model with the lowest validation
/// error). Reproducible for a seed and a thread count; stoppable between steps (Ctrl-C in the CLI),
/// its state handed to a callback at every epoch's end and resumable from it (checkpoint.hpp keeps
/// it in a file) to the same weights, bit for bit.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <numeric>
#include <string>
#include <vector>

#include "../core/units.hpp"
#include "../config.hpp"
#include "../hand/dofs.hpp"
#include "../core/random.hpp"
#include "../io/number_text.hpp"
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

/// @brief Where a training run is, at the end of an epoch or between two steps: what train_network()
/// needs to go on as if it had never stopped (TrainConfig::resume, TrainConfig::on_checkpoint).
struct TrainingState {
  int epoch = 0;                           ///< Epoch to go on with (0-based).
  long step = 0;                           ///< Steps of that epoch already taken.
  double loss_sum = 0.0;                   ///< Sum of that epoch's losses so far.
  long steps = 0;                          ///< Optimiser steps in all.
  long trained_frames = 0;                 ///< Frames trained on in all.
  double seconds = 0.0;                    ///< Wall time of the run so far.
  double train_seconds = 0.0;              ///< Of it, in the steps.
  std::vector<EpochRecord> epochs;         ///< The finished epochs.
  int best_epoch = -1;                     ///< Epoch of the kept model (-1: none yet).
  double best_validation_error_deg = NAN;  ///< Its validation error.
  nn::TensorMap best;                      ///< The kept model's tensors (PyTorch layout).
  std::vector<std::vector<float>> values;  ///< Every tensor of the network, in its own memory order.
  OptimizerState optimizer;                ///< The optimizer's moments and steps.
  std::map<std::string, std::string> run;  ///< What is trained and how (run_identity()): a state resumes only the same run.
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
  /// Called with the state at the end of every epoch, every checkpoint_seconds within an epoch, and
  /// where a stop (signal or time limit) interrupts one.
  std::function<void(const TrainingState&)> on_checkpoint;
  double checkpoint_seconds = 600.0;  ///< Within an epoch, the wall time between two on_checkpoint calls.
  const TrainingState* resume = nullptr;  ///< Go on from this state (of the same run: run_identity()).
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

/// @brief How many of `count` normalised predictions lie outside the joint limits ([-1, 1]); with
/// `hold`, each is moved to them. Every model's poses are held there as their last step, as the
/// estimator holds them: a linear map extrapolates without bound (one fitted on a real recording
/// reached -230 and +265 degrees on another take), and so does the FCN, whose last layer is linear
/// (the U-Net's tanh keeps it within). The truth lies within the limits, so holding can only bring
/// a prediction closer. Pose-guided calibration holds after adding its offsets (with_offsets), so
/// its predictions are taken as they are (`hold` false).
inline std::size_t outside_limits(float* normalized, std::size_t count, bool hold = true) noexcept {
  std::size_t outside = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const float v = normalized[i];
    if (v > 1.0f || v < -1.0f) {
      if (hold) normalized[i] = v > 1.0f ? 1.0f : -1.0f;
      ++outside;
    }
  }
  return outside;
}

/// @brief The network's outputs (normalised, frames x 25) for every frame of `samples`, in
/// evaluation mode, in chunks of the network's max batch, held within the joint limits unless
/// `hold` is false (outside_limits); `outside`, when given, is set to how many were outside them.
inline std::vector<float> predict(TrainableNetwork& net, const Samples& samples, core::ThreadPool& pool, std::size_t* outside = nullptr,
                                  bool hold = true) {
  std::vector<float> out(static_cast<std::size_t>(samples.frames()) * kTargets);
  for (long f = 0; f < samples.frames(); f += net.max_batch()) {
    const int n = static_cast<int>(std::min<long>(net.max_batch(), samples.frames() - f));
    net.forward(samples.inputs.data() + f * samples.cells, n, false, pool);
    std::copy(net.output(), net.output() + static_cast<long>(n) * kTargets, out.begin() + f * kTargets);
  }
  const std::size_t beyond = outside_limits(out.data(), out.size(), hold);
  if (outside) *outside = beyond;
  return out;
}

/// @brief Mean absolute angle error in degrees of normalised predictions against true angles, over
/// the DoFs of `scored` (the labelled ones).
inline double mean_error_degrees(const std::vector<float>& predicted, const std::vector<float>& angles, const hand::JointLimits& limits,
                                 const hand::DofSet& scored = hand::all_dofs()) {
  double sum = 0.0;
  std::size_t count = 0;
  const std::size_t frames = angles.size() / hand::kDofCount;
  for (std::size_t f = 0; f < frames; ++f) {
    hand::Angles normalized{};
    std::copy(predicted.begin() + static_cast<long>(f * hand::kDofCount), predicted.begin() + static_cast<long>((f + 1) * hand::kDofCount),
              normalized.begin());
    const hand::Angles radians = limits.denormalize(normalized);  // as eval turns predictions into angles
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      if (!scored[d]) continue;
      sum += std::abs(radians[d] - angles[f * hand::kDofCount + d]);
      ++count;
    }
  }
  return count ? sum / static_cast<double>(count) * core::kDegreesPerRadian : NAN;
}

/// @brief What a run trains and how, as text: the network's tensors, the frames (counts and a
/// checksum of their inputs and targets), the batch, epochs, seed, update rule and augmentation. A
/// TrainingState resumes only a run with the same identity.
inline std::map<std::string, std::string> run_identity(const TrainableNetwork& net, const Samples& train, const Samples& validation,
                                                       const TrainConfig& config) {
  std::uint64_t hash = 14695981039346656037ULL;  // FNV-1a over the bytes of the frames
  const auto add = [&hash](const std::vector<float>& values) {
    const auto* bytes = reinterpret_cast<const unsigned char*>(values.data());
    for (std::size_t i = 0; i < values.size() * sizeof(float); ++i) hash = (hash ^ bytes[i]) * 1099511628211ULL;
  };
  for (const Samples* s : {&train, &validation}) {
    add(s->inputs);
    add(s->targets);
  }
  const OptimizerConfig& o = config.optimizer;
  const Augmentation& a = config.augmentation;
  char checksum[17];
  std::snprintf(checksum, sizeof checksum, "%016llx", static_cast<unsigned long long>(hash));
  return {{"tensors", std::to_string(net.parameters().size()) + " (" + std::to_string(net.parameters().trainable_count()) + " trained values)"},
          {"frames", std::to_string(train.frames()) + " training, " + std::to_string(validation.frames()) + " validation"},
          {"frames_checksum", checksum},
          {"batch", std::to_string(config.batch)},
          {"epochs", std::to_string(config.epochs)},
          {"seed", std::to_string(config.seed)},
          {"optimizer", std::string(o.kind == OptimizerKind::Adam ? "adam" : "sgd") + " lr " + io::number_text(o.learning_rate) + " betas " +
                            io::number_text(o.beta1) + " " + io::number_text(o.beta2) + " eps " + io::number_text(o.epsilon)},
          {"augmentation", io::number_text(a.gain) + " " + io::number_text(a.offset) + " " + io::number_text(a.noise)}};
}

/// @brief Trains `net` on `train` (targets normalised by `limits`), keeps the tensors with the
/// lowest validation error (the last ones when `validation` is empty). From config.resume it goes
/// on where that state was and ends as the run that never stopped would have, bit for bit (the
/// same thread count). Throws glovepose::Error for mismatched sizes, a non-finite loss (naming the
/// step) or a state of another run (naming what differs).
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
  const std::map<std::string, std::string> identity = run_identity(net, train, validation, config);
  const auto start = std::chrono::steady_clock::now();
  double seconds_before = 0.0;  // of the run before it was resumed
  const auto elapsed = [&] { return seconds_before + std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  double train_seconds = 0.0;
  long trained_frames = 0;
  int first_epoch = 0;
  long first_step = 0;
  double first_loss_sum = 0.0;
  if (const TrainingState* s = config.resume) {
    for (const auto& [key, value] : identity) {
      const auto it = s->run.find(key);
      const std::string was = it == s->run.end() ? "(none)" : it->second;
      if (was != value)
        throw Error("train: the checkpoint is of another run: its " + key + " is " + was + ", this run's " + value +
                    "; expected the same data and settings");
    }
    const auto damaged = [](const std::string& what) { return Error("train: the checkpoint is damaged: " + what); };
    if (s->epoch < 0 || s->epoch > config.epochs || s->step < 0 || (s->step > 0 && s->step >= steps_per_epoch) ||
        (s->epoch == config.epochs && s->step != 0))
      throw damaged("epoch " + std::to_string(s->epoch) + ", step " + std::to_string(s->step) + ", expected within the run's " +
                    std::to_string(config.epochs) + " epochs of " + std::to_string(steps_per_epoch) + " steps");
    if (s->epochs.size() != static_cast<std::size_t>(s->epoch) || s->best_epoch < -1 || s->best_epoch >= s->epoch || s->steps < 0 ||
        s->trained_frames < 0 || s->optimizer.steps != s->steps)
      throw damaged(std::to_string(s->epochs.size()) + " epoch records, kept epoch " + std::to_string(s->best_epoch) + ", " +
                    std::to_string(s->steps) + " steps, expected one record per finished epoch, a finished epoch kept and the optimizer's steps");
    const nn::TensorMap shapes = net.parameters().to_tensors();
    if (s->best_epoch >= 0) {
      if (s->best.size() != shapes.size()) throw damaged("the kept model has " + std::to_string(s->best.size()) + " tensors, expected " +
                                                         std::to_string(shapes.size()));
      for (const auto& [name, t] : shapes) {
        const auto it = s->best.find(name);
        if (it == s->best.end() || it->second.shape != t.shape || it->second.values.size() != t.values.size())
          throw damaged("the kept model's tensor '" + name + "' is missing or of another shape, expected the network's");
      }
    }
    ParameterSet& params = net.parameters();
    if (s->values.size() != params.size())
      throw Error("train: the checkpoint holds " + std::to_string(s->values.size()) + " tensors, expected " + std::to_string(params.size()));
    for (std::size_t k = 0; k < params.size(); ++k) {
      if (s->values[k].size() != params[k].size())
        throw Error("train: the checkpoint's tensor '" + params[k].name + "' has " + std::to_string(s->values[k].size()) + " values, expected " +
                    std::to_string(params[k].size()));
      params[k].value = s->values[k];
    }
    optimizer.restore(s->optimizer);
    result.epochs = s->epochs;
    result.best_epoch = s->best_epoch;
    result.best_validation_error_deg = s->best_validation_error_deg;
    result.best = s->best;
    result.steps = s->steps;
    trained_frames = s->trained_frames;
    train_seconds = s->train_seconds;
    seconds_before = s->seconds;
    first_epoch = s->epoch;
    first_step = s->step;
    first_loss_sum = s->loss_sum;
  }
  auto last_checkpoint = std::chrono::steady_clock::now();
  const auto checkpoint = [&](int epoch, long step, double loss_sum) {
    last_checkpoint = std::chrono::steady_clock::now();
    if (!config.on_checkpoint) return;
    TrainingState s;
    s.epoch = epoch;
    s.step = step;
    s.loss_sum = loss_sum;
    s.steps = result.steps;
    s.trained_frames = trained_frames;
    s.seconds = elapsed();
    s.train_seconds = train_seconds;
    s.epochs = result.epochs;
    s.best_epoch = result.best_epoch;
    s.best_validation_error_deg = result.best_validation_error_deg;
    s.best = result.best;
    for (const Parameter& p : net.parameters().all()) s.values.push_back(p.value);
    s.optimizer = optimizer.state();
    s.run = identity;
    config.on_checkpoint(s);
  };
  const auto keep = [&](const EpochRecord& record) {
    result.best_epoch = record.epoch;
    result.best_validation_error_deg = record.validation_error_deg;
    result.best = net.parameters().to_tensors();
  };
  for (int epoch = first_epoch; epoch < config.epochs && !result.stopped; ++epoch) {
    std::iota(order.begin(), order.end(), 0L);
    core::Rng rng(core::derive_seed(config.seed, {0x5348554646ULL, static_cast<std::uint64_t>(epoch)}));
    for (long i = train.frames() - 1; i > 0; --i)
      std::swap(order[static_cast<std::size_t>(i)], order[rng.next() % static_cast<std::uint64_t>(i + 1)]);
    double loss_sum = epoch == first_epoch ? first_loss_sum : 0.0;
    long step = epoch == first_epoch ? first_step : 0;
    const long epoch_start_step = step;
    for (; step < steps_per_epoch; ++step) {
      if ((config.stop && config.stop->load()) || (config.max_seconds > 0.0 && elapsed() > config.max_seconds)) {
        result.stopped = true;
        checkpoint(epoch, step, loss_sum);  // where the stop came, so a resumed run takes this epoch's next step
        break;
      }
      if (step > epoch_start_step && std::chrono::duration<double>(std::chrono::steady_clock::now() - last_checkpoint).count() >
                                         config.checkpoint_seconds)
        checkpoint(epoch, step, loss_sum);
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
    if (step == 0 || step == epoch_start_step) break;  // stopped before this epoch trained anything
    EpochRecord record{epoch, loss_sum / static_cast<double>(step), NAN, 0.0};
    if (validation.frames() > 0)
      record.validation_error_deg = mean_error_degrees(predict(net, validation, pool), validation.angles, limits, validation.labelled);
    record.seconds = elapsed();
    result.epochs.push_back(record);
    const bool better = validation.frames() == 0 || !(record.validation_error_deg >= result.best_validation_error_deg);
    if (better) keep(record);
    if (!result.stopped) checkpoint(epoch + 1, 0, 0.0);
  }
  result.seconds = elapsed();
  result.samples_per_second = trained_frames / std::max(train_seconds, 1e-9);
  return result;
}

}  // namespace glovepose::train
