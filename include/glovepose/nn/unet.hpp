/// @file unet.hpp
/// @brief The paper's U-Net (Table 6; our reading in weights_format.md): 2x5x5 stretch maps ->
/// 1x5x5 pose map, on fixed grids. A glove's E inputs that are not on the maps come in as E more
/// input planes of constant value ((2 + E) x 5 x 5; only enc1 reads them).
///
/// Load time: every batch norm is folded into the convolution before it, each layer's weights are
/// packed per useful tap (conv_plan.hpp; taps that only meet zero padding are dropped), output
/// channels are padded to the SIMD width, and the weights are stored as F32 (exact) or in 16 bits
/// (F16, BF16, Fixed16: half the bytes to stream at batch 1; widened to F32 in registers). The
/// loaded model is immutable and may be shared by any number of threads; each stream owns a Workspace.
///
/// Activations live as [position][frame][channel]: a layer is, per useful tap and per skip
/// source, one matrix product of the (frame x channel) rows it joins with the tap's weight block,
/// which is also how concatenation costs nothing (each source is its own block of input channels).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <exception>
#include <mutex>
#include <numeric>
#include <thread>
#include <vector>

#include "../config.hpp"
#include "../status.hpp"
#include "batching.hpp"
#include "conv_plan.hpp"
#include "fixed16.hpp"
#include "half.hpp"
#include "kernels/scalar.hpp"
#include "kernels/simd.hpp"
#include "kernels/sparse_row.hpp"
#include "packed_weights.hpp"
#include "team.hpp"
#include "tensor.hpp"
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
/// @brief Frames per chunk of the one-output-channel layer: its (row, tap) sums, 25 x 2 x 32 floats a
/// frame (6.4 KB), stay in the L2 between the product that writes them and the sums that read them.
inline constexpr int kTapColumnFrames = 16;

/// @brief Values in one network input for a glove without extra inputs (2 x 5 x 5, channel-major);
/// UNet::input_values() in general.
inline constexpr int kUNetInputs = 50;
/// @brief Most extra input planes a network reads (a glove has at most 256 inputs).
inline constexpr int kMaxExtraInputs = 256;
/// @brief Values in one network output (1 x 5 x 5).
inline constexpr int kUNetOutputs = 25;

/// @brief The U-Net.
/// @tparam Backend kernels::SimdBackend (default) or kernels::ScalarBackend (the reference).
template <typename Backend = kernels::SimdBackend>
class UNet {
 public:
  /// @brief Builds the network of width `width` from PyTorch-named tensors (weights_format.md); the
  /// number of extra input planes is enc1.weight's input channels less 2. Throws glovepose::Error
  /// naming the tensor when one is missing, extra, of the wrong shape, or not finite.
  static UNet from_tensors(const TensorMap& tensors, int width, double bn_eps = 1e-5,
                           WeightStorage storage = WeightStorage::F32) {
    if (width < 1 || width > kMaxWidth)
      throw Error("UNet: width " + std::to_string(width) + ", expected 1.." + std::to_string(kMaxWidth));
    if (!(bn_eps > 0.0)) throw Error("UNet: bn_eps must be > 0");
    UNet net;
    net.width_ = width;
    net.storage_ = storage;
    net.extra_inputs_ = extra_planes_of(tensors);
    net.define_buffers();
    const std::vector<LayerSpec> specs = unet_layers(width);
    check_tensor_names(tensors, width, net.extra_inputs_);
    for (const LayerSpec& spec : specs) net.layers_.push_back(net.pack(spec, tensors, bn_eps));
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
  int input_values() const noexcept { return (2 + extra_inputs_) * 25; }
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
    for (const PackedLayer& l : layers_)
      n += l.weights.bytes();
    return n;
  }

  /// @brief Per-stream activations and scratch for batches of up to `capacity` frames.
  class Workspace {
   public:
    /// @brief Largest batch this workspace serves.
    int capacity() const noexcept { return capacity_; }

   private:
    friend class UNet;
    int capacity_ = 0;
    int width_ = 0;  // the network it was made for: buffer sizes follow from width, planes and capacity
    int extra_inputs_ = 0;
    std::vector<AlignedVector<float>> buffers;
    std::vector<const float*> x_rows;
    std::vector<float*> y_rows;
    AlignedVector<float> columns;      // Im2col: receptive fields, one row per (position, frame)
    std::vector<int> sparse_index;     // Taps, small batches: nonzero entries of the sources' rows
    std::vector<float> sparse_value;
    std::vector<kernels::SparseRow> sparse_rows;  // per (source, position, frame)
    std::vector<kernels::SparseRow> tap_rows;     // the rows one product joins
    AlignedVector<float> tap_sums;     // TapColumns: per (source, position, frame of a chunk) one sum per tap
    std::vector<float> input_sums;     // Fixed16: sum of each source row (per source, position, frame)
    std::vector<float> output_sums;    // Fixed16: sum of the inputs each output row met
    // Team members 1.. (forward with a Team): each its own row lists for its share of a product.
    struct MemberRows {
      std::vector<const float*> x_rows;
      std::vector<float*> y_rows;
      std::vector<kernels::SparseRow> tap_rows;
    };
    std::vector<MemberRows> members;
  };

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
      ws.buffers.emplace_back(static_cast<std::size_t>(b.positions) * static_cast<std::size_t>(capacity) *
                                  static_cast<std::size_t>(b.stride),
                              0.0f);
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
  GLOVEPOSE_REALTIME Status forward(const float* input, float* output, int frames, Workspace& ws, Team& team) const noexcept {
    if (static_cast<std::size_t>(team.size()) > ws.members.size() + 1) return Status::SizeMismatch;
    return forward(input, output, frames, ws, &team);
  }

