/// @file linear.hpp
/// @brief An affine map y = W x + b: the classic data-glove calibration (a least-squares line from
/// sensor values to joint angles), kept as the baseline the networks must beat. Fitted by
/// train::fit_linear (train/linear_fit.hpp); this header is only the per-frame evaluation.
#pragma once

#include <cfloat>
#include <cmath>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "../config.hpp"
#include "../status.hpp"

namespace glovepose::nn {

/// @brief y = W x + b with `outputs` x `inputs` float weights. Immutable after construction, so one
/// instance may be shared by threads; predict() keeps no state.
class LinearMap {
 public:
  /// @brief Takes the weights (row-major, `outputs` rows of `inputs` values: weight[o * inputs + i]
  /// multiplies input i in output o) and the `outputs` biases. Throws glovepose::Error when a count
  /// is below 1, a size does not match, or a value is NaN or infinite (naming the value).
  LinearMap(int inputs, int outputs, std::vector<float> weight, std::vector<float> bias)
      : inputs_(inputs), outputs_(outputs), weight_(std::move(weight)), bias_(std::move(bias)) {
    if (inputs_ < 1 || outputs_ < 1)
      throw Error("LinearMap: " + std::to_string(inputs_) + " inputs and " + std::to_string(outputs_) +
                  " outputs, expected at least 1 of each");
    const std::size_t expected = static_cast<std::size_t>(inputs_) * static_cast<std::size_t>(outputs_);
    if (weight_.size() != expected)
      throw Error("LinearMap: " + std::to_string(weight_.size()) + " weights, expected outputs x inputs = " + std::to_string(outputs_) +
                  " x " + std::to_string(inputs_) + " = " + std::to_string(expected));
    if (bias_.size() != static_cast<std::size_t>(outputs_))
      throw Error("LinearMap: " + std::to_string(bias_.size()) + " biases, expected one per output (" + std::to_string(outputs_) + ")");
    for (int o = 0; o < outputs_; ++o) {
      double row_sum = 0.0;
      for (int i = 0; i < inputs_; ++i) {
        const float w = weight_[static_cast<std::size_t>(o) * static_cast<std::size_t>(inputs_) + static_cast<std::size_t>(i)];
        if (!std::isfinite(w))
          throw Error("LinearMap: weight (output " + std::to_string(o) + ", input " + std::to_string(i) + ") is " + std::to_string(w) +
                      ", expected a finite number");
        row_sum += std::fabs(static_cast<double>(w));
      }
      const float b = bias_[static_cast<std::size_t>(o)];
      if (!std::isfinite(b))
        throw Error("LinearMap: bias of output " + std::to_string(o) + " is " + std::to_string(b) + ", expected a finite number");
      if (row_sum > max_row_abs_sum_) max_row_abs_sum_ = row_sum;
      if (std::fabs(static_cast<double>(b)) > max_abs_bias_) max_abs_bias_ = std::fabs(static_cast<double>(b));
    }
  }

  /// @brief Number of inputs (length of x).
  int inputs() const noexcept { return inputs_; }
  /// @brief Number of outputs (length of y).
  int outputs() const noexcept { return outputs_; }
  /// @brief Weights, row-major outputs x inputs.
  const std::vector<float>& weight() const noexcept { return weight_; }
  /// @brief Biases, one per output.
  const std::vector<float>& bias() const noexcept { return bias_; }

  /// @brief One frame: y[0..outputs) = W x + b, x of length inputs(); sums in double. Returns
  /// Status::NonFinite (y untouched) when an input is NaN or infinite or a result would overflow float.
  GLOVEPOSE_REALTIME Status predict(const float* x, float* y) const noexcept {
    if (!accepts(x)) return Status::NonFinite;
    write(x, y);
    return Status::Ok;
  }

  /// @brief `frames` frames, row-major: x is frames x inputs(), y frames x outputs(). All or nothing:
  /// returns Status::NonFinite with y untouched when any frame is refused (as by predict()) and then
  /// stores that frame's index in `*rejected_frame` if given; Status::SizeMismatch for frames < 0.
  GLOVEPOSE_REALTIME Status predict(const float* x, float* y, long frames, long* rejected_frame = nullptr) const noexcept {
    if (frames < 0) return Status::SizeMismatch;
    for (long f = 0; f < frames; ++f)
      if (!accepts(x + f * inputs_)) {
        if (rejected_frame) *rejected_frame = f;
        return Status::NonFinite;
      }
    for (long f = 0; f < frames; ++f) write(x + f * inputs_, y + f * outputs_);
    return Status::Ok;
  }

 private:
  // Finite inputs, and no output beyond float's range. The bound max|x| * max_o sum_i |W_oi| + max|b|
  // settles almost every frame without evaluating the map; only when it cannot, the outputs are
  // computed once without being stored.
  bool accepts(const float* x) const noexcept {
    double max_abs_x = 0.0;
    for (int i = 0; i < inputs_; ++i) {
      if (!std::isfinite(x[i])) return false;
      const double a = std::fabs(static_cast<double>(x[i]));
      if (a > max_abs_x) max_abs_x = a;
    }
    if (max_abs_x * max_row_abs_sum_ + max_abs_bias_ <= 0.5 * static_cast<double>(FLT_MAX)) return true;
    for (int o = 0; o < outputs_; ++o)
      if (!std::isfinite(static_cast<float>(output(x, o)))) return false;
    return true;
  }

  double output(const float* x, int o) const noexcept {
    const float* w = weight_.data() + static_cast<std::ptrdiff_t>(o) * inputs_;
    double sum = 0.0;
    for (int i = 0; i < inputs_; ++i) sum += static_cast<double>(w[i]) * static_cast<double>(x[i]);
    return static_cast<double>(bias_[static_cast<std::size_t>(o)]) + sum;
  }

  void write(const float* x, float* y) const noexcept {
    for (int o = 0; o < outputs_; ++o) y[o] = static_cast<float>(output(x, o));
  }

  int inputs_;
  int outputs_;
  std::vector<float> weight_;
  std::vector<float> bias_;
  double max_row_abs_sum_ = 0.0;  // max over outputs of sum_i |W_oi|: bounds |W x| by max|x| times it
  double max_abs_bias_ = 0.0;
};

}  // namespace glovepose::nn
