/// @file unet_packing.hpp
/// @brief Load time of the U-Net (unet.hpp): its activation buffers, and each layer packed for the
/// kernels. Every batch norm is folded into the convolution before it, each layer's weights are
/// packed per useful tap (conv_plan.hpp; taps that only meet zero padding are dropped), output
/// channels are padded to the SIMD width, and the weights are encoded in the storage chosen at load
/// (packed_weights.hpp). How a layer's products are organised (UNetMode) is chosen here.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "../config.hpp"
#include "conv_plan.hpp"
#include "kernels/scalar.hpp"
#include "kernels/weight_load.hpp"
#include "packed_weights.hpp"
#include "tensor.hpp"
#include "unet_topology.hpp"
#include "weight_storage.hpp"

namespace glovepose::nn {

/// @brief One activation buffer of the network.
struct UNetBuffer {
  int channels;
  int stride;  // channels padded to the SIMD width (the network input is never padded)
  int size;    // grid side
  int positions;
};

/// @brief One useful tap: the output positions it adds into and the input position each reads.
struct UNetTap {
  std::vector<int> out_positions, in_positions;
};

/// @brief How a layer's products are organised (unet_run.hpp).
enum class UNetMode : unsigned char {
  Taps,    // per useful tap and source: one product of the rows it joins with the tap's block
  Im2col,  // few input channels: gather each output's whole receptive field, one product with K = taps x channels
  // One output channel: per input row, one product with the kernel's taps as columns (a sum per
  // tap); each output then adds the (input row, tap) sums it meets. Replaces a short dot product
  // per (output, tap, source), whose horizontal sums and pointer set-up cost more than the FMAs.
  TapColumns,
};

/// @brief One layer as the forward runs it: its products' organisation, taps and packed weights.
struct UNetPackedLayer {
  std::vector<UNetTap> taps;
  std::vector<int> sources;
  int out_buffer = 0;
  UNetMode mode = UNetMode::Taps;
  int kernel_taps = 0;         // kernel * kernel (Im2col row length = kernel_taps * channels)
  std::vector<int> receptive;  // Im2col: [out position][tap] -> input position or -1
  // Im2col, small batches: per out position (from receptive_first[p]) the rows tap * channels + c
  // of the taps that meet input, ascending, and the (input position, channel) each reads.
  std::vector<int> receptive_first, receptive_rows;
  std::vector<std::pair<int, int>> receptive_inputs;
  std::vector<std::vector<std::pair<int, int>>> terms;  // TapColumns: [out position] -> (tap, input position)
  int tap_stride = 0;                                   // TapColumns: taps padded to the SIMD width
  Activation activation = Activation::Relu;
  AlignedVector<float> bias;  // padded output channels
  // per (tap, source): in channels x padded out channels, in column panels; Fixed16 in Taps layers only
  PackedWeights weights;
  std::vector<std::size_t> block;  // offset of (tap, source) block
  std::size_t stored_weights = 0;
};

/// @brief The activation buffers of a width-`width` network reading `extra_inputs` extra input
/// planes, their channels padded for `Backend` and `storage` (the input and output are not).
template <typename Backend>
std::vector<UNetBuffer> unet_buffers(int width, int extra_inputs, WeightStorage storage) {
  std::vector<UNetBuffer> buffers;
  for (int id = 0; id < kUNetBufferCount; ++id) {
    const int c = unet_buffer_channels(id, width, extra_inputs);
    // BF16 and Fixed16 weights come in pairs of vectors (kernels/weight_load.hpp): whole pairs of output channels.
    const int multiple = paired_storage(storage) ? 2 * Backend::lanes : Backend::lanes;
    const int stride = (id == 0 || id == kUNetBufferCount - 1) ? c : round_up(c, multiple);
    buffers.push_back({c, stride, unet_buffer_size(id), unet_buffer_size(id) * unet_buffer_size(id)});
  }
  return buffers;
}

/// @brief Layer `spec` of a network with `buffers` (unet_buffers()), from PyTorch-named `tensors`,
/// batch norm folded with `eps`, weights encoded as `storage`. Throws glovepose::Error for a folded
/// value the storage cannot hold or a non-finite one, naming the layer.
template <typename Backend>
UNetPackedLayer pack_unet_layer(const UNetLayer& spec, const TensorMap& tensors, double eps, const std::vector<UNetBuffer>& buffers,
                                int width, int extra_inputs, WeightStorage storage) {
  spec.geometry.validate(spec.conv);
  const UNetBuffer& out = buffers[static_cast<std::size_t>(spec.out_buffer)];
  const int cin = spec.in_channels(width, extra_inputs), cout = spec.out_channels, k = spec.geometry.kernel;
  UNetPackedLayer layer;
  layer.sources = spec.sources;
  layer.out_buffer = spec.out_buffer;
  layer.activation = spec.activation;
  const int first_channels = buffers[static_cast<std::size_t>(spec.sources[0])].channels;
  layer.mode =
      cout == 1 ? UNetMode::TapColumns : (spec.sources.size() == 1 && first_channels * k * k <= 64 ? UNetMode::Im2col : UNetMode::Taps);
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
  const bool fixed = storage == WeightStorage::Fixed16 && layer.mode == UNetMode::Taps && spec.sources[0] != 0;
  const bool paired = storage == WeightStorage::BF16 || fixed;
  // TapColumns: the taps are the product's columns, padded to whole pairs of vectors for every
  // storage (the pair layout needs them; the same stride keeps 16-bit layers half an F32 one).
  if (layer.mode == UNetMode::TapColumns) layer.tap_stride = round_up(layer.kernel_taps, 2 * Backend::lanes);
  const int columns = layer.mode == UNetMode::TapColumns ? layer.tap_stride : out.stride;
  // Where W(row, column) of a (rows x columns) product block goes.
  const auto slot = [&](int row, int co, int rows) {
    const int column = paired ? kernels::paired_slot(co, Backend::lanes) : co;
    return static_cast<std::size_t>(kernels::panel_index(row, column, rows, columns, Backend::panel));
  };
  std::vector<int> column_of;            // Fixed16: the output channel of each packed slot (padding included)
  if (layer.mode == UNetMode::Im2col) {  // one dense (taps x channels) x stride block over the whole kernel
    const int cs = first_channels, rows = layer.kernel_taps * cs;
    packed.assign(static_cast<std::size_t>(rows) * static_cast<std::size_t>(out.stride), 0.0f);
    for (int tap = 0; tap < layer.kernel_taps; ++tap)
      for (int ci = 0; ci < cs; ++ci)
        for (int co = 0; co < cout; ++co)
          packed[slot(tap * cs + ci, co, rows)] = static_cast<float>(w_at(ci, co, tap) * scale[static_cast<std::size_t>(co)]);
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
  if (layer.mode == UNetMode::TapColumns) {  // per source one channels x taps block; taps no output meets stay zero
    int channel_base = 0;
    for (int source : spec.sources) {
      const int cs = buffers[static_cast<std::size_t>(source)].channels;
      const std::size_t base = packed.size();
      layer.block.push_back(base);
      packed.resize(base + static_cast<std::size_t>(cs) * static_cast<std::size_t>(columns), 0.0f);
      for (const TapPairs& t : plan)
        for (int ci = 0; ci < cs; ++ci)
          packed[base + slot(ci, t.tap, cs)] = static_cast<float>(w_at(channel_base + ci, 0, t.tap) * scale[0]);
      layer.stored_weights += plan.size() * static_cast<std::size_t>(cs);
      channel_base += cs;
    }
    layer.terms.resize(static_cast<std::size_t>(out.positions));
    for (const TapPairs& t : plan)
      for (std::size_t j = 0; j < t.out_positions.size(); ++j)
        layer.terms[static_cast<std::size_t>(t.out_positions[j])].push_back({t.tap, t.in_positions[j]});
  }
  for (const TapPairs& t : plan) {
    if (layer.mode != UNetMode::Taps) break;
    layer.taps.push_back({t.out_positions, t.in_positions});
    int channel_base = 0;
    for (int source : spec.sources) {
      const int cs = buffers[static_cast<std::size_t>(source)].channels;
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
  const WeightStorage stored = fixed ? WeightStorage::Fixed16 : (storage == WeightStorage::Fixed16 ? WeightStorage::F32 : storage);
  layer.weights = encode_weights(packed, stored, column_of, out.stride,
                                 "UNet: layer " + spec.conv + (spec.bn.empty() ? "" : " with " + spec.bn + " folded in"));
  return layer;
}

}  // namespace glovepose::nn
