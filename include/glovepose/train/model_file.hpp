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
#include "../model/model_file.hpp"
#include "../model/model_info.hpp"
#include "../sensor/calibration.hpp"
#include "network.hpp"
#include "samples.hpp"
#include "trainable_fcn.hpp"
#include "trainable_unet.hpp"
#include "trainer.hpp"

namespace glovepose::train {

/// @brief Metadata for a new model of `architecture` and `width` for `glove`, normalised by the
/// glove's joint limits (its description's, else the reference's), with inputs calibrated by `mode`
/// (`range`: the training range).
inline model::ModelInfo make_model_info(model::Architecture architecture, int width, const grid::GloveDescription& glove,
                                        model::CalibrationMode mode, const sensor::CalibrationRange* range) {
  model::ModelInfo info;
  info.architecture = architecture;
  info.width = architecture == model::Architecture::Linear ? 0 : width;
  info.inputs = glove.cell_count();
  info.glove = glove.id();
  if (glove != grid::GloveDescription::glauser2019()) info.glove_description = glove;
  info.calibration = mode;
  const hand::JointLimits limits = glove.joint_limits();
  info.joint_limits_min.assign(limits.min().begin(), limits.min().end());
  info.joint_limits_max.assign(limits.max().begin(), limits.max().end());
  if (mode == model::CalibrationMode::Training && range) {
    info.calibration_min = std::vector<double>(range->min().data(), range->min().data() + range->size());
    info.calibration_max = std::vector<double>(range->max().data(), range->max().data() + range->size());
  }
  return info;
}

/// @brief make_model_info for the architecture `architecture` spells; throws glovepose::Error for a
/// name of none.
inline model::ModelInfo make_model_info(const std::string& architecture, int width, const grid::GloveDescription& glove,
                                        model::CalibrationMode mode, const sensor::CalibrationRange* range) {
  return make_model_info(model::architecture(architecture), width, glove, mode, range);
}

/// @brief A network of the architecture `info` names, for `glove`, with zero tensors.
inline std::unique_ptr<TrainableNetwork> make_network(const model::ModelInfo& info, const grid::GloveDescription& glove, int max_batch) {
  if (info.architecture == model::Architecture::UNet) return std::make_unique<TrainableUNet>(info.width, glove.map(), max_batch);
  if (info.architecture == model::Architecture::Fcn) return std::make_unique<TrainableFcn>(info.inputs, info.width, max_batch);
  throw Error("architecture '" + info.architecture_name() + "' has no trainable network, expected unet or fcn");
}

/// @brief A model read from a file: metadata, glove, and the network or linear map.
struct TrainedModel {
  model::ModelInfo info;                                                 ///< Metadata.
  grid::GloveDescription glove = grid::GloveDescription::glauser2019();  ///< The glove it was trained for.
  std::unique_ptr<TrainableNetwork> network;                             ///< U-Net or FCN (null for linear).
  std::optional<nn::LinearMap> linear;                                   ///< The linear map (linear models).
  std::map<std::string, std::string> metadata;                           ///< Every metadata entry of the file (provenance included).

  /// @brief The training-set calibration range stored in the file; throws unless it has one.
  sensor::CalibrationRange training_range() const {
    std::optional<sensor::CalibrationRange> range = info.training_range(cell_names(info.inputs), glove.calibration().config());
    if (!range)
      throw Error(
          "the model has no training-set calibration range (metadata calibration_min/max), expected one for --calibration-mode training");
    return std::move(*range);
  }

