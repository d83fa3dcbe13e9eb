/// @file fcn.hpp
/// @brief The fully connected network for inference (fcn_topology.hpp): calibrated cell values ->
/// 25 normalised DoF values, from the tensors the trainer or PyTorch wrote (fc1..fc6 as
/// torch.nn.Linear names them).
///
/// Load time: each layer's [out, in] weight matrix is transposed to in x out, its output columns
/// padded to the SIMD width (whole pairs of vectors for BF16 and Fixed16), packed in the kernels'
/// column panels and stored as chosen (packed_weights.hpp). Per frame, one row product per layer;
/// up to kSparseMaxFrames frames the products take only the nonzero inputs (a ReLU leaves about
/// half of them zero, and a zero input's weight row is not read). The loaded network is immutable
/// and may be shared by any number of threads; each stream owns a Workspace.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include "../config.hpp"
#include "../status.hpp"
#include "batching.hpp"
#include "fcn_topology.hpp"
#include "fixed16.hpp"
#include "kernels/scalar.hpp"
#include "kernels/simd.hpp"
#include "kernels/sparse_row.hpp"
#include "packed_weights.hpp"
#include "tensor.hpp"
#include "weight_storage.hpp"

namespace glovepose::nn {

/// @brief The FCN.
/// @tparam Backend kernels::SimdBackend (default) or kernels::ScalarBackend (the reference).
template <typename Backend = kernels::SimdBackend>
class Fcn {
 public:
  /// @brief Builds the FCN for `inputs` cells and hidden width `hidden` from PyTorch-named tensors
  /// (fc1.weight [hidden, inputs] ... fc6.weight [25, hidden / 2] and their biases). Throws
  /// glovepose::Error naming the tensor when one is missing, extra, of the wrong shape or not
  /// finite, or a weight the storage cannot represent.
  static Fcn from_tensors(const TensorMap& tensors, int inputs, int hidden, WeightStorage storage = WeightStorage::F32) {
    if (inputs < 1 || inputs > kMaxInputs || hidden < 2 || hidden > kMaxHidden)
      throw Error("Fcn: " + std::to_string(inputs) + " inputs and hidden width " + std::to_string(hidden) + ", expected 1.." +
                  std::to_string(kMaxInputs) + " inputs and a hidden width of 2.." + std::to_string(kMaxHidden));
    check_tensors(tensors, fcn_tensor_shapes(inputs, hidden), "Fcn",
                  "an FCN of " + std::to_string(inputs) + " inputs and hidden width " + std::to_string(hidden));
    Fcn net;
    net.storage_ = storage;
    net.widths_ = fcn_widths(inputs, hidden);
    const int multiple = paired_storage(storage) ? 2 * Backend::lanes : Backend::lanes;
    net.strides_.push_back(inputs);  // the input row is never padded
    for (int l = 1; l <= kFcnLayers; ++l) net.strides_.push_back(round_up(net.widths_[static_cast<std::size_t>(l)], multiple));
    for (int l = 0; l < kFcnLayers; ++l) net.layers_.push_back(net.pack(l, tensors));
    for (const auto& entry : tensors) net.parameter_count_ += static_cast<std::size_t>(entry.second.element_count());
    return net;
  }

  /// @brief Cell values per frame.
  int inputs() const noexcept { return widths_.front(); }
  /// @brief Hidden width h.
  int hidden() const noexcept { return widths_[1]; }
  /// @brief Values per output frame (25).
  int outputs() const noexcept { return widths_.back(); }
  /// @brief Weight storage chosen at load.
  WeightStorage storage() const noexcept { return storage_; }
  /// @brief Trainable parameters (weights and biases).
  std::size_t parameter_count() const noexcept { return parameter_count_; }
  /// @brief Multiply-adds per frame with every input nonzero.
  std::size_t mac_count() const noexcept {
    std::size_t n = 0;
    for (int l = 0; l < kFcnLayers; ++l)
      n += static_cast<std::size_t>(widths_[static_cast<std::size_t>(l)]) *
           static_cast<std::size_t>(widths_[static_cast<std::size_t>(l + 1)]);
    return n;
  }
  /// @brief Weights kept (biases not counted, as UNet::stored_weight_count): all of every layer's,
  /// and each meets one input per frame, so as many as mac_count().
  std::size_t stored_weight_count() const noexcept { return mac_count(); }
  /// @brief Bytes of packed weights a dense forward streams (channel padding included).
  std::size_t weight_bytes() const noexcept {
    std::size_t n = 0;
    for (const Layer& l : layers_) n += l.weights.bytes();
    return n;
  }

