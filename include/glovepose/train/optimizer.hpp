/// @file optimizer.hpp
/// @brief Adam (the paper's optimiser for the U-Net: lr 2e-4, betas 0.5 / 0.999) and plain SGD (the
/// paper's for the FCN: lr 0.01), updating a ParameterSet in place from its gradients, with the
/// arithmetic of torch.optim (torch 1.13) so a step here equals a step there.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "../config.hpp"
#include "parameters.hpp"
#include "../core/thread_pool.hpp"

namespace glovepose::train {

/// @brief Which update rule.
enum class OptimizerKind : unsigned char { Adam, Sgd };

/// @brief Optimiser settings (defaults: the paper's Adam for the CNNs, appendix A).
struct OptimizerConfig {
  OptimizerKind kind = OptimizerKind::Adam;  ///< Update rule.
  double learning_rate = 2e-4;               ///< lr.
  double beta1 = 0.5;                        ///< Adam: decay of the mean of gradients.
  double beta2 = 0.999;                      ///< Adam: decay of the mean of squared gradients.
  double epsilon = 1e-8;                     ///< Adam: added to the denominator.
};

/// @brief An optimizer's state: Adam's moments per tensor (empty for SGD and untrained tensors) and
/// the steps taken (Optimizer::state(), Optimizer::restore()).
struct OptimizerState {
  std::vector<std::vector<float>> mean;    ///< Mean of the gradients, per tensor.
  std::vector<std::vector<float>> square;  ///< Mean of the squared gradients, per tensor.
  long steps = 0;                          ///< Steps taken.
};

/// @brief Adam or SGD with per-tensor state.
class Optimizer {
 public:
  /// @brief State (Adam moments) for the trainable tensors of `params`. Throws for bad settings.
  Optimizer(const ParameterSet& params, OptimizerConfig config) : config_(config) {
    if (!(config.learning_rate > 0.0) || !(config.beta1 >= 0.0 && config.beta1 < 1.0) || !(config.beta2 >= 0.0 && config.beta2 < 1.0) ||
        !(config.epsilon > 0.0))
      throw Error("Optimizer: expected lr > 0, 0 <= beta1, beta2 < 1 and epsilon > 0");
    for (const Parameter& p : params.all()) {
      const std::size_t n = p.trainable && config.kind == OptimizerKind::Adam ? p.size() : 0;
      mean_.emplace_back(n, 0.0f);
      square_.emplace_back(n, 0.0f);
    }
  }

  /// @brief Settings (the learning rate may be changed between steps).
  OptimizerConfig& config() noexcept { return config_; }
  /// @brief Steps taken.
  long steps() const noexcept { return steps_; }

  /// @brief The state, for a checkpoint.
  OptimizerState state() const { return {mean_, square_, steps_}; }

  /// @brief Continues from `s` (state() of an optimizer for the same parameters and rule). Throws
  /// glovepose::Error naming the first tensor whose size differs.
  void restore(OptimizerState s) {
    if (s.mean.size() != mean_.size() || s.square.size() != square_.size())
      throw Error("Optimizer::restore: state for " + std::to_string(s.mean.size()) + " tensors, expected " + std::to_string(mean_.size()));
    for (std::size_t k = 0; k < mean_.size(); ++k)
      if (s.mean[k].size() != mean_[k].size() || s.square[k].size() != square_[k].size())
        throw Error("Optimizer::restore: tensor " + std::to_string(k) + " has " + std::to_string(s.mean[k].size()) +
                    " moments, expected " + std::to_string(mean_[k].size()) + " (another network or update rule)");
    mean_ = std::move(s.mean);
    square_ = std::move(s.square);
    steps_ = s.steps;
  }

  /// @brief One update of every trainable tensor from its gradient, split over the pool's threads
  /// by contiguous ranges (element-wise, so the result does not depend on the thread count).
  void step(ParameterSet& params, core::ThreadPool& pool) {
    if (params.size() != mean_.size()) throw Error("Optimizer::step: the parameter set is not the one the optimizer was made for");
    ++steps_;
    const double t = static_cast<double>(steps_);
    // torch.optim.Adam: step_size = lr / (1 - beta1^t), denom = sqrt(v) / sqrt(1 - beta2^t) + eps.
    const float step_size = static_cast<float>(config_.learning_rate / (1.0 - std::pow(config_.beta1, t)));
    const float correction2 = static_cast<float>(std::sqrt(1.0 - std::pow(config_.beta2, t)));
    const float b1 = static_cast<float>(config_.beta1), b2 = static_cast<float>(config_.beta2);
    const float eps = static_cast<float>(config_.epsilon), lr = static_cast<float>(config_.learning_rate);
    for (std::size_t k = 0; k < params.size(); ++k) {
      Parameter& p = params[k];
      if (!p.trainable) continue;
      float* value = p.value.data();
      const float* grad = p.grad.data();
      float* m = mean_[k].data();
      float* v = square_[k].data();
      const bool adam = config_.kind == OptimizerKind::Adam;
      pool.for_shares(static_cast<long>(p.size()), [&](core::Range r, int) {
        for (long i = r.begin; i < r.end; ++i) {
          const float g = grad[i];
          if (!adam) {
            value[i] -= lr * g;
            continue;
          }
          m[i] = m[i] * b1 + (1.0f - b1) * g;
          v[i] = v[i] * b2 + (1.0f - b2) * g * g;
          value[i] -= step_size * m[i] / (std::sqrt(v[i]) / correction2 + eps);
        }
      });
    }
  }

 private:
  OptimizerConfig config_;
  std::vector<std::vector<float>> mean_, square_;
  long steps_ = 0;
};

}  // namespace glovepose::train