 private:
  Status forward(const float* input, float* output, int frames, Workspace& ws, Team* team) const noexcept {
    if (frames < 1 || frames > ws.capacity_ || ws.width_ != width_ || ws.extra_inputs_ != extra_inputs_ ||
        ws.buffers.size() != buffers_.size())
      return Status::SizeMismatch;
    const int values = input_values(), planes = 2 + extra_inputs_;
    for (long i = 0; i < static_cast<long>(frames) * values; ++i)
      if (!std::isfinite(input[i])) return Status::NonFinite;
    // NCHW -> [position][frame][channel]
    float* in = ws.buffers[0].data();
    for (int f = 0; f < frames; ++f)
      for (int c = 0; c < planes; ++c)
        for (int p = 0; p < 25; ++p) in[(p * frames + f) * planes + c] = input[f * values + c * 25 + p];
    for (const PackedLayer& layer : layers_) run(layer, frames, ws, team);
    const float* out = ws.buffers.back().data();
    for (long i = 0; i < static_cast<long>(frames) * kUNetOutputs; ++i)
      if (!std::isfinite(out[i])) return Status::NonFinite;  // an overflow inside the network: output untouched
    for (int f = 0; f < frames; ++f)
      for (int p = 0; p < 25; ++p) output[f * kUNetOutputs + p] = out[p * frames + f];
    return Status::Ok;
  }

 public:

  /// @brief Many frames for evaluation: splits them over `threads` threads, each with its own
  /// workspace, in chunks of `chunk` frames. Set-up code: allocates; throws glovepose::Error naming
  /// the first frame with a non-finite input.
  void forward_batch(const float* input, float* output, long frames, int threads = 1, int chunk = kSparseMaxFrames) const {
    if (frames <= 0) return;
    if (threads < 1 || chunk < 1) throw Error("UNet::forward_batch: threads and chunk must be >= 1");
    const long values = input_values();
    for (long i = 0; i < frames * values; ++i)
      if (!std::isfinite(input[i])) throw Error("UNet::forward_batch: frame " + std::to_string(i / values) + " has a non-finite input");
    chunk = std::min(chunk, kMaxBatch);
    run_frame_shares(frames, threads, [&](long begin, long end) {
      Workspace ws = make_workspace(chunk);
      for (long f = begin; f < end; f += chunk) {
        const int n = static_cast<int>(std::min<long>(chunk, end - f));
        if (forward(input + f * values, output + f * kUNetOutputs, n, ws) != Status::Ok)
          throw Error("UNet::forward_batch: frames " + std::to_string(f) + ".." + std::to_string(f + n - 1) +
                      " overflowed inside the network (non-finite result)");
      }
    });
  }

  /// @brief For the last `frames`-frame forward on `ws`: the fraction of each hidden activation
  /// buffer (e1, e2, e3, e4, d1, d2, d3, after their ReLU; real channels only) that is exactly
  /// zero. Forwards of up to kSparseMaxFrames frames skip those entries (kernels/sparse_row.hpp),
  /// so these fractions set how much of the weights a frame reads. Diagnostic, set-up code: throws
  /// glovepose::Error for a workspace of another network or `frames` outside 1..capacity.
  std::array<double, kUNetBufferCount - 2> zero_fractions(const Workspace& ws, int frames) const {
    if (ws.width_ != width_ || ws.buffers.size() != buffers_.size())
      throw Error("UNet::zero_fractions: workspace of a width-" + std::to_string(ws.width_) + " network, expected width " + std::to_string(width_));
    if (frames < 1 || frames > ws.capacity_)
      throw Error("UNet::zero_fractions: " + std::to_string(frames) + " frames, expected 1.." + std::to_string(ws.capacity_));
    std::array<double, kUNetBufferCount - 2> fractions{};
    for (int id = 1; id + 1 < kUNetBufferCount; ++id) {
      const BufferSpec& spec = buffers_[static_cast<std::size_t>(id)];
      const float* values = ws.buffers[static_cast<std::size_t>(id)].data();
      const long rows = static_cast<long>(spec.positions) * frames;
      long zeros = 0;
      for (long r = 0; r < rows; ++r)
        zeros += std::count(values + r * spec.stride, values + r * spec.stride + spec.channels, 0.0f);
      fractions[static_cast<std::size_t>(id - 1)] = static_cast<double>(zeros) / static_cast<double>(rows * spec.channels);
    }
    return fractions;
  }