  /// @brief Normalised predictions (frames x 25) for prepared samples, held within the joint limits
  /// as the estimator holds them unless `hold` is false (pose-guided calibration holds after its
  /// offsets: outside_limits); `outside`, when given, adds how many were outside them.
  std::vector<float> predict(const Samples& samples, core::ThreadPool& pool, std::size_t* outside = nullptr, bool hold = true) {
    if (samples.cells != info.inputs)
      throw Error("the samples have " + std::to_string(samples.cells) + " cells per frame, the model takes " + std::to_string(info.inputs));
    std::vector<float> out(static_cast<std::size_t>(samples.frames()) * kTargets);
    std::size_t beyond = 0;
    if (network) {
      out = train::predict(*network, samples, pool, &beyond, hold);
    } else {
      long rejected = -1;
      if (linear->predict(samples.inputs.data(), out.data(), samples.frames(), &rejected) != Status::Ok)
        throw Error("linear model: frame " + std::to_string(rejected) + " has a non-finite input");
      beyond = outside_limits(out.data(), out.size(), hold);
    }
    if (outside) *outside += beyond;
    rest_unlabelled(out);
    return out;
  }

  /// @brief In normalised predictions (frames x 25), the DoFs the model had no reference angles for
  /// set to the rest pose.
  void rest_unlabelled(std::vector<float>& normalized) const {
    const hand::DofSet& labelled = info.labelled_dofs;
    if (labelled == hand::all_dofs()) return;
    const hand::JointLimits limits = info.joint_limits();
    for (std::size_t f = 0; f < normalized.size() / kTargets; ++f) {
      hand::Angles a{};
      for (std::size_t d = 0; d < hand::kDofCount; ++d) a[d] = normalized[f * kTargets + d];
      a = limits.rest_unlabelled(a, labelled);
      for (std::size_t d = 0; d < hand::kDofCount; ++d) normalized[f * kTargets + d] = static_cast<float>(a[d]);
    }
  }
};

/// @brief Writes a model file: `info`, the tensors (stored as `dtype`: F32, F16 or BF16), and
/// `provenance` (extra metadata such as the command and seed that made it), whole or not at all;
/// errors name the "model file" and the cause.
inline void save_model(const std::string& path, const model::ModelInfo& info, const nn::TensorMap& tensors,
                       const std::map<std::string, std::string>& provenance = {}, io::DType dtype = io::DType::F32) {
  nn::WeightFile file;
  file.tensors = tensors;
  for (const auto& [key, value] : provenance) file.metadata[key] = value;
  info.to(file);
  file.to_tensor_file(dtype).write(path, "model file");
}

/// @brief The tensors of a linear map ("weight" [25, cells], "bias" [25], as torch.nn.Linear).
inline nn::TensorMap linear_tensors(const nn::LinearMap& map) {
  return {{"weight", nn::Tensor{{map.outputs(), map.inputs()}, map.weight()}}, {"bias", nn::Tensor{{map.outputs()}, map.bias()}}};
}

/// @brief Reads a model file of any architecture (model::load_model_file), its network sized for
/// batches of `max_batch`. Throws glovepose::Error naming the file and what is wrong.
inline TrainedModel load_model(const std::string& path, int max_batch = 1024) {
  return model::load_model_file(path, [max_batch](model::ModelFile&& file) {
    TrainedModel trained;
    trained.info = std::move(file.info);
    trained.metadata = std::move(file.metadata);
    trained.glove = trained.info.glove_of_model();
    if (trained.info.architecture == model::Architecture::Linear) {
      for (const char* name : {"weight", "bias"})
        if (!file.tensors.count(name))
          throw Error(std::string("tensor '") + name + "' is missing, expected a linear model's weight and bias");
      if (file.tensors.size() != 2) throw Error("a linear model holds exactly the tensors 'weight' and 'bias'");
      const nn::Tensor& w = file.tensors.at("weight");
      if (w.shape != std::vector<std::int64_t>{kTargets, trained.info.inputs})
        throw Error("tensor 'weight' has shape " + io::shape_string(w.shape) + ", expected [25, " + std::to_string(trained.info.inputs) +
                    "]");
      trained.linear.emplace(trained.info.inputs, kTargets, w.values, file.tensors.at("bias").values);
    } else {
      trained.network = make_network(trained.info, trained.glove, max_batch);
      trained.network->parameters().load(file.tensors);
    }
    return trained;
  });
}

}  // namespace glovepose::train
