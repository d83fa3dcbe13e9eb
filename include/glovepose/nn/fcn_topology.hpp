/// @file fcn_topology.hpp
/// @brief The fully connected network's shape (the paper's FCN baseline, appendix A:
/// F44-F2048-F2048-F2048-F2048-F1024-F26, after Glauser et al. 2019), with 25 outputs and any
/// hidden width: inputs -> h -> h -> h -> h -> h/2 -> 25, ReLU after every layer but the last.
/// Shared by the inference network (fcn.hpp) and the trainer (train/trainable_fcn.hpp).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace glovepose::nn {

/// @brief Outputs of the FCN: one normalised value per DoF of the hand model.
inline constexpr int kFcnOutputs = 25;

/// @brief Fully connected layers of the FCN (fc1..fc6).
inline constexpr int kFcnLayers = 6;

/// @brief Layer widths, input first: inputs, h, h, h, h, h/2, 25.
inline std::vector<int> fcn_widths(int inputs, int hidden) { return {inputs, hidden, hidden, hidden, hidden, hidden / 2, kFcnOutputs}; }

/// @brief Tensor names and shapes as torch.nn.Linear stores them: "fcL.weight" [out, in], "fcL.bias" [out].
inline std::map<std::string, std::vector<std::int64_t>> fcn_tensor_shapes(int inputs, int hidden) {
  const std::vector<int> widths = fcn_widths(inputs, hidden);
  std::map<std::string, std::vector<std::int64_t>> shapes;
  for (int l = 0; l < kFcnLayers; ++l) {
    const std::string name = "fc" + std::to_string(l + 1);
    shapes[name + ".weight"] = {widths[static_cast<std::size_t>(l + 1)], widths[static_cast<std::size_t>(l)]};
    shapes[name + ".bias"] = {widths[static_cast<std::size_t>(l + 1)]};
  }
  return shapes;
}

}  // namespace glovepose::nn