  /// @brief For the last forward on `ws`, which must have been of a single frame: the bytes of
  /// packed weights that forward read (channel padding included). The row products (kernels/
  /// sparse_row.hpp) read, per tap and source, the weight rows of the channels that are nonzero at
  /// one or more of the input positions the tap joins; the first layer the rows of the taps that
  /// meet input; the last, per source, the rows of its nonzero channels. At batch 1 these bytes come
  /// from the L3 every frame (the w = 64 weights do not fit a core's L2), so they bound the forward's
  /// time from below: docs/performance.md. Diagnostic, set-up code: throws glovepose::Error for a
  /// workspace of another network.
  std::size_t weight_bytes_read(const Workspace& ws) const {
    if (ws.width_ != width_ || ws.buffers.size() != buffers_.size())
      throw Error("UNet::weight_bytes_read: workspace of a width-" + std::to_string(ws.width_) + " network, expected width " +
                  std::to_string(width_));
    // Rows of a block whose input channels of buffer `id` are nonzero at one or more of `positions`
    // (frame 0 of a single-frame forward).
    const auto nonzero_rows = [&](int id, const std::vector<int>& positions) {
      const BufferSpec& spec = buffers_[static_cast<std::size_t>(id)];
      const float* values = ws.buffers[static_cast<std::size_t>(id)].data();
      std::size_t rows = 0;
      for (int c = 0; c < spec.channels; ++c)
        rows += std::any_of(positions.begin(), positions.end(),
                            [&](int p) { return values[static_cast<long>(p) * spec.stride + c] != 0.0f; });
      return rows;
    };
    std::size_t bytes = 0;
    for (const PackedLayer& l : layers_) {
      // A layer keeps one storage: F32, or 16 bits (which leave w32 empty).
      const std::size_t weight_size = l.weights.weight_size();
      const std::size_t out_stride = static_cast<std::size_t>(buffers_[static_cast<std::size_t>(l.out_buffer)].stride);
      if (l.mode == Mode::Im2col) {  // every row of a tap that meets input, whatever its value
        std::vector<int> rows(l.receptive_rows);
        std::sort(rows.begin(), rows.end());
        bytes += static_cast<std::size_t>(std::unique(rows.begin(), rows.end()) - rows.begin()) * out_stride * weight_size;
      } else if (l.mode == Mode::TapColumns) {  // per source, its nonzero channels anywhere; the taps are the columns
        for (int id : l.sources) {
          std::vector<int> everywhere(static_cast<std::size_t>(buffers_[static_cast<std::size_t>(id)].positions));
          std::iota(everywhere.begin(), everywhere.end(), 0);
          bytes += nonzero_rows(id, everywhere) * static_cast<std::size_t>(l.tap_stride) * weight_size;
        }
      } else {
        for (const PackedTap& tap : l.taps)
          for (int id : l.sources) bytes += nonzero_rows(id, tap.in_positions) * out_stride * weight_size;
      }
    }
    return bytes;
  }

 private:
  struct BufferSpec {
    int channels;
    int stride;  // channels padded to the SIMD width (the network input is never padded)
    int size;    // grid side
    int positions;
  };

  using LayerSpec = UNetLayer;

  struct PackedTap {
    std::vector<int> out_positions, in_positions;
  };

  // How a layer's products are organised (see run()).
  enum class Mode : unsigned char {
    Taps,    // per useful tap and source: one product of the rows it joins with the tap's block
    Im2col,  // few input channels: gather each output's whole receptive field, one product with K = taps x channels
    // One output channel: per input row, one product with the kernel's taps as columns (a sum per
    // tap); each output then adds the (input row, tap) sums it meets. Replaces a short dot product
    // per (output, tap, source), whose horizontal sums and pointer set-up cost more than the FMAs.
    TapColumns,
  };

  struct PackedLayer {
    std::vector<PackedTap> taps;
    std::vector<int> sources;
    int out_buffer = 0;
    Mode mode = Mode::Taps;
    int kernel_taps = 0;                            // kernel * kernel (Im2col row length = kernel_taps * channels)
    std::vector<int> receptive;                     // Im2col: [out position][tap] -> input position or -1
    // Im2col, small batches: per out position (from receptive_first[p]) the rows tap * channels + c
    // of the taps that meet input, ascending, and the (input position, channel) each reads.
    std::vector<int> receptive_first, receptive_rows;
    std::vector<std::pair<int, int>> receptive_inputs;
    std::vector<std::vector<std::pair<int, int>>> terms;  // TapColumns: [out position] -> (tap, input position)
    int tap_stride = 0;                             // TapColumns: taps padded to the SIMD width
    Activation activation = Activation::Relu;
    AlignedVector<float> bias;   // padded output channels
    // per (tap, source): in channels x padded out channels, in column panels; Fixed16 in Taps layers only
    PackedWeights weights;
    std::vector<std::size_t> block;  // offset of (tap, source) block
    std::size_t stored_weights = 0;
  };

  void define_buffers() {
    for (int id = 0; id < kUNetBufferCount; ++id) {
      const int c = unet_buffer_channels(id, width_, extra_inputs_);
      // BF16 and Fixed16 weights come in pairs of vectors (kernels/weight_load.hpp): whole pairs of output channels.
      const bool paired = paired_storage(storage_);
      const int multiple = paired ? 2 * Backend::lanes : Backend::lanes;
      const int stride = (id == 0 || id == 8) ? c : round_up(c, multiple);
      buffers_.push_back({c, stride, unet_buffer_size(id), unet_buffer_size(id) * unet_buffer_size(id)});
    }
  }

