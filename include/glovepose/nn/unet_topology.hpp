/// @file unet_topology.hpp
/// @brief The U-Net's layers as data (the paper's Table 6; our reading in weights_format.md): which
/// buffers each layer reads and writes, its geometry, batch norm and activation, and the tensors a
/// width-w network is made of. Shared by the inference network (unet.hpp) and the trainer
/// (train/trainable_unet.hpp), so the two cannot disagree about the architecture.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "conv_plan.hpp"

namespace glovepose::nn {

/// @brief Activation after a layer.
enum class Activation : unsigned char { Relu, Tanh };

/// @brief Activation buffers: 0 input, 1 e1, 2 e2, 3 e3, 4 e4, 5 d1, 6 d2, 7 d3, 8 output.
inline constexpr int kUNetBufferCount = 9;
/// @brief Positions of the input and output grids (5 x 5).
inline constexpr int kUNetGridPositions = 25;
/// @brief Input planes of a network for a glove without extra inputs: the two stretch maps.
inline constexpr int kUNetMapPlanes = 2;
/// @brief Values in one network input for a glove without extra inputs (2 x 5 x 5, channel-major);
/// UNet::input_values() in general.
inline constexpr int kUNetInputs = kUNetMapPlanes * kUNetGridPositions;
/// @brief Values in one network output (1 x 5 x 5).
inline constexpr int kUNetOutputs = kUNetGridPositions;
/// @brief Most extra input planes a network reads (a glove has at most 256 inputs).
inline constexpr int kMaxExtraInputs = 256;

/// @brief PyTorch's NCHW frames (`frames` x `planes` x `positions`) -> the networks' activation
/// layout [position][frame][plane] (inference and training share it).
inline void to_position_major(const float* nchw, int frames, int planes, int positions, float* rows) noexcept {
  for (int f = 0; f < frames; ++f)
    for (int c = 0; c < planes; ++c)
      for (int p = 0; p < positions; ++p)
        rows[(static_cast<long>(p) * frames + f) * planes + c] = nchw[(static_cast<long>(f) * planes + c) * positions + p];
}

/// @brief One plane back: [position][frame] -> `frames` x `positions` (NCHW with one channel).
inline void from_position_major(const float* rows, int frames, int positions, float* nchw) noexcept {
  for (int f = 0; f < frames; ++f)
    for (int p = 0; p < positions; ++p) nchw[static_cast<long>(f) * positions + p] = rows[static_cast<long>(p) * frames + f];
}

/// @brief Channels of buffer `id` in a width-`w` network for a glove with `extra_inputs` inputs
/// that are not on the stretch maps: the input holds the two maps and one constant plane per extra
/// input (grid::GridMap::to_input_planes()).
inline int unet_buffer_channels(int id, int w, int extra_inputs = 0) noexcept {
  constexpr int factor[] = {0, 1, 2, 4, 8, 4, 2, 1, 0};
  return id == 0 ? kUNetMapPlanes + extra_inputs : (id == 8 ? 1 : factor[id] * w);
}

/// @brief Grid side of buffer `id` (5x5 in, 3x3, 2x2, 1x1 at the bottom, back to 5x5).
inline int unet_buffer_size(int id) noexcept {
  constexpr int size[] = {5, 5, 3, 2, 1, 2, 3, 5, 5};
  return size[id];
}

/// @brief One layer: convolution (or transposed convolution), optional batch norm, activation.
struct UNetLayer {
  std::string conv;          ///< State-dict prefix of the convolution.
  std::string bn;            ///< State-dict prefix of its batch norm; empty: none.
  ConvGeometry geometry;     ///< Sizes, kernel, stride, padding.
  std::vector<int> sources;  ///< Buffers read, concatenated along channels in this order.
  int out_buffer;            ///< Buffer written.
  int out_channels;          ///< Output channels.
  Activation activation;     ///< Activation after the batch norm.

  /// @brief Input channels (sum over the concatenated sources).
  int in_channels(int width, int extra_inputs = 0) const noexcept {
    int c = 0;
    for (int s : sources) c += unet_buffer_channels(s, width, extra_inputs);
    return c;
  }
};

/// @brief The layers of a width-`w` U-Net in forward order.
inline std::vector<UNetLayer> unet_layers(int w) {
  const auto R = Activation::Relu;
  return {
      {"enc1", "", {5, 5, 5, 1, 2, false}, {0}, 1, w, R},        {"enc2", "bn2", {5, 3, 3, 2, 1, false}, {1}, 2, 2 * w, R},
      {"enc3", "bn3", {3, 2, 3, 2, 1, false}, {2}, 3, 4 * w, R}, {"enc4", "bn4", {2, 1, 4, 2, 1, false}, {3}, 4, 8 * w, R},
      {"dec1", "dbn1", {1, 2, 4, 2, 1, true}, {4}, 5, 4 * w, R}, {"dec2", "dbn2", {2, 3, 3, 2, 1, true}, {5, 3}, 6, 2 * w, R},
      {"dec3", "dbn3", {3, 5, 3, 2, 1, true}, {6, 2}, 7, w, R},  {"out", "", {5, 5, 5, 1, 2, false}, {7, 1}, 8, 1, Activation::Tanh},
  };
}

/// @brief The tensor names and shapes (PyTorch state_dict) a width-`w` network reading
/// `extra_inputs` extra input planes is made of (only enc1.weight depends on them).
inline std::map<std::string, std::vector<std::int64_t>> unet_tensor_shapes(int w, int extra_inputs = 0) {
  std::map<std::string, std::vector<std::int64_t>> shapes;
  for (const UNetLayer& s : unet_layers(w)) {
    const std::int64_t in = s.in_channels(w, extra_inputs), out = s.out_channels;
    const std::int64_t k = s.geometry.kernel;
    shapes[s.conv + ".weight"] =
        s.geometry.transposed ? std::vector<std::int64_t>{in, out, k, k} : std::vector<std::int64_t>{out, in, k, k};
    shapes[s.conv + ".bias"] = {out};
    if (!s.bn.empty())
      for (const char* part : {".weight", ".bias", ".running_mean", ".running_var"}) shapes[s.bn + part] = {out};
  }
  return shapes;
}

}  // namespace glovepose::nn
