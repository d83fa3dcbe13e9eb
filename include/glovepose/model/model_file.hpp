/// @file model_file.hpp
/// @brief The one reader of model files (weights_format.md): the file's metadata read once into
/// ModelInfo, with its tensors, handed to what builds a network from them: PoseModel::load (the
/// real-time PoseNetwork), train::load_model (the trainable networks and linear maps) and
/// UNetModel::load (the bare U-Net). Every error, of the file, its metadata or the network built
/// from it, names the file.
#pragma once

#include <map>
#include <string>
#include <utility>

#include "../config.hpp"
#include "../nn/weights.hpp"
#include "model_info.hpp"

namespace glovepose::model {

/// @brief What a model file holds.
struct ModelFile {
  ModelInfo info;                               ///< The metadata, parsed and checked.
  std::map<std::string, std::string> metadata;  ///< Every metadata entry as written, provenance included.
  nn::TensorMap tensors;                        ///< The network's tensors, widened to float.

  /// @brief The model in a weight file already read. Throws glovepose::Error naming the metadata
  /// key that is missing or wrong.
  static ModelFile from(nn::WeightFile file) {
    ModelInfo info = ModelInfo::from(file);
    return ModelFile{std::move(info), std::move(file.metadata), std::move(file.tensors)};
  }
};

/// @brief Reads the model file at `path` and returns `build(ModelFile&&)`: the loaded model, made
/// from the file's metadata and tensors. Throws glovepose::Error naming the file and what is wrong,
/// whether the file, its metadata or `build` found it.
template <typename Build>
auto load_model_file(const std::string& path, Build&& build) {
  nn::WeightFile file = nn::WeightFile::read(path);  // its errors name the file already
  try {
    return std::forward<Build>(build)(ModelFile::from(std::move(file)));
  } catch (const Error& e) {
    throw Error("model file '" + path + "': " + e.what());
  }
}

}  // namespace glovepose::model