  // Extra input planes from enc1.weight [w, 2 + E, 5, 5]; 0 when it is missing or malformed, which
  // check_tensor_names() then reports.
  static int extra_planes_of(const TensorMap& tensors) {
    const auto it = tensors.find("enc1.weight");
    if (it == tensors.end() || it->second.shape.size() != 4 || it->second.shape[1] < 2) return 0;
    const std::int64_t extra = it->second.shape[1] - 2;
    if (extra > kMaxExtraInputs)
      throw Error("UNet: tensor 'enc1.weight' reads " + std::to_string(it->second.shape[1]) + " input planes, expected 2 stretch maps and at most " +
                  std::to_string(kMaxExtraInputs) + " extra inputs");
    return static_cast<int>(extra);
  }

  static void check_tensor_names(const TensorMap& tensors, int width, int extra_inputs) {
    check_tensors(tensors, expected_tensors(width, extra_inputs), "UNet",
                  "a width-" + std::to_string(width) + " U-Net" +
                      (extra_inputs > 0 ? " reading " + std::to_string(extra_inputs) + " extra input planes" : std::string()));
  }

  PackedLayer pack(const LayerSpec& spec, const TensorMap& tensors, double eps) const {
    spec.geometry.validate(spec.conv);
    const BufferSpec& out = buffers_[static_cast<std::size_t>(spec.out_buffer)];
    const int cin = spec.in_channels(width_, extra_inputs_), cout = spec.out_channels, k = spec.geometry.kernel;
    PackedLayer layer;
    layer.sources = spec.sources;
    layer.out_buffer = spec.out_buffer;
    layer.activation = spec.activation;
    const int first_channels = buffers_[static_cast<std::size_t>(spec.sources[0])].channels;
    layer.mode = cout == 1 ? Mode::TapColumns : (spec.sources.size() == 1 && first_channels * k * k <= 64 ? Mode::Im2col : Mode::Taps);
    layer.kernel_taps = k * k;

    // Fold BN (inference) into per-output-channel scale and shift, in double.
    std::vector<double> scale(static_cast<std::size_t>(cout), 1.0), shift(static_cast<std::size_t>(cout), 0.0);
    const std::vector<float>& bias = tensors.at(spec.conv + ".bias").values;
    for (int o = 0; o < cout; ++o) shift[static_cast<std::size_t>(o)] = bias[static_cast<std::size_t>(o)];
    if (!spec.bn.empty()) {
      const auto& gamma = tensors.at(spec.bn + ".weight").values;
      const auto& beta = tensors.at(spec.bn + ".bias").values;
      const auto& mean = tensors.at(spec.bn + ".running_mean").values;
      const auto& var = tensors.at(spec.bn + ".running_var").values;
      for (std::size_t o = 0; o < static_cast<std::size_t>(cout); ++o) {
        if (!(var[o] >= 0.0f))
          throw Error("UNet: tensor '" + spec.bn + ".running_var' has a negative variance at channel " + std::to_string(o));
        scale[o] = gamma[o] / std::sqrt(static_cast<double>(var[o]) + eps);
        shift[o] = (shift[o] - mean[o]) * scale[o] + beta[o];
      }
    }
    layer.bias.assign(static_cast<std::size_t>(out.stride), 0.0f);
    for (int o = 0; o < cout; ++o) layer.bias[static_cast<std::size_t>(o)] = static_cast<float>(shift[static_cast<std::size_t>(o)]);

    // Pack the useful taps: block (tap, source) = source channels x ldw, BN scale applied.
    const std::vector<float>& weight = tensors.at(spec.conv + ".weight").values;
    const auto w_at = [&](int ci, int co, int tap) -> double {
      const std::size_t kk = static_cast<std::size_t>(k) * static_cast<std::size_t>(k);
      const std::size_t idx = spec.geometry.transposed
                                  ? (static_cast<std::size_t>(ci) * static_cast<std::size_t>(cout) + static_cast<std::size_t>(co)) * kk
                                  : (static_cast<std::size_t>(co) * static_cast<std::size_t>(cin) + static_cast<std::size_t>(ci)) * kk;
      return weight[idx + static_cast<std::size_t>(tap)];
    };
    std::vector<float> packed;
    const std::vector<TapPairs> plan = plan_taps(spec.geometry);
    // Fixed16 codes the row products only; the first and last layers (few weights) stay F32 (the
    // first runs as Taps when it reads extra input planes).
    const bool fixed = storage_ == WeightStorage::Fixed16 && layer.mode == Mode::Taps && spec.sources[0] != 0;
    const bool paired = storage_ == WeightStorage::BF16 || fixed;
    // TapColumns: the taps are the product's columns, padded to whole pairs of vectors for every
    // storage (the pair layout needs them; the same stride keeps 16-bit layers half an F32 one).
    if (layer.mode == Mode::TapColumns) layer.tap_stride = round_up(layer.kernel_taps, 2 * Backend::lanes);
    const int columns = layer.mode == Mode::TapColumns ? layer.tap_stride : out.stride;
    // Where W(row, column) of a (rows x columns) product block goes.
    const auto slot = [&](int row, int co, int rows) {
      const int column = paired ? kernels::paired_slot(co, Backend::lanes) : co;
      return static_cast<std::size_t>(kernels::panel_index(row, column, rows, columns, Backend::panel));
    };
    std::vector<int> column_of;  // Fixed16: the output channel of each packed slot (padding included)
    if (layer.mode == Mode::Im2col) {  // one dense (taps x channels) x stride block over the whole kernel
      const int cs = first_channels, rows = layer.kernel_taps * cs;
      packed.assign(static_cast<std::size_t>(rows) * static_cast<std::size_t>(out.stride), 0.0f);
      for (int tap = 0; tap < layer.kernel_taps; ++tap)
        for (int ci = 0; ci < cs; ++ci)
          for (int co = 0; co < cout; ++co)
            packed[slot(tap * cs + ci, co, rows)] =
                static_cast<float>(w_at(ci, co, tap) * scale[static_cast<std::size_t>(co)]);
      layer.receptive.assign(static_cast<std::size_t>(out.positions * layer.kernel_taps), -1);
      for (const TapPairs& t : plan)
        for (std::size_t j = 0; j < t.out_positions.size(); ++j)
          layer.receptive[static_cast<std::size_t>(t.out_positions[j] * layer.kernel_taps + t.tap)] = t.in_positions[j];
      for (int p = 0; p < out.positions; ++p) {
        layer.receptive_first.push_back(static_cast<int>(layer.receptive_rows.size()));
        for (int tap = 0; tap < layer.kernel_taps; ++tap) {
          const int source = layer.receptive[static_cast<std::size_t>(p * layer.kernel_taps + tap)];
          for (int ci = 0; source >= 0 && ci < cs; ++ci) {
            layer.receptive_rows.push_back(tap * cs + ci);
            layer.receptive_inputs.push_back({source, ci});
          }
        }
      }
      layer.receptive_first.push_back(static_cast<int>(layer.receptive_rows.size()));
      layer.stored_weights = plan.size() * static_cast<std::size_t>(cs) * static_cast<std::size_t>(cout);  // useful taps only
      layer.block.push_back(0);
    }
    if (layer.mode == Mode::TapColumns) {  // per source one channels x taps block; taps no output meets stay zero
      int channel_base = 0;
      for (int source : spec.sources) {
        const int cs = buffers_[static_cast<std::size_t>(source)].channels;
        const std::size_t base = packed.size();
        layer.block.push_back(base);
        packed.resize(base + static_cast<std::size_t>(cs) * static_cast<std::size_t>(columns), 0.0f);
        for (const TapPairs& t : plan)
          for (int ci = 0; ci < cs; ++ci) packed[base + slot(ci, t.tap, cs)] = static_cast<float>(w_at(channel_base + ci, 0, t.tap) * scale[0]);
        layer.stored_weights += plan.size() * static_cast<std::size_t>(cs);
        channel_base += cs;
      }
      layer.terms.resize(static_cast<std::size_t>(out.positions));
      for (const TapPairs& t : plan)
        for (std::size_t j = 0; j < t.out_positions.size(); ++j)
          layer.terms[static_cast<std::size_t>(t.out_positions[j])].push_back({t.tap, t.in_positions[j]});
    }
    for (const TapPairs& t : plan) {
      if (layer.mode != Mode::Taps) break;
      layer.taps.push_back({t.out_positions, t.in_positions});
      int channel_base = 0;
      for (int source : spec.sources) {
        const int cs = buffers_[static_cast<std::size_t>(source)].channels;
        // cs x stride, in the backend's column panels (kernels::panel_index)
        const std::size_t base = packed.size();
        layer.block.push_back(base);
        packed.resize(base + static_cast<std::size_t>(cs) * static_cast<std::size_t>(out.stride), 0.0f);
        for (int ci = 0; ci < cs; ++ci)
          for (int co = 0; co < cout; ++co)
            packed[base + slot(ci, co, cs)] = static_cast<float>(w_at(channel_base + ci, co, t.tap) * scale[static_cast<std::size_t>(co)]);
        if (fixed) {
          column_of.resize(packed.size());
          for (int ci = 0; ci < cs; ++ci)
            for (int co = 0; co < out.stride; ++co) column_of[base + slot(ci, co, cs)] = co;
        }
        layer.stored_weights += static_cast<std::size_t>(cs) * static_cast<std::size_t>(cout);
        channel_base += cs;
      }
    }
    // Folding can scale weights far beyond what the file held (a tiny running variance); refuse what
    // the chosen storage cannot represent rather than compute with infinities.
    for (float v : layer.bias)
      if (!std::isfinite(v)) throw Error("UNet: layer " + spec.conv + " has a non-finite folded bias");
    const WeightStorage stored = fixed ? WeightStorage::Fixed16 : (storage_ == WeightStorage::Fixed16 ? WeightStorage::F32 : storage_);
    layer.weights = encode_weights(packed, stored, column_of, out.stride,
                                   "UNet: layer " + spec.conv + (spec.bn.empty() ? "" : " with " + spec.bn + " folded in"));
    return layer;
  }