  /// @brief Per-stream activations and scratch for batches of up to `capacity` frames.
  class Workspace {
   public:
    /// @brief Largest batch this workspace serves.
    int capacity() const noexcept { return capacity_; }

   private:
    friend class Fcn;
    int capacity_ = 0;
    std::vector<int> widths_;                  // the network it was made for
    std::vector<AlignedVector<float>> values;  // per layer boundary: [frame][stride]
    std::vector<const float*> x_rows;
    std::vector<float*> y_rows;
    std::vector<int> sparse_index;  // small batches: each frame's nonzero inputs
    std::vector<float> sparse_value;
    std::vector<kernels::SparseRow> sparse_rows;
  };

  /// @brief A workspace for batches of up to `capacity` frames (set-up: allocates).
  Workspace make_workspace(int capacity = 1) const {
    if (capacity < 1 || capacity > kMaxBatch)
      throw Error("Fcn::make_workspace: capacity " + std::to_string(capacity) + ", expected 1.." + std::to_string(kMaxBatch));
    Workspace ws;
    ws.capacity_ = capacity;
    ws.widths_ = widths_;
    int widest = 0;
    for (int stride : strides_) {
      ws.values.emplace_back(static_cast<std::size_t>(stride) * static_cast<std::size_t>(capacity), 0.0f);
      widest = std::max(widest, stride);
    }
    ws.x_rows.resize(static_cast<std::size_t>(capacity));
    ws.y_rows.resize(static_cast<std::size_t>(capacity));
    const std::size_t sparse = static_cast<std::size_t>(std::min(capacity, kSparseMaxFrames));
    ws.sparse_index.resize(sparse * static_cast<std::size_t>(widest));
    ws.sparse_value.resize(sparse * static_cast<std::size_t>(widest));
    ws.sparse_rows.resize(sparse);
    return ws;
  }

  /// @brief `frames` frames: `input` frames x inputs() -> `output` frames x outputs(), row-major,
  /// frames <= the workspace's capacity. Returns Status::NonFinite (output untouched) for a NaN or
  /// infinite input or result, Status::SizeMismatch for a workspace of another network or too
  /// small; never allocates.
  GLOVEPOSE_REALTIME Status forward(const float* input, float* output, int frames, Workspace& ws) const noexcept {
    if (frames < 1 || frames > ws.capacity_ || ws.widths_ != widths_) return Status::SizeMismatch;
    const int in = inputs(), out = outputs();
    for (long i = 0; i < static_cast<long>(frames) * in; ++i)
      if (!std::isfinite(input[i])) return Status::NonFinite;
    std::copy(input, input + static_cast<long>(frames) * in, ws.values[0].begin());
    for (int l = 0; l < kFcnLayers; ++l) run(l, frames, ws);
    const float* result = ws.values.back().data();
    const long stride = strides_.back();
    for (int f = 0; f < frames; ++f)
      for (int o = 0; o < out; ++o)
        if (!std::isfinite(result[f * stride + o])) return Status::NonFinite;  // an overflow inside the network
    for (int f = 0; f < frames; ++f) std::copy(result + f * stride, result + f * stride + out, output + static_cast<long>(f) * out);
    return Status::Ok;
  }

  /// @brief Many frames for evaluation: splits them over `threads` threads, each with its own
  /// workspace, in chunks of `chunk` frames. Set-up code: allocates; throws glovepose::Error naming
  /// the first frame with a non-finite input.
  void forward_batch(const float* input, float* output, long frames, int threads = 1, int chunk = kSparseMaxFrames) const {
    forward_batch_of(*this, "Fcn", inputs(), outputs(), input, output, frames, threads, chunk);
  }

 private:
  static constexpr int kMaxInputs = 1 << 16;
  static constexpr int kMaxHidden = 1 << 16;

  struct Layer {
    AlignedVector<float> bias;  // padded output channels
    PackedWeights weights;      // in x padded out, in the backend's column panels
  };

