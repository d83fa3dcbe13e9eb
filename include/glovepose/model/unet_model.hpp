/// @file unet_model.hpp
/// @brief A U-Net model file loaded as the bare network with its metadata, for benchmarks, studies
/// and tests that run the U-Net without the estimator (which loads every architecture through
/// PoseModel). Read by the one model file reader, model_file.hpp.
#pragma once

#include <string>
#include <utility>

#include "../config.hpp"
#include "../nn/unet.hpp"
#include "model_file.hpp"
#include "model_info.hpp"

namespace glovepose::model {

/// @brief A loaded U-Net model: the network and its metadata.
template <typename Backend = nn::kernels::SimdBackend>
struct UNetModel {
  ModelInfo info;          ///< Metadata.
  nn::UNet<Backend> unet;  ///< The network.

  /// @brief Loads a model file, with weights kept as `storage`. Throws glovepose::Error naming the
  /// file and what is wrong (including a model of another architecture).
  static UNetModel load(const std::string& path, nn::WeightStorage storage = nn::WeightStorage::F32) {
    return load_model_file(path, [storage](ModelFile&& file) {
      if (file.info.architecture != Architecture::UNet)
        throw Error("architecture '" + file.info.architecture_name() +
                    "' is not a U-Net; PoseModel::load runs U-Nets and FCNs, train::load_model every architecture");
      nn::UNet<Backend> net = nn::UNet<Backend>::from_tensors(file.tensors, file.info.width, file.info.bn_eps, storage);
      return UNetModel{std::move(file.info), std::move(net)};
    });
  }
};

}  // namespace glovepose::model