  // One team member's part of a layer's products: its share of the output column panels of every
  // row or, when the layer has fewer panels than members, its share of the output positions (all
  // the taps' rows that add into them: no two members write one row). Either way each output
  // element gets the same kernel calls, in the same order, as without a team.
  struct Share {
    int member = 0, members = 1;
  };

  // Every (tap, source) product of a Taps layer, or `share` of each; the sources are compacted
  // first (compact_sources) for small batches.
  template <typename W>
  void run_tap_share(const PackedLayer& layer, const W* weights, int frames, Workspace& ws, const std::size_t (&first_row)[2],
                     Share share = {}) const noexcept {
    const BufferSpec& out_spec = buffers_[static_cast<std::size_t>(layer.out_buffer)];
    float* out = ws.buffers[static_cast<std::size_t>(layer.out_buffer)].data();
    const std::size_t sources = layer.sources.size();
    const bool sparse = frames <= kSparseMaxFrames;
    const int panels = (out_spec.stride + Backend::panel - 1) / Backend::panel;
    const bool split_columns = panels >= share.members;
    // Dense products block their rows by count (gemm_rows): splitting rows would change the blocks.
    if (!split_columns && !sparse && share.member > 0) return;
    const bool split_rows = !split_columns && sparse;
    const int column_begin = split_columns ? std::min(out_spec.stride, panels * share.member / share.members * Backend::panel) : 0;
    const int column_end = split_columns ? std::min(out_spec.stride, panels * (share.member + 1) / share.members * Backend::panel)
                                         : out_spec.stride;
    const int position_begin = split_rows ? out_spec.positions * share.member / share.members : 0;
    const int position_end = split_rows ? out_spec.positions * (share.member + 1) / share.members : out_spec.positions;
    if (column_end <= column_begin || position_end <= position_begin) return;
    const bool own_rows = share.member > 0;
    const float** x_rows = own_rows ? ws.members[static_cast<std::size_t>(share.member - 1)].x_rows.data() : ws.x_rows.data();
    float** y_rows = own_rows ? ws.members[static_cast<std::size_t>(share.member - 1)].y_rows.data() : ws.y_rows.data();
    kernels::SparseRow* tap_rows = own_rows ? ws.members[static_cast<std::size_t>(share.member - 1)].tap_rows.data() : ws.tap_rows.data();
    for (std::size_t t = 0; t < layer.taps.size(); ++t) {
      const PackedTap& tap = layer.taps[t];
      for (std::size_t s = 0; s < sources; ++s) {
        const int id = layer.sources[s];
        const BufferSpec& in_spec = buffers_[static_cast<std::size_t>(id)];
        const float* in = ws.buffers[static_cast<std::size_t>(id)].data();
        int rows = 0;
        for (std::size_t j = 0; j < tap.out_positions.size(); ++j) {
          if (tap.out_positions[j] < position_begin || tap.out_positions[j] >= position_end) continue;
          for (int f = 0; f < frames; ++f, ++rows) {
            const long in_row = static_cast<long>(tap.in_positions[j]) * frames + f;
            if (sparse) tap_rows[rows] = ws.sparse_rows[first_row[s] + static_cast<std::size_t>(in_row)];
            else x_rows[rows] = in + in_row * in_spec.stride;
            y_rows[rows] = out + (static_cast<long>(tap.out_positions[j]) * frames + f) * out_spec.stride + column_begin;
          }
        }
        // The block's column panels from column_begin on: a panel boundary, so the kernel splits
        // its columns into the same blocks as for the whole width.
        const W* block = weights + layer.block[t * sources + s] + static_cast<long>(in_spec.channels) * column_begin;
        if (!sparse) Backend::gemm_rows(x_rows, y_rows, rows, block, in_spec.channels, column_end - column_begin);
        else Backend::gemm_sparse_rows(tap_rows, y_rows, rows, block, in_spec.channels, column_end - column_begin);
      }
    }
  }

