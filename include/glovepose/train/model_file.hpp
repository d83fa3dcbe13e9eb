/// @file model_file.hpp
/// @brief Trained models of every architecture (U-Net, FCN, linear) as model files
/// (weights_format.md): writing what the trainer made, reading it back to evaluate or fine-tune,
/// and predicting normalised DoF values for prepared samples.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "../config.hpp"
#include "../grid/glove_description.hpp"
#include "../hand/dofs.hpp"
#include "../nn/linear.hpp"
#include "../nn/model.hpp"
#include "../sensor/calibration.hpp"
#include "network.hpp"
#include "samples.hpp"
#include "trainable_fcn.hpp"
#include "trainable_unet.hpp"
#include "trainer.hpp"

namespace glovepose::train {

/// @brief The joint limits a model's outputs are normalised by.
inline hand::JointLimits joint_limits(const nn::ModelInfo& info) {
  hand::Angles lo{}, hi{};
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    lo[d] = info.joint_limits_min[d];
    hi[d] = info.joint_limits_max[d];
  }
  return hand::JointLimits(lo, hi);
}

/// @brief Metadata for a new model of `architecture` and `width` for `glove`, normalised by the
/// glove's joint limits (its description's, else the reference's), with inputs calibrated by `mode`
/// (`range`: the training range).
inline nn::ModelInfo make_model_info(const std::string& architecture, int width, const grid::GloveDescription& glove, CalibrationMode mode,
                                     const sensor::CalibrationRange* range) {
  nn::ModelInfo info;
  info.architecture = architecture;
  info.width = architecture == "linear" ? 0 : width;
  info.inputs = glove.cell_count();
  info.glove = glove.id();
  if (glove != grid::GloveDescription::glauser2019()) info.glove_description = glove.to_metadata();
  info.calibration = to_string(mode);
  const hand::JointLimits limits = glove.joint_limits();
  info.joint_limits_min.assign(limits.min().begin(), limits.min().end());
  info.joint_limits_max.assign(limits.max().begin(), limits.max().end());
  if (mode == CalibrationMode::Training && range) {
    info.calibration_min = std::vector<double>(range->min().data(), range->min().data() + range->size());
    info.calibration_max = std::vector<double>(range->max().data(), range->max().data() + range->size());
  }
  return info;
}

/// @brief A network of the architecture `info` names, for `glove`, with zero tensors.
inline std::unique_ptr<TrainableNetwork> make_network(const nn::ModelInfo& info, const grid::GloveDescription& glove, int max_batch) {
  if (info.architecture == "unet") return std::make_unique<TrainableUNet>(info.width, glove.map(), max_batch);
  if (info.architecture == "fcn") return std::make_unique<TrainableFcn>(info.inputs, info.width, max_batch);
  throw Error("architecture '" + info.architecture + "' has no trainable network, expected unet or fcn");
}

/// @brief A model read from a file: metadata, glove, and the network or linear map.
struct TrainedModel {
  nn::ModelInfo info;                                                    ///< Metadata.
  grid::GloveDescription glove = grid::GloveDescription::glauser2019();  ///< The glove it was trained for.
  std::unique_ptr<TrainableNetwork> network;                             ///< U-Net or FCN (null for linear).
  std::optional<nn::LinearMap> linear;                                   ///< The linear map (linear models).
  std::map<std::string, std::string> metadata;                           ///< Every metadata entry of the file (provenance included).

  /// @brief The training-set calibration range stored in the file; throws unless it has one.
  sensor::CalibrationRange training_range() const {
    if (!info.calibration_min || !info.calibration_max)
      throw Error(
          "the model has no training-set calibration range (metadata calibration_min/max), expected one for --calibration training");
    const Eigen::Map<const Eigen::VectorXd> lo(info.calibration_min->data(), static_cast<Eigen::Index>(info.calibration_min->size()));
    const Eigen::Map<const Eigen::VectorXd> hi(info.calibration_max->data(), static_cast<Eigen::Index>(info.calibration_max->size()));
    return sensor::CalibrationRange(lo, hi, cell_names(info.calibration_min->size()), glove.calibration().config());
  }

