/// @file pose_model_options.hpp
/// @brief How to load a PoseModel (pose_model.hpp): the weights' storage, the glove and its wiring.
#pragma once

#include <optional>

#include "grid/glove_description.hpp"
#include "nn/weight_storage.hpp"
#include "sensor/layout.hpp"

namespace glovepose {

/// @brief How to load a PoseModel.
struct PoseModelOptions {
  /// In-memory weight precision. The 16-bit storages halve the bytes a frame reads (faster at
  /// batch 1). Fixed16 is the real-time choice: its angles differ from F32 by under 0.005
  /// degree (shipped model), F16's by a few hundredths, BF16's by tenths (README, "Figures").
  nn::WeightStorage storage = nn::WeightStorage::F32;
  /// The glove. Default: the description stored in the model file, else the built-in 44-cell glove
  /// when the model was trained for it.
  std::optional<grid::GloveDescription> glove;
  /// The glove's wiring (which cells each measured row sums), needed for rows and C_m frames.
  /// Default: the paper's 15 x 12 trace matrix for the built-in glove; none for other gloves (then
  /// only already solved C_c frames are accepted).
  std::optional<sensor::TraceLayout> layout;
};

}  // namespace glovepose
