/// @file unet.hpp
/// @brief The paper's U-Net (Table 6; our reading in weights_format.md): 2x5x5 stretch maps ->
/// 1x5x5 pose map, on fixed grids. A glove's E inputs that are not on the maps come in as E more
/// input planes of constant value ((2 + E) x 5 x 5; only enc1 reads them).
///
/// This file: loading, the workspace's sizes and the forward's entry points. Load time packs each
/// layer (unet_packing.hpp: batch norm folded, taps that only meet padding dropped, weights as F32
/// or in 16 bits: F16, BF16, Fixed16, half the bytes to stream at batch 1); the forward runs the
/// packed layers (unet_run.hpp); unet_diagnostics.hpp says what a forward read. The loaded model is
/// immutable and may be shared by any number of threads; each stream owns a Workspace.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../status.hpp"
#include "batching.hpp"
#include "kernels/scalar.hpp"
#include "kernels/simd.hpp"
#include "../core/team.hpp"
#include "tensor.hpp"
#include "unet_packing.hpp"
#include "unet_run.hpp"
#include "unet_topology.hpp"
#include "weight_storage.hpp"

namespace glovepose::nn {

/// @brief Named widths: the paper's three sizes (Tables 4/5: about 3M, 13M, 50M parameters) and w = 64.
struct UNetPreset {
  const char* name;  ///< Preset name.
  int width;         ///< Base width w.
};
/// @brief The presets.
inline constexpr std::array<UNetPreset, 4> kUNetPresets{{{"paper3m", 48}, {"w64", 64}, {"paper13m", 100}, {"paper50m", 196}}};

/// @brief Largest base width accepted (w = 4096 is already ~22G parameters).
inline constexpr int kMaxWidth = 4096;

/// @brief The U-Net.
/// @tparam Backend kernels::SimdBackend (default) or kernels::ScalarBackend (the reference).
template <typename Backend = kernels::SimdBackend>
class UNet {
 public:
  /// @brief Builds the network of width `width` from PyTorch-named tensors (weights_format.md); the
  /// number of extra input planes is enc1.weight's input channels less 2. Throws glovepose::Error
  /// naming the tensor when one is missing, extra, of the wrong shape, or not finite.
  static UNet from_tensors(const TensorMap& tensors, int width, double bn_eps = 1e-5, WeightStorage storage = WeightStorage::F32) {
    if (width < 1 || width > kMaxWidth) throw Error("UNet: width " + std::to_string(width) + ", expected 1.." + std::to_string(kMaxWidth));
    if (!(bn_eps > 0.0)) throw Error("UNet: bn_eps must be > 0");
    UNet net;
    net.width_ = width;
    net.storage_ = storage;
    net.extra_inputs_ = extra_planes_of(tensors);
    net.buffers_ = unet_buffers<Backend>(width, net.extra_inputs_, storage);
    check_tensor_names(tensors, width, net.extra_inputs_);
    for (const UNetLayer& spec : unet_layers(width))
      net.layers_.push_back(pack_unet_layer<Backend>(spec, tensors, bn_eps, net.buffers_, width, net.extra_inputs_, storage));
    for (const auto& [name, t] : tensors)
      if (name.find("running_") == std::string::npos) net.parameter_count_ += static_cast<std::size_t>(t.element_count());
    return net;
  }

  /// @brief The tensor names and shapes a network of width `width` reading `extra_inputs` extra
  /// input planes is made of.
  static std::map<std::string, std::vector<std::int64_t>> expected_tensors(int width, int extra_inputs = 0) {
    return unet_tensor_shapes(width, extra_inputs);
  }

  /// @brief Base width w.
  int width() const noexcept { return width_; }
  /// @brief Input planes beside the two stretch maps: the glove's extra inputs, one constant plane each.
  int extra_inputs() const noexcept { return extra_inputs_; }
  /// @brief Values in one frame's input: (2 + extra_inputs()) x 5 x 5.
  int input_values() const noexcept { return (kUNetMapPlanes + extra_inputs_) * kUNetGridPositions; }
  /// @brief Weight storage chosen at load.
  WeightStorage storage() const noexcept { return storage_; }
  /// @brief Trainable parameters of the PyTorch model (conv weights and biases, BN scale and shift).
  std::size_t parameter_count() const noexcept { return parameter_count_; }
  /// @brief Weights kept after folding BN and dropping taps that only meet padding (unpadded count).
  std::size_t stored_weight_count() const noexcept {
    std::size_t n = 0;
    for (const PackedLayer& l : layers_) n += l.stored_weights;
    return n;
  }
  /// @brief Multiply-adds per frame that meet real input (padding skipped; im2col's zero taps and
  /// channel padding not counted): the arithmetic floor of a forward.
  std::size_t mac_count() const noexcept {
    std::size_t n = 0;
    for (const PackedLayer& l : layers_) {
      const std::size_t cout = static_cast<std::size_t>(buffers_[static_cast<std::size_t>(l.out_buffer)].channels);
      std::size_t cin = 0;
      for (int s : l.sources) cin += static_cast<std::size_t>(buffers_[static_cast<std::size_t>(s)].channels);
      std::size_t pairs = 0;
      if (l.mode == Mode::Im2col) {
        for (int source : l.receptive) pairs += source >= 0;
      } else if (l.mode == Mode::TapColumns) {
        for (const auto& list : l.terms) pairs += list.size();
      } else {
        for (const PackedTap& t : l.taps) pairs += t.out_positions.size();
      }
      n += pairs * cin * cout;
    }
    return n;
  }