  // A Taps layer's products, shared by the team's members when there is one.
  template <typename W>
  void run_taps(const PackedLayer& layer, const W* weights, int frames, Workspace& ws, Team* team) const noexcept {
    std::size_t first_row[2] = {0, 0};  // unet_layers(): at most two (concatenated) sources
    if (frames <= kSparseMaxFrames) compact_sources(layer, frames, ws, first_row);
    if (team == nullptr || team->size() == 1) {
      run_tap_share(layer, weights, frames, ws, first_row);
      return;
    }
    auto share = [&](int member) noexcept { run_tap_share(layer, weights, frames, ws, first_row, Share{member, team->size()}); };
    team->run(share);
  }

  // Fixed16: out = scale * (sum of level * x - kFixed16Offset * sum of x) + bias, per output row,
  // where sum of x runs over every input row the output met (fixed16.hpp).
  void finish_fixed16(const PackedLayer& layer, int frames, Workspace& ws) const noexcept {
    const BufferSpec& out_spec = buffers_[static_cast<std::size_t>(layer.out_buffer)];
    float* out = ws.buffers[static_cast<std::size_t>(layer.out_buffer)].data();
    const int out_rows = out_spec.positions * frames;
    float* met = ws.output_sums.data();
    std::fill(met, met + out_rows, 0.0f);
    float* input_sum = ws.input_sums.data();
    std::size_t first = 0;
    for (std::size_t s = 0; s < layer.sources.size(); ++s) {
      const BufferSpec& in_spec = buffers_[static_cast<std::size_t>(layer.sources[s])];
      const float* in = ws.buffers[static_cast<std::size_t>(layer.sources[s])].data();
      const int in_rows = in_spec.positions * frames;
      for (int r = 0; r < in_rows; ++r)
        input_sum[first + static_cast<std::size_t>(r)] = Backend::sum(in + static_cast<long>(r) * in_spec.stride, in_spec.channels);
      for (const PackedTap& tap : layer.taps)
        for (std::size_t j = 0; j < tap.out_positions.size(); ++j)
          for (int f = 0; f < frames; ++f)
            met[tap.out_positions[j] * frames + f] += input_sum[first + static_cast<std::size_t>(tap.in_positions[j] * frames + f)];
      first += static_cast<std::size_t>(in_rows);
    }
    const float* scale = layer.weights.fixed_scale.data();
    const float* bias = layer.bias.data();
    for (int r = 0; r < out_rows; ++r) {
      float* row = out + static_cast<long>(r) * out_spec.stride;
      finish_fixed16_row(row, out_spec.stride, scale, bias, met[r]);
    }
  }

