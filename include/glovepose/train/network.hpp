/// @file network.hpp
/// @brief What the trainer trains: a network from calibrated cell values (C per frame) to the 25
/// normalised DoF values (hand::kDofs order, [-1, 1] within the joint limits), with the L2 loss.
#pragma once

#include <cstddef>
#include <cstdint>

#include "../hand/dofs.hpp"
#include "../model/architecture.hpp"
#include "parameters.hpp"
#include "../core/thread_pool.hpp"

namespace glovepose::train {

/// @brief Values per frame a network predicts.
inline constexpr int kTargets = static_cast<int>(hand::kDofCount);

/// @brief A network with a forward pass in training or evaluation mode and a backward pass.
class TrainableNetwork {
 public:
  virtual ~TrainableNetwork() = default;
  /// @brief Architecture::UNet or Architecture::Fcn (the weight file's metadata).
  virtual model::Architecture architecture() const = 0;
  /// @brief Its size parameter (U-Net base width, FCN hidden width).
  virtual int width() const = 0;
  /// @brief Cell values per frame.
  virtual int inputs() const = 0;
  /// @brief Largest batch forward() accepts.
  virtual int max_batch() const = 0;
  /// @brief Forward pass of `frames` frames (cells: frames x inputs()); training mode uses batch
  /// statistics in batch norm and updates the running ones, evaluation mode uses the running ones.
  virtual void forward(const float* cells, int frames, bool training, core::ThreadPool& pool) = 0;
  /// @brief The last forward's output, frames x kTargets.
  virtual const float* output() const = 0;
  /// @brief Backward pass of the last (training-mode) forward: sets every trainable tensor's grad
  /// to dLoss/dvalue given dLoss/doutput (frames x kTargets).
  virtual void backward(const float* output_grad, core::ThreadPool& pool) = 0;
  /// @brief The tensors (PyTorch names).
  virtual ParameterSet& parameters() = 0;
  /// @brief The tensors (PyTorch names).
  virtual const ParameterSet& parameters() const = 0;
  /// @brief Fresh initial weights (the architecture's own scheme); the draw depends only on `seed`.
  virtual void initialize(std::uint64_t seed) = 0;
};

/// @brief Mean squared error over n values (torch.nn.functional.mse_loss, mean reduction); writes
/// its gradient 2 (y - t) / n into `grad`. Accumulated in double.
inline double mse_loss(const float* y, const float* target, long n, float* grad) noexcept {
  double sum = 0.0;
  const float scale = 2.0f / static_cast<float>(n);
  for (long i = 0; i < n; ++i) {
    const double d = static_cast<double>(y[i]) - static_cast<double>(target[i]);
    sum += d * d;
    grad[i] = scale * (y[i] - target[i]);
  }
  return sum / static_cast<double>(n);
}

/// @brief mse_loss over the labelled DoFs only, for `frames` rows of kTargets values: the mean of
/// (y - t)^2 over frames x (labelled DoFs) (PyTorch: mse_loss(y[:, mask], t[:, mask])); the
/// gradient is 2 (y - t) / that count for labelled DoFs and 0 for the others, so a DoF without
/// reference angles is never trained. At least one DoF must be labelled.
inline double masked_mse_loss(const float* y, const float* target, long frames, const hand::DofSet& labelled, float* grad) noexcept {
  long per_frame = 0;
  for (bool l : labelled) per_frame += l ? 1 : 0;
  const long n = frames * per_frame;
  double sum = 0.0;
  const float scale = 2.0f / static_cast<float>(n);
  for (long f = 0; f < frames; ++f)
    for (long d = 0; d < kTargets; ++d) {
      const long i = f * kTargets + d;
      if (!labelled[static_cast<std::size_t>(d)]) {
        grad[i] = 0.0f;
        continue;
      }
      const double diff = static_cast<double>(y[i]) - static_cast<double>(target[i]);
      sum += diff * diff;
      grad[i] = scale * (y[i] - target[i]);
    }
  return sum / static_cast<double>(n);
}

}  // namespace glovepose::train