  /// @brief Bytes of packed weights streamed per forward at batch 1 (channel padding included).
  std::size_t weight_bytes() const noexcept {
    std::size_t n = 0;
    for (const PackedLayer& l : layers_) n += l.weights.bytes();
    return n;
  }

  /// @brief Per-stream activations and scratch for batches of up to `capacity` frames.
  using Workspace = UNetWorkspace<Backend>;

  /// @brief A workspace for batches of up to `capacity` frames, for a forward by a Team of up to
  /// `team_size` members (set-up: allocates).
  Workspace make_workspace(int capacity = 1, int team_size = 1) const {
    if (capacity < 1 || capacity > kMaxBatch)
      throw Error("UNet::make_workspace: capacity " + std::to_string(capacity) + ", expected 1.." + std::to_string(kMaxBatch));
    if (team_size < 1 || team_size > 64) throw Error("UNet::make_workspace: team size " + std::to_string(team_size) + ", expected 1..64");
    Workspace ws;
    ws.capacity_ = capacity;
    ws.width_ = width_;
    ws.extra_inputs_ = extra_inputs_;
    for (const BufferSpec& b : buffers_)
      ws.buffers.emplace_back(
          static_cast<std::size_t>(b.positions) * static_cast<std::size_t>(capacity) * static_cast<std::size_t>(b.stride), 0.0f);
    std::size_t rows = 0, columns = 0, tap_sums = 0;
    for (const PackedLayer& l : layers_) {
      const BufferSpec& out = buffers_[static_cast<std::size_t>(l.out_buffer)];
      const std::size_t outputs = static_cast<std::size_t>(out.positions) * static_cast<std::size_t>(capacity);
      for (const PackedTap& t : l.taps) rows = std::max(rows, t.out_positions.size() * static_cast<std::size_t>(capacity));
      if (l.mode == Mode::Im2col) {
        rows = std::max(rows, outputs);
        columns = std::max(columns, outputs * static_cast<std::size_t>(l.kernel_taps) *
                                        static_cast<std::size_t>(buffers_[static_cast<std::size_t>(l.sources[0])].channels));
      }
      if (l.mode == Mode::TapColumns) {  // one chunk of frames at a time (run_tap_columns())
        std::size_t source_rows = 0;
        for (int s : l.sources) {
          const std::size_t positions = static_cast<std::size_t>(buffers_[static_cast<std::size_t>(s)].positions) *
                                        static_cast<std::size_t>(std::min(capacity, kTapColumnFrames));
          rows = std::max(rows, positions);
          source_rows += positions;
        }
        tap_sums = std::max(tap_sums, source_rows * static_cast<std::size_t>(l.tap_stride));
      }
    }
    std::size_t sparse_values = 0, sparse_rows = 0;
    const std::size_t sparse_frames = static_cast<std::size_t>(std::min(capacity, kSparseMaxFrames));
    for (const PackedLayer& l : layers_) {
      if (l.mode == Mode::Im2col) continue;
      std::size_t values = 0, source_rows = 0;
      for (int s : l.sources) {
        const BufferSpec& in = buffers_[static_cast<std::size_t>(s)];
        source_rows += static_cast<std::size_t>(in.positions) * sparse_frames;
        values += static_cast<std::size_t>(in.positions) * sparse_frames * static_cast<std::size_t>(in.channels);
      }
      sparse_values = std::max(sparse_values, values);
      sparse_rows = std::max(sparse_rows, source_rows);
    }
    std::size_t input_rows = 0, output_rows = 0;
    for (const PackedLayer& l : layers_) {
      if (!l.weights.fixed16()) continue;
      std::size_t rows_in = 0;
      for (int s : l.sources) rows_in += static_cast<std::size_t>(buffers_[static_cast<std::size_t>(s)].positions);
      input_rows = std::max(input_rows, rows_in * static_cast<std::size_t>(capacity));
      output_rows = std::max(output_rows, static_cast<std::size_t>(buffers_[static_cast<std::size_t>(l.out_buffer)].positions) *
                                              static_cast<std::size_t>(capacity));
    }
    ws.input_sums.resize(input_rows);
    ws.output_sums.resize(output_rows);
    ws.sparse_index.resize(sparse_values);
    ws.sparse_value.resize(sparse_values);
    ws.sparse_rows.resize(sparse_rows);
    ws.tap_rows.resize(rows);
    ws.x_rows.resize(rows);
    ws.y_rows.resize(rows);
    ws.columns.resize(columns);
    ws.tap_sums.resize(tap_sums);
    ws.members.resize(static_cast<std::size_t>(team_size - 1));
    for (auto& m : ws.members) {
      m.x_rows.resize(rows);
      m.y_rows.resize(rows);
      m.tap_rows.resize(rows);
    }
    return ws;
  }