  // The nonzero entries of every row of the layer's sources, once per layer (many taps share a row).
  void compact_sources(const PackedLayer& layer, int frames, Workspace& ws, std::size_t (&first_row)[2]) const noexcept {
    std::size_t row = 0, value = 0;
    for (std::size_t s = 0; s < layer.sources.size() && s < 2; ++s) {
      const BufferSpec& in_spec = buffers_[static_cast<std::size_t>(layer.sources[s])];
      const float* in = ws.buffers[static_cast<std::size_t>(layer.sources[s])].data();
      first_row[s] = row;
      for (long r = 0; r < static_cast<long>(in_spec.positions) * frames; ++r, ++row) {
        int* index = ws.sparse_index.data() + value;
        float* values = ws.sparse_value.data() + value;
        const int count = Backend::compact(in + r * in_spec.stride, in_spec.channels, index, values);
        ws.sparse_rows[row] = {index, values, count};
        value += static_cast<std::size_t>(in_spec.channels);
      }
    }
  }

  template <typename W>
  void run_im2col(const PackedLayer& layer, const W* weights, int frames, Workspace& ws) const noexcept {
    const BufferSpec& in_spec = buffers_[static_cast<std::size_t>(layer.sources[0])];
    const BufferSpec& out_spec = buffers_[static_cast<std::size_t>(layer.out_buffer)];
    const float* in = ws.buffers[static_cast<std::size_t>(layer.sources[0])].data();
    float* out = ws.buffers[static_cast<std::size_t>(layer.out_buffer)].data();
    const int cs = in_spec.channels, row = layer.kernel_taps * cs, rows = out_spec.positions * frames;
    float* col = ws.columns.data();
    if (frames <= kSparseMaxFrames) {  // the taps that meet input only: sparse rows over the same block
      for (int p = 0; p < out_spec.positions; ++p)
        for (int f = 0; f < frames; ++f) {
          const long r = static_cast<long>(p) * frames + f;
          const int first = layer.receptive_first[static_cast<std::size_t>(p)];
          const int count = layer.receptive_first[static_cast<std::size_t>(p) + 1] - first;
          float* values = col + r * row;
          for (int i = 0; i < count; ++i) {
            const auto& [source, c] = layer.receptive_inputs[static_cast<std::size_t>(first + i)];
            values[i] = in[(static_cast<long>(source) * frames + f) * in_spec.stride + c];
          }
          ws.tap_rows[static_cast<std::size_t>(r)] = {layer.receptive_rows.data() + first, values, count};
          ws.y_rows[static_cast<std::size_t>(r)] = out + r * out_spec.stride;
        }
      Backend::gemm_sparse_rows(ws.tap_rows.data(), ws.y_rows.data(), rows, weights, row, out_spec.stride);
      return;
    }
    for (int p = 0; p < out_spec.positions; ++p)
      for (int f = 0; f < frames; ++f) {
        const long r = static_cast<long>(p) * frames + f;
        float* dst = col + r * row;
        for (int tap = 0; tap < layer.kernel_taps; ++tap) {
          const int source = layer.receptive[static_cast<std::size_t>(p * layer.kernel_taps + tap)];
          for (int c = 0; c < cs; ++c) dst[tap * cs + c] = source < 0 ? 0.0f : in[(static_cast<long>(source) * frames + f) * in_spec.stride + c];
        }
        ws.x_rows[static_cast<std::size_t>(r)] = dst;
        ws.y_rows[static_cast<std::size_t>(r)] = out + r * out_spec.stride;
      }
    Backend::gemm_rows(ws.x_rows.data(), ws.y_rows.data(), rows, weights, row, out_spec.stride);
  }

