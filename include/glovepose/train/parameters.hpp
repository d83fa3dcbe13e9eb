/// @file parameters.hpp
/// @brief A network's tensors while it trains: values and gradients in the layout the trainer
/// computes with, converted to and from PyTorch's state_dict layout (the weight file's) at the edges.
///
/// Convolution weights are kept tap-major, [tap][input channel][output channel], so each kernel
/// tap is one (in x out) matrix for the products of trainable_unet.hpp; PyTorch stores
/// [out][in][ky][kx] (Conv2d) and [in][out][ky][kx] (ConvTranspose2d). Everything else is kept as
/// PyTorch stores it.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../nn/tensor.hpp"

namespace glovepose::train {

/// @brief How a tensor's values are ordered in memory.
enum class Layout : unsigned char {
  Plain,           ///< As PyTorch stores it.
  ConvTaps,        ///< Conv2d weight [out, in, k, k] kept as [k*k][in][out].
  TransposedTaps,  ///< ConvTranspose2d weight [in, out, k, k] kept as [k*k][in][out].
};

/// @brief One named tensor of a network.
struct Parameter {
  std::string name;                 ///< PyTorch state_dict name.
  std::vector<std::int64_t> shape;  ///< PyTorch shape.
  Layout layout = Layout::Plain;    ///< Memory order of `value` and `grad`.
  bool trainable = true;            ///< false: a statistic (BN running mean/var), not optimised.
  std::vector<float> value;         ///< Values.
  std::vector<float> grad;          ///< dLoss/dvalue of the last backward pass (trainable only).

  /// @brief Number of values.
  std::size_t size() const noexcept { return value.size(); }

  /// @brief Position in PyTorch's row-major order of the value at position `i` of `value`.
  std::size_t torch_index(std::size_t i) const noexcept {
    if (layout == Layout::Plain) return i;
    const std::size_t a = static_cast<std::size_t>(shape[0]), b = static_cast<std::size_t>(shape[1]);
    const std::size_t taps = static_cast<std::size_t>(shape[2] * shape[3]);
    const std::size_t in = layout == Layout::ConvTaps ? b : a, out = layout == Layout::ConvTaps ? a : b;
    const std::size_t co = i % out, ci = (i / out) % in, tap = i / (out * in);
    return layout == Layout::ConvTaps ? (co * in + ci) * taps + tap : (ci * out + co) * taps + tap;
  }
};

/// @brief The tensors of a network, in the order they were added.
class ParameterSet {
 public:
  /// @brief Adds a zero-filled tensor; returns its index.
  std::size_t add(std::string name, std::vector<std::int64_t> shape, Layout layout = Layout::Plain, bool trainable = true) {
    std::int64_t n = 1;
    for (std::int64_t d : shape) n *= d;
    if (layout != Layout::Plain && shape.size() != 4)
      throw Error("ParameterSet: tensor '" + name + "' is a convolution weight of shape " + io::shape_string(shape) +
                  ", expected 4 dimensions");
    Parameter p{std::move(name), std::move(shape), layout, trainable, std::vector<float>(static_cast<std::size_t>(n), 0.0f), {}};
    if (trainable) p.grad.assign(p.value.size(), 0.0f);
    params_.push_back(std::move(p));
    return params_.size() - 1;
  }

  /// @brief Tensor `i`.
  Parameter& operator[](std::size_t i) noexcept { return params_[i]; }
  /// @brief Tensor `i`.
  const Parameter& operator[](std::size_t i) const noexcept { return params_[i]; }
  /// @brief Number of tensors.
  std::size_t size() const noexcept { return params_.size(); }
  /// @brief All tensors.
  std::vector<Parameter>& all() noexcept { return params_; }
  /// @brief All tensors.
  const std::vector<Parameter>& all() const noexcept { return params_; }

  /// @brief Number of trainable values.
  std::size_t trainable_count() const noexcept {
    std::size_t n = 0;
    for (const Parameter& p : params_) n += p.trainable ? p.size() : 0;
    return n;
  }

  /// @brief The tensors in PyTorch's layout, by name (what a weight file stores).
  nn::TensorMap to_tensors() const {
    nn::TensorMap map;
    for (const Parameter& p : params_) map[p.name] = nn::Tensor{p.shape, torch_order(p, p.value)};
    return map;
  }

  /// @brief The gradients in PyTorch's layout, by name (trainable tensors only).
  nn::TensorMap gradients() const {
    nn::TensorMap map;
    for (const Parameter& p : params_)
      if (p.trainable) map[p.name] = nn::Tensor{p.shape, torch_order(p, p.grad)};
    return map;
  }

  /// @brief Sets every tensor from `tensors` (PyTorch layout). Throws glovepose::Error naming the
  /// tensor that is missing, extra, of another shape or not finite.
  void load(const nn::TensorMap& tensors) {
    for (Parameter& p : params_) {
      const auto it = tensors.find(p.name);
      if (it == tensors.end()) throw Error("tensor '" + p.name + "' is missing, expected shape " + io::shape_string(p.shape));
      if (it->second.shape != p.shape)
        throw Error("tensor '" + p.name + "' has shape " + io::shape_string(it->second.shape) + ", expected " + io::shape_string(p.shape));
      if (it->second.values.size() != p.size())
        throw Error("tensor '" + p.name + "' holds " + std::to_string(it->second.values.size()) + " values, expected " +
                    std::to_string(p.size()));
      for (std::size_t i = 0; i < p.size(); ++i) {
        const float v = it->second.values[p.torch_index(i)];
        if (!std::isfinite(v)) throw Error("tensor '" + p.name + "' contains NaN or infinity, expected finite values");
        p.value[i] = v;
      }
    }
    for (const auto& [name, t] : tensors) {
      bool known = false;
      for (const Parameter& p : params_) known = known || p.name == name;
      if (!known) throw Error("tensor '" + name + "' is not part of this network");
    }
  }

 private:
  static std::vector<float> torch_order(const Parameter& p, const std::vector<float>& values) {
    std::vector<float> out(values.size());
    for (std::size_t i = 0; i < values.size(); ++i) out[p.torch_index(i)] = values[i];
    return out;
  }

  std::vector<Parameter> params_;
};

}  // namespace glovepose::train
