/// @file unet_run.hpp
/// @brief The U-Net's forward, layer by layer, over packed layers (unet_packing.hpp) and a
/// stream's workspace. Activations live as [position][frame][channel]: a layer is, per useful tap
/// and per skip source, one matrix product of the (frame x channel) rows it joins with the tap's
/// weight block, which is also how concatenation costs nothing (each source is its own block of
/// input channels). Every function here is per-frame code: noexcept, allocation-free.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <type_traits>
#include <vector>

#include "../config.hpp"
#include "batching.hpp"
#include "fixed16.hpp"
#include "kernels/sparse_row.hpp"
#include "layer_probe.hpp"
#include "../core/team.hpp"
#include "tensor.hpp"
#include "unet_packing.hpp"

#ifndef GLOVEPOSE_LAYER_PROBE
#define GLOVEPOSE_LAYER_PROBE ::glovepose::nn::NoLayerProbe  // layer_probe.hpp
#endif

namespace glovepose::nn {

/// @brief Frames per chunk of the one-output-channel layer: its (row, tap) sums, 25 x 2 x 32 floats a
/// frame (6.4 KB), stay in the L2 between the product that writes them and the sums that read them.
inline constexpr int kTapColumnFrames = 16;

template <typename Backend>
class UNet;
template <typename Backend>
class UNetRunner;
class UNetDiagnostics;

/// @brief Per-stream activations and scratch of a UNet<Backend> for batches of up to capacity()
/// frames (UNet::make_workspace).
template <typename Backend>
class UNetWorkspace {
 public:
  /// @brief Largest batch this workspace serves.
  int capacity() const noexcept { return capacity_; }

 private:
  friend class UNet<Backend>;
  friend class UNetRunner<Backend>;
  friend class UNetDiagnostics;
  int capacity_ = 0;
  int width_ = 0;  // the network it was made for: buffer sizes follow from width, planes and capacity
  int extra_inputs_ = 0;
  std::vector<AlignedVector<float>> buffers;
  std::vector<const float*> x_rows;
  std::vector<float*> y_rows;
  AlignedVector<float> columns;   // Im2col: receptive fields, one row per (position, frame)
  std::vector<int> sparse_index;  // Taps, small batches: nonzero entries of the sources' rows
  std::vector<float> sparse_value;
  std::vector<kernels::SparseRow> sparse_rows;  // per (source, position, frame)
  std::vector<kernels::SparseRow> tap_rows;     // the rows one product joins
  AlignedVector<float> tap_sums;                // TapColumns: per (source, position, frame of a chunk) one sum per tap
  std::vector<float> input_sums;                // Fixed16: sum of each source row (per source, position, frame)
  std::vector<float> output_sums;               // Fixed16: sum of the inputs each output row met
  // Team members 1.. (forward with a Team): each its own row lists for its share of a product.
  struct MemberRows {
    std::vector<const float*> x_rows;
    std::vector<float*> y_rows;
    std::vector<kernels::SparseRow> tap_rows;
  };
  std::vector<MemberRows> members;
};

/// @brief Runs packed layers on a workspace: per layer its products (UNetMode), bias or the
/// Fixed16 finish, and the activation. Holds only a reference to the network's buffers.
template <typename Backend>
class UNetRunner {
 public:
  using BufferSpec = UNetBuffer;             ///< An activation buffer.
  using PackedLayer = UNetPackedLayer;       ///< A packed layer.
  using PackedTap = UNetTap;                 ///< A useful tap.
  using Mode = UNetMode;                     ///< How a layer's products are organised.
  using Workspace = UNetWorkspace<Backend>;  ///< A stream's activations and scratch.

  /// @brief A runner over the activation buffers `buffers` (unet_buffers()), which must outlive it.
  /// One runner is made per forward.
  explicit UNetRunner(const std::vector<UNetBuffer>& buffers) noexcept : buffers_(buffers) { Probe::mark(LayerEvent::Forward); }