  // TapColumns: each source row's sums over its channels, one per tap (a product with the taps as
  // columns, sparse for small batches as in run_taps); then each output adds the (row, tap) sums it
  // meets. Frames go in chunks of kTapColumnFrames so that the sums stay in the L2 between the two.
  template <typename W>
  void run_tap_columns(const PackedLayer& layer, const W* weights, int frames, Workspace& ws) const noexcept {
    const BufferSpec& out_spec = buffers_[static_cast<std::size_t>(layer.out_buffer)];
    float* out = ws.buffers[static_cast<std::size_t>(layer.out_buffer)].data();
    const bool sparse = frames <= kSparseMaxFrames;
    std::size_t first_row[2] = {0, 0};  // unet_layers(): at most two (concatenated) sources
    if (sparse) compact_sources(layer, frames, ws, first_row);
    const long columns = layer.tap_stride;
    const std::size_t sources = std::min<std::size_t>(layer.sources.size(), 2);
    for (int first = 0; first < frames; first += kTapColumnFrames) {
      const int chunk = std::min(kTapColumnFrames, frames - first);
      float* sums[2] = {nullptr, nullptr};
      float* next = ws.tap_sums.data();
      for (std::size_t s = 0; s < sources; ++s) {
        const BufferSpec& in_spec = buffers_[static_cast<std::size_t>(layer.sources[s])];
        const float* in = ws.buffers[static_cast<std::size_t>(layer.sources[s])].data();
        const int rows = in_spec.positions * chunk;
        sums[s] = next;
        next += rows * columns;
        std::fill(sums[s], next, 0.0f);
        for (int r = 0; r < rows; ++r) {
          const long in_row = static_cast<long>(r / chunk) * frames + first + r % chunk;
          if (sparse) ws.tap_rows[static_cast<std::size_t>(r)] = ws.sparse_rows[first_row[s] + static_cast<std::size_t>(in_row)];
          else ws.x_rows[static_cast<std::size_t>(r)] = in + in_row * in_spec.stride;
          ws.y_rows[static_cast<std::size_t>(r)] = sums[s] + r * columns;
        }
        const W* block = weights + layer.block[s];
        if (sparse) Backend::gemm_sparse_rows(ws.tap_rows.data(), ws.y_rows.data(), rows, block, in_spec.channels, layer.tap_stride);
        else Backend::gemm_rows(ws.x_rows.data(), ws.y_rows.data(), rows, block, in_spec.channels, layer.tap_stride);
      }
      for (int p = 0; p < out_spec.positions; ++p)
        for (int f = 0; f < chunk; ++f) {
          float total[2] = {0.0f, 0.0f};  // one chain per source: independent additions
          for (const auto& [tap, in_pos] : layer.terms[static_cast<std::size_t>(p)])
            for (std::size_t s = 0; s < sources; ++s) total[s] += sums[s][(static_cast<long>(in_pos) * chunk + f) * columns + tap];
          out[(static_cast<long>(p) * frames + first + f) * out_spec.stride] += total[0] + total[1];
        }
    }
  }

  template <typename W>
  void run_products(const PackedLayer& layer, const W* weights, int frames, Workspace& ws, Team* team) const noexcept {
    if (layer.mode == Mode::Im2col) run_im2col(layer, weights, frames, ws);
    else if (layer.mode == Mode::TapColumns) run_tap_columns(layer, weights, frames, ws);
    else run_taps(layer, weights, frames, ws, team);
  }

  void run(const PackedLayer& layer, int frames, Workspace& ws, Team* team) const noexcept {
    const BufferSpec& out_spec = buffers_[static_cast<std::size_t>(layer.out_buffer)];
    float* out = ws.buffers[static_cast<std::size_t>(layer.out_buffer)].data();
    const int rows = out_spec.positions * frames;  // <= 25 * kMaxBatch
    if (layer.weights.fixed16()) {  // Fixed16: products of levels first, then scale, offset and bias
      std::fill(out, out + static_cast<long>(rows) * out_spec.stride, 0.0f);
      run_taps(layer, layer.weights.wfx16.data(), frames, ws, team);
      finish_fixed16(layer, frames, ws);
    } else {
      for (int r = 0; r < rows; ++r)
        std::copy(layer.bias.begin(), layer.bias.begin() + out_spec.stride, out + static_cast<long>(r) * out_spec.stride);
      layer.weights.visit([&](const auto* w) {
        if constexpr (!std::is_same_v<std::remove_cv_t<std::remove_pointer_t<decltype(w)>>, kernels::Fixed16>)
          run_products(layer, w, frames, ws, team);
      });
    }
    if (layer.activation == Activation::Relu)
      Backend::relu(out, rows * out_spec.stride);
    else
      for (int r = 0; r < rows; ++r) out[r] = std::tanh(out[r]);
  }

  UNet() = default;

  int width_ = 0;
  int extra_inputs_ = 0;
  WeightStorage storage_ = WeightStorage::F32;
  std::vector<BufferSpec> buffers_;
  std::vector<PackedLayer> layers_;
  std::size_t parameter_count_ = 0;
};

}  // namespace glovepose::nn