  Layer pack(int l, const TensorMap& tensors) const {
    const std::string name = "fc" + std::to_string(l + 1);
    const int k = widths_[static_cast<std::size_t>(l)], n = widths_[static_cast<std::size_t>(l + 1)];
    const int columns = strides_[static_cast<std::size_t>(l + 1)];
    const bool paired = paired_storage(storage_);
    const std::vector<float>& weight = tensors.at(name + ".weight").values;  // [n][k]
    std::vector<float> packed(static_cast<std::size_t>(k) * static_cast<std::size_t>(columns), 0.0f);
    std::vector<int> column_of(packed.size(), 0);  // Fixed16: the output channel of each slot
    for (int row = 0; row < k; ++row)
      for (int co = 0; co < columns; ++co) {
        const int column = paired ? kernels::paired_slot(co, Backend::lanes) : co;
        const auto slot = static_cast<std::size_t>(kernels::panel_index(row, column, k, columns, Backend::panel));
        column_of[slot] = co;
        if (co < n) packed[slot] = weight[static_cast<std::size_t>(co) * static_cast<std::size_t>(k) + static_cast<std::size_t>(row)];
      }
    Layer layer;
    const std::vector<float>& bias = tensors.at(name + ".bias").values;
    layer.bias.assign(static_cast<std::size_t>(columns), 0.0f);
    std::copy(bias.begin(), bias.end(), layer.bias.begin());
    layer.weights = encode_weights(packed, storage_, column_of, columns, "Fcn: layer " + name);
    return layer;
  }

  // One layer: y = x W + b (Fixed16: y = scale * (x levels - kFixed16Offset * sum x) + b), then
  // ReLU unless it is the last.
  void run(int l, int frames, Workspace& ws) const noexcept {
    const Layer& layer = layers_[static_cast<std::size_t>(l)];
    const int k = widths_[static_cast<std::size_t>(l)];
    const long in_stride = strides_[static_cast<std::size_t>(l)], out_stride = strides_[static_cast<std::size_t>(l + 1)];
    const float* x = ws.values[static_cast<std::size_t>(l)].data();
    float* y = ws.values[static_cast<std::size_t>(l + 1)].data();
    const bool fixed = layer.weights.fixed16();
    for (int f = 0; f < frames; ++f) {
      float* row = y + f * out_stride;
      if (fixed)
        std::fill(row, row + out_stride, 0.0f);
      else
        std::copy(layer.bias.begin(), layer.bias.end(), row);
      ws.y_rows[static_cast<std::size_t>(f)] = row;
    }
    const bool sparse = frames <= kSparseMaxFrames;
    for (int f = 0; f < frames; ++f) {
      const float* row = x + f * in_stride;
      if (!sparse) {
        ws.x_rows[static_cast<std::size_t>(f)] = row;
        continue;
      }
      int* index = ws.sparse_index.data() + static_cast<long>(f) * k;
      float* value = ws.sparse_value.data() + static_cast<long>(f) * k;
      ws.sparse_rows[static_cast<std::size_t>(f)] = {index, value, Backend::compact(row, k, index, value)};
    }
    layer.weights.visit([&](const auto* w) {
      if (sparse)
        Backend::gemm_sparse_rows(ws.sparse_rows.data(), ws.y_rows.data(), frames, w, k, static_cast<int>(out_stride));
      else
        Backend::gemm_rows(ws.x_rows.data(), ws.y_rows.data(), frames, w, k, static_cast<int>(out_stride));
    });
    if (fixed) {
      const float* scale = layer.weights.fixed_scale.data();
      for (int f = 0; f < frames; ++f) {
        float* row = y + f * out_stride;
        finish_fixed16_row(row, static_cast<int>(out_stride), scale, layer.bias.data(), Backend::sum(x + f * in_stride, k));
      }
    }
    if (l + 1 < kFcnLayers) Backend::relu(y, static_cast<int>(frames * out_stride));
  }

  Fcn() = default;

  WeightStorage storage_ = WeightStorage::F32;
  std::vector<int> widths_;   // inputs, hidden..., outputs
  std::vector<int> strides_;  // per layer boundary: the row length in the workspace (padded)
  std::vector<Layer> layers_;
  std::size_t parameter_count_ = 0;
};

}  // namespace glovepose::nn