  /// @brief One layer on the `frames` frames in `ws`, its products shared by `team` when given.
  GLOVEPOSE_REALTIME void run(const PackedLayer& layer, int frames, Workspace& ws, core::Team* team) const noexcept {
    const BufferSpec& out_spec = buffers_[static_cast<std::size_t>(layer.out_buffer)];
    float* out = ws.buffers[static_cast<std::size_t>(layer.out_buffer)].data();
    const int rows = out_spec.positions * frames;  // <= 25 * kMaxBatch
    Probe::mark(LayerEvent::LayerBegin);
    if (layer.weights.fixed16()) {  // Fixed16: products of levels first, then scale, offset and bias
      std::fill(out, out + static_cast<long>(rows) * out_spec.stride, 0.0f);
      run_taps(layer, layer.weights.wfx16.data(), frames, ws, team);
      Probe::mark(LayerEvent::ProductsEnd);
      finish_fixed16(layer, frames, ws);
      Probe::mark(LayerEvent::FinishEnd);
    } else {
      for (int r = 0; r < rows; ++r)
        std::copy(layer.bias.begin(), layer.bias.begin() + out_spec.stride, out + static_cast<long>(r) * out_spec.stride);
      layer.weights.visit([&](const auto* w) {
        if constexpr (!std::is_same_v<std::remove_cv_t<std::remove_pointer_t<decltype(w)>>, kernels::Fixed16>)
          run_products(layer, w, frames, ws, team);
      });
      Probe::mark(LayerEvent::ProductsEnd);
    }
    Probe::mark(LayerEvent::ActivationBegin);
    if (layer.activation == Activation::Relu)
      Backend::relu(out, rows * out_spec.stride);
    else
      for (int r = 0; r < rows; ++r) out[r] = std::tanh(out[r]);
    Probe::mark(LayerEvent::ActivationEnd);
  }

 private:
  using Probe = GLOVEPOSE_LAYER_PROBE;  // layer_probe.hpp: nothing unless a timing experiment asks

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
    const int column_end =
        split_columns ? std::min(out_spec.stride, panels * (share.member + 1) / share.members * Backend::panel) : out_spec.stride;
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
            if (sparse)
              tap_rows[rows] = ws.sparse_rows[first_row[s] + static_cast<std::size_t>(in_row)];
            else
              x_rows[rows] = in + in_row * in_spec.stride;
            y_rows[rows] = out + (static_cast<long>(tap.out_positions[j]) * frames + f) * out_spec.stride + column_begin;
          }
        }
        // The block's column panels from column_begin on: a panel boundary, so the kernel splits
        // its columns into the same blocks as for the whole width.
        const W* block = weights + layer.block[t * sources + s] + static_cast<long>(in_spec.channels) * column_begin;
        if (!sparse)
          Backend::gemm_rows(x_rows, y_rows, rows, block, in_spec.channels, column_end - column_begin);
        else
          Backend::gemm_sparse_rows(tap_rows, y_rows, rows, block, in_spec.channels, column_end - column_begin);
      }
    }
  }

  // A Taps layer's products, shared by the team's members when there is one.
  template <typename W>
  void run_taps(const PackedLayer& layer, const W* weights, int frames, Workspace& ws, core::Team* team) const noexcept {
    std::size_t first_row[2] = {0, 0};  // unet_layers(): at most two (concatenated) sources
    if (frames <= kSparseMaxFrames) {
      Probe::mark(LayerEvent::CompactionBegin);
      compact_sources(layer, frames, ws, first_row);
      Probe::mark(LayerEvent::CompactionEnd);
    }
    if (team == nullptr || team->size() == 1) {
      Probe::mark(LayerEvent::ShareBegin);
      run_tap_share(layer, weights, frames, ws, first_row);
      Probe::mark(LayerEvent::ShareEnd);
      return;
    }
    auto share = [&](int member) noexcept {
      Probe::mark(LayerEvent::ShareBegin, member);
      run_tap_share(layer, weights, frames, ws, first_row, Share{member, team->size()});
      Probe::mark(LayerEvent::ShareEnd, member);
    };
    Probe::mark(LayerEvent::HandOver);
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
          for (int c = 0; c < cs; ++c)
            dst[tap * cs + c] = source < 0 ? 0.0f : in[(static_cast<long>(source) * frames + f) * in_spec.stride + c];
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
          if (sparse)
            ws.tap_rows[static_cast<std::size_t>(r)] = ws.sparse_rows[first_row[s] + static_cast<std::size_t>(in_row)];
          else
            ws.x_rows[static_cast<std::size_t>(r)] = in + in_row * in_spec.stride;
          ws.y_rows[static_cast<std::size_t>(r)] = sums[s] + r * columns;
        }
        const W* block = weights + layer.block[s];
        if (sparse)
          Backend::gemm_sparse_rows(ws.tap_rows.data(), ws.y_rows.data(), rows, block, in_spec.channels, layer.tap_stride);
        else
          Backend::gemm_rows(ws.x_rows.data(), ws.y_rows.data(), rows, block, in_spec.channels, layer.tap_stride);
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
  void run_products(const PackedLayer& layer, const W* weights, int frames, Workspace& ws, core::Team* team) const noexcept {
    if (layer.mode == Mode::Im2col)
      run_im2col(layer, weights, frames, ws);
    else if (layer.mode == Mode::TapColumns)
      run_tap_columns(layer, weights, frames, ws);
    else
      run_taps(layer, weights, frames, ws, team);
  }

  const std::vector<UNetBuffer>& buffers_;
};

}  // namespace glovepose::nn
