/// @file unet_diagnostics.hpp
/// @brief What a U-Net forward did, for benchmarks and studies (set-up code, may allocate): the
/// zeros each ReLU left, and the bytes of weights a single-frame forward read.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <numeric>
#include <string>
#include <vector>

#include "../config.hpp"
#include "unet.hpp"

namespace glovepose::nn {

/// @brief Reads a network's and a workspace's internals for the functions below.
class UNetDiagnostics {
 public:
  /// @brief For the last `frames`-frame forward on `ws`: the fraction of each hidden activation
  /// buffer (e1, e2, e3, e4, d1, d2, d3, after their ReLU; real channels only) that is exactly
  /// zero. Forwards of up to kSparseMaxFrames frames skip those entries (kernels/sparse_row.hpp),
  /// so these fractions set how much of the weights a frame reads. Diagnostic, set-up code: throws
  /// glovepose::Error for a workspace of another network or `frames` outside 1..capacity.
  template <typename Backend>
  static std::array<double, kUNetBufferCount - 2> zero_fractions(const UNet<Backend>& net, const UNetWorkspace<Backend>& ws, int frames) {
    if (ws.width_ != net.width_ || ws.buffers.size() != net.buffers_.size())
      throw Error("zero_fractions: workspace of a width-" + std::to_string(ws.width_) + " network, expected width " +
                  std::to_string(net.width_));
    if (frames < 1 || frames > ws.capacity_)
      throw Error("zero_fractions: " + std::to_string(frames) + " frames, expected 1.." + std::to_string(ws.capacity_));
    std::array<double, kUNetBufferCount - 2> fractions{};
    for (int id = 1; id + 1 < kUNetBufferCount; ++id) {
      const UNetBuffer& spec = net.buffers_[static_cast<std::size_t>(id)];
      const float* values = ws.buffers[static_cast<std::size_t>(id)].data();
      const long rows = static_cast<long>(spec.positions) * frames;
      long zeros = 0;
      for (long r = 0; r < rows; ++r) zeros += std::count(values + r * spec.stride, values + r * spec.stride + spec.channels, 0.0f);
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
  template <typename Backend>
  static std::size_t weight_bytes_read(const UNet<Backend>& net, const UNetWorkspace<Backend>& ws) {
    if (ws.width_ != net.width_ || ws.buffers.size() != net.buffers_.size())
      throw Error("weight_bytes_read: workspace of a width-" + std::to_string(ws.width_) + " network, expected width " +
                  std::to_string(net.width_));
    // Rows of a block whose input channels of buffer `id` are nonzero at one or more of `positions`
    // (frame 0 of a single-frame forward).
    const auto nonzero_rows = [&](int id, const std::vector<int>& positions) {
      const UNetBuffer& spec = net.buffers_[static_cast<std::size_t>(id)];
      const float* values = ws.buffers[static_cast<std::size_t>(id)].data();
      std::size_t rows = 0;
      for (int c = 0; c < spec.channels; ++c)
        rows +=
            std::any_of(positions.begin(), positions.end(), [&](int p) { return values[static_cast<long>(p) * spec.stride + c] != 0.0f; });
      return rows;
    };
    std::size_t bytes = 0;
    for (const UNetPackedLayer& l : net.layers_) {
      // A layer keeps one storage: F32, or 16 bits (which leave w32 empty).
      const std::size_t weight_size = l.weights.weight_size();
      const std::size_t out_stride = static_cast<std::size_t>(net.buffers_[static_cast<std::size_t>(l.out_buffer)].stride);
      if (l.mode == UNetMode::Im2col) {  // every row of a tap that meets input, whatever its value
        std::vector<int> rows(l.receptive_rows);
        std::sort(rows.begin(), rows.end());
        bytes += static_cast<std::size_t>(std::unique(rows.begin(), rows.end()) - rows.begin()) * out_stride * weight_size;
      } else if (l.mode == UNetMode::TapColumns) {  // per source, its nonzero channels anywhere; the taps are the columns
        for (int id : l.sources) {
          std::vector<int> everywhere(static_cast<std::size_t>(net.buffers_[static_cast<std::size_t>(id)].positions));
          std::iota(everywhere.begin(), everywhere.end(), 0);
          bytes += nonzero_rows(id, everywhere) * static_cast<std::size_t>(l.tap_stride) * weight_size;
        }
      } else {
        for (const UNetTap& tap : l.taps)
          for (int id : l.sources) bytes += nonzero_rows(id, tap.in_positions) * out_stride * weight_size;
      }
    }
    return bytes;
  }
};

/// @brief For the last `frames`-frame forward of `net` on `ws`: the fraction of zeros in each hidden
/// activation buffer (UNetDiagnostics::zero_fractions).
template <typename Backend>
std::array<double, kUNetBufferCount - 2> zero_fractions(const UNet<Backend>& net, const UNetWorkspace<Backend>& ws, int frames) {
  return UNetDiagnostics::zero_fractions(net, ws, frames);
}

/// @brief For the last single-frame forward of `net` on `ws`: the bytes of packed weights it read
/// (UNetDiagnostics::weight_bytes_read).
template <typename Backend>
std::size_t weight_bytes_read(const UNet<Backend>& net, const UNetWorkspace<Backend>& ws) {
  return UNetDiagnostics::weight_bytes_read(net, ws);
}

}  // namespace glovepose::nn