  /// @brief Normalised predictions (frames x 25) for prepared samples.
  std::vector<float> predict(const Samples& samples, ThreadPool& pool) {
    if (samples.cells != info.inputs)
      throw Error("the samples have " + std::to_string(samples.cells) + " cells per frame, the model takes " + std::to_string(info.inputs));
    std::vector<float> out(static_cast<std::size_t>(samples.frames()) * kTargets);
    if (network) {
      out = train::predict(*network, samples, pool);
    } else {
      long rejected = -1;
      if (linear->predict(samples.inputs.data(), out.data(), samples.frames(), &rejected) != Status::Ok)
        throw Error("linear model: frame " + std::to_string(rejected) + " has a non-finite input");
    }
    const hand::DofSet labelled = info.labelled();
    if (labelled != hand::all_dofs()) {  // DoFs the model had no reference angles for read the rest pose
      const hand::JointLimits limits = joint_limits(info);
      for (long f = 0; f < samples.frames(); ++f) {
        hand::Angles a{};
        for (std::size_t d = 0; d < hand::kDofCount; ++d) a[d] = out[static_cast<std::size_t>(f) * kTargets + d];
        a = limits.rest_unlabelled(a, labelled);
        for (std::size_t d = 0; d < hand::kDofCount; ++d) out[static_cast<std::size_t>(f) * kTargets + d] = static_cast<float>(a[d]);
      }
    }
    return out;
  }
};

/// @brief Writes a model file: `info`, the tensors (stored as `dtype`: F32, F16 or BF16), and
/// `provenance` (extra metadata such as the command and seed that made it).
inline void save_model(const std::string& path, const nn::ModelInfo& info, const nn::TensorMap& tensors,
                       const std::map<std::string, std::string>& provenance = {}, io::DType dtype = io::DType::F32) {
  nn::WeightFile file;
  file.tensors = tensors;
  for (const auto& [key, value] : provenance) file.metadata[key] = value;
  info.to(file);
  file.write(path, dtype);
}

/// @brief The tensors of a linear map ("weight" [25, cells], "bias" [25], as torch.nn.Linear).
inline nn::TensorMap linear_tensors(const nn::LinearMap& map) {
  return {{"weight", nn::Tensor{{map.outputs(), map.inputs()}, map.weight()}}, {"bias", nn::Tensor{{map.outputs()}, map.bias()}}};
}

/// @brief Reads a model file of any architecture, its network sized for batches of `max_batch`.
/// Throws glovepose::Error naming the file and what is wrong.
inline TrainedModel load_model(const std::string& path, int max_batch = 1024) {
  const nn::WeightFile file = nn::WeightFile::read(path);
  try {
    TrainedModel model;
    model.info = nn::ModelInfo::from(file);
    model.metadata = file.metadata;
    model.glove = grid::GloveDescription::of_model(model.info.glove, model.info.glove_description);
    if (model.glove.cell_count() != model.info.inputs)
      throw Error("metadata 'inputs' is " + std::to_string(model.info.inputs) + " but the glove has " +
                  std::to_string(model.glove.cell_count()) + " cells");
    if (model.info.architecture == "linear") {
      for (const char* name : {"weight", "bias"})
        if (!file.tensors.count(name))
          throw Error(std::string("tensor '") + name + "' is missing, expected a linear model's weight and bias");
      if (file.tensors.size() != 2) throw Error("a linear model holds exactly the tensors 'weight' and 'bias'");
      const nn::Tensor& w = file.tensors.at("weight");
      if (w.shape != std::vector<std::int64_t>{kTargets, model.info.inputs})
        throw Error("tensor 'weight' has shape " + io::shape_string(w.shape) + ", expected [25, " + std::to_string(model.info.inputs) +
                    "]");
      model.linear.emplace(model.info.inputs, kTargets, w.values, file.tensors.at("bias").values);
    } else {
      model.network = make_network(model.info, model.glove, max_batch);
      model.network->parameters().load(file.tensors);
    }
    return model;
  } catch (const Error& e) {
    throw Error("model file '" + path + "': " + e.what());
  }
}

}  // namespace glovepose::train