  /// @brief One frame: `input` 2x5x5 (channel, row, column) -> `output` 1x5x5 in (-1, 1).
  /// Returns Status::NonFinite (output untouched) for a NaN or infinite input or result,
  /// Status::SizeMismatch for a workspace of another network or too small, or for a network that
  /// reads extra input planes (use the pointer form); never allocates.
  GLOVEPOSE_REALTIME Status forward(const std::array<float, kUNetInputs>& input, std::array<float, kUNetOutputs>& output,
                                    Workspace& ws) const noexcept {
    if (extra_inputs_ != 0) return Status::SizeMismatch;
    return forward(input.data(), output.data(), 1, ws);
  }

  /// @brief `frames` frames (each input_values() in, (2 + extra_inputs()) x 5 x 5, and 1x5x5 out,
  /// PyTorch's NCHW order), frames <= capacity.
  GLOVEPOSE_REALTIME Status forward(const float* input, float* output, int frames, Workspace& ws) const noexcept {
    return forward(input, output, frames, ws, nullptr);
  }

  /// @brief forward() with every large layer's products shared by the members of `team`: output
  /// channels split at column-panel boundaries (each member streams its own part of the weights),
  /// or, for a layer of one panel, the rows. Each output is computed by the same kernel calls as
  /// without a team: the results are identical. Status::SizeMismatch for a workspace made for a
  /// smaller team.
  GLOVEPOSE_REALTIME Status forward(const float* input, float* output, int frames, Workspace& ws, core::Team& team) const noexcept {
    if (static_cast<std::size_t>(team.size()) > ws.members.size() + 1) return Status::SizeMismatch;
    return forward(input, output, frames, ws, &team);
  }

 private:
  Status forward(const float* input, float* output, int frames, Workspace& ws, core::Team* team) const noexcept {
    if (frames < 1 || frames > ws.capacity_ || ws.width_ != width_ || ws.extra_inputs_ != extra_inputs_ ||
        ws.buffers.size() != buffers_.size())
      return Status::SizeMismatch;
    for (long i = 0; i < static_cast<long>(frames) * input_values(); ++i)
      if (!std::isfinite(input[i])) return Status::NonFinite;
    to_position_major(input, frames, kUNetMapPlanes + extra_inputs_, kUNetGridPositions, ws.buffers[0].data());
    const UNetRunner<Backend> runner(buffers_);
    for (const PackedLayer& layer : layers_) runner.run(layer, frames, ws, team);
    const float* out = ws.buffers.back().data();
    for (long i = 0; i < static_cast<long>(frames) * kUNetOutputs; ++i)
      if (!std::isfinite(out[i])) return Status::NonFinite;  // an overflow inside the network: output untouched
    from_position_major(out, frames, kUNetGridPositions, output);
    return Status::Ok;
  }

 public:
  /// @brief Many frames for evaluation: splits them over `threads` threads, each with its own
  /// workspace, in chunks of `chunk` frames. Set-up code: allocates; throws glovepose::Error naming
  /// the first frame with a non-finite input.
  void forward_batch(const float* input, float* output, long frames, int threads = 1, int chunk = kSparseMaxFrames) const {
    forward_batch_of(*this, "UNet", input_values(), kUNetOutputs, input, output, frames, threads, chunk);
  }

 private:
  // Extra input planes from enc1.weight [w, 2 + E, 5, 5]; 0 when it is missing or malformed, which
  // check_tensor_names() then reports.
  static int extra_planes_of(const TensorMap& tensors) {
    const auto it = tensors.find("enc1.weight");
    if (it == tensors.end() || it->second.shape.size() != 4 || it->second.shape[1] < 2) return 0;
    const std::int64_t extra = it->second.shape[1] - 2;
    if (extra > kMaxExtraInputs)
      throw Error("UNet: tensor 'enc1.weight' reads " + std::to_string(it->second.shape[1]) +
                  " input planes, expected 2 stretch maps and at most " + std::to_string(kMaxExtraInputs) + " extra inputs");
    return static_cast<int>(extra);
  }

  static void check_tensor_names(const TensorMap& tensors, int width, int extra_inputs) {
    check_tensors(tensors, expected_tensors(width, extra_inputs), "UNet",
                  "a width-" + std::to_string(width) + " U-Net" +
                      (extra_inputs > 0 ? " reading " + std::to_string(extra_inputs) + " extra input planes" : std::string()));
  }

  friend class UNetDiagnostics;
  using BufferSpec = UNetBuffer;
  using PackedLayer = UNetPackedLayer;
  using PackedTap = UNetTap;
  using Mode = UNetMode;

  UNet() = default;

  int width_ = 0;
  int extra_inputs_ = 0;
  WeightStorage storage_ = WeightStorage::F32;
  std::vector<BufferSpec> buffers_;
  std::vector<PackedLayer> layers_;
  std::size_t parameter_count_ = 0;
};

}  // namespace glovepose::nn
