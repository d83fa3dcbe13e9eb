/// @file model.hpp
/// @brief A model file: the U-Net plus the metadata the estimator needs (weights_format.md).
#pragma once

#include <charconv>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../hand/dofs.hpp"
#include "unet.hpp"
#include "weights.hpp"

namespace glovepose::nn {

/// @brief The metadata of a model file.
struct ModelInfo {
  std::string architecture;              ///< "unet", "fcn" (the paper's fully connected baseline) or "linear".
  int width = 0;                         ///< U-Net base width, FCN hidden width; 0 for linear.
  int inputs = 44;                       ///< Cell values per frame the model takes.
  std::string glove;                     ///< Sensor layout id the model was trained for.
  std::string glove_description;         ///< The glove as data (grid/glove_description.hpp JSON); empty: the built-in glove `glove`.
  std::string calibration = "onthefly";  ///< How inputs were normalised in training: none, training or onthefly.
  double bn_eps = 1e-5;                  ///< Batch-norm epsilon.
  std::vector<double> joint_limits_min;  ///< Per DoF, radians: what output -1 means.
  std::vector<double> joint_limits_max;  ///< Per DoF, radians: what output +1 means.
  std::optional<std::vector<double>> calibration_min;  ///< Per cell, training-set minimum (optional).
  std::optional<std::vector<double>> calibration_max;  ///< Per cell, training-set maximum (optional).
  /// The pose-guided calibration fitted for this model (calibration/pose_offset.hpp JSON, with its
  /// calibration sequence); empty: min-max calibration only.
  std::string pose_offset;
  /// The DoFs the model was trained on reference angles for (hand::dof_set_text()); empty: all 25.
  /// The others were trained toward the rest pose and read it (PoseModel).
  std::string labelled_dofs;

  /// @brief labelled_dofs as a set (every DoF when empty).
  hand::DofSet labelled() const {
    return labelled_dofs.empty() ? hand::all_dofs() : hand::parse_dof_set(labelled_dofs, "metadata 'labelled_dofs'");
  }

  /// @brief Reads and checks the metadata; throws glovepose::Error naming the key that is missing or wrong.
  static ModelInfo from(const WeightFile& file) {
    ModelInfo info;
    if (file.meta("format") != "glovepose-model")
      throw Error("metadata 'format' is '" + file.meta("format") + "', expected 'glovepose-model'");
    if (file.meta("format_version") != "1") throw Error("metadata 'format_version' is '" + file.meta("format_version") + "', expected '1'");
    info.architecture = file.meta("architecture");
    if (info.architecture != "unet" && info.architecture != "fcn" && info.architecture != "linear")
      throw Error("metadata 'architecture' is '" + info.architecture + "', expected 'unet', 'fcn' or 'linear'");
    if (info.architecture != "linear") info.width = parse_int(file.meta("width"), "width");
    if (file.metadata.count("inputs")) info.inputs = parse_int(file.meta("inputs"), "inputs");
    if (file.metadata.count("glove_description")) info.glove_description = file.meta("glove_description");
    if (file.metadata.count("calibration")) info.calibration = file.meta("calibration");
    if (info.calibration != "none" && info.calibration != "training" && info.calibration != "onthefly")
      throw Error("metadata 'calibration' is '" + info.calibration + "', expected none, training or onthefly");
    info.glove = file.meta("glove");
    info.bn_eps = parse_double(file.meta("bn_eps"), "bn_eps");
    info.joint_limits_min = file.meta_numbers("joint_limits_min");
    info.joint_limits_max = file.meta_numbers("joint_limits_max");
    if (info.joint_limits_min.size() != 25 || info.joint_limits_max.size() != 25)
      throw Error("metadata 'joint_limits_min'/'joint_limits_max' hold " + std::to_string(info.joint_limits_min.size()) + "/" +
                  std::to_string(info.joint_limits_max.size()) + " numbers, expected 25 each");
    if (file.metadata.count("calibration_min") || file.metadata.count("calibration_max")) {
      info.calibration_min = file.meta_numbers("calibration_min");
      info.calibration_max = file.meta_numbers("calibration_max");
      if (info.calibration_min->size() != info.calibration_max->size())
        throw Error("metadata 'calibration_min' and 'calibration_max' differ in length");
    }
    if (file.metadata.count("pose_offset")) info.pose_offset = file.meta("pose_offset");
    if (file.metadata.count("labelled_dofs")) {
      info.labelled_dofs = file.meta("labelled_dofs");
      info.labelled();  // throws unless it names a set of DoFs
    }
    return info;
  }

  /// @brief Writes the metadata into a file's metadata map.
  void to(WeightFile& file) const {
    file.metadata["format"] = "glovepose-model";
    file.metadata["format_version"] = "1";
    file.metadata["architecture"] = architecture;
    if (architecture != "linear") file.metadata["width"] = std::to_string(width);
    file.metadata["inputs"] = std::to_string(inputs);
    file.metadata["glove"] = glove;
    if (!glove_description.empty()) file.metadata["glove_description"] = glove_description;
    file.metadata["calibration"] = calibration;
    char eps[32];
    std::snprintf(eps, sizeof eps, "%.17g", bn_eps);
    file.metadata["bn_eps"] = eps;
    file.metadata["joint_limits_min"] = WeightFile::format_numbers(joint_limits_min);
    file.metadata["joint_limits_max"] = WeightFile::format_numbers(joint_limits_max);
    if (calibration_min) file.metadata["calibration_min"] = WeightFile::format_numbers(*calibration_min);
    if (calibration_max) file.metadata["calibration_max"] = WeightFile::format_numbers(*calibration_max);
    if (!pose_offset.empty()) file.metadata["pose_offset"] = pose_offset;
    if (!labelled_dofs.empty()) file.metadata["labelled_dofs"] = labelled_dofs;
  }

 private:
  static int parse_int(const std::string& text, const char* key) {
    std::size_t used = 0;
    int v = 0;
    try {
      v = std::stoi(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != text.size() || v < 1 || v > kMaxWidth)
      throw Error(std::string("metadata '") + key + "' is '" + text + "', expected an integer 1.." + std::to_string(kMaxWidth));
    return v;
  }
  static double parse_double(const std::string& text, const char* key) {
    double v = 0;
    const auto result = std::from_chars(text.data(), text.data() + text.size(), v);  // locale-independent
    if (result.ec != std::errc() || result.ptr != text.data() + text.size() || !(v > 0) || !std::isfinite(v))
      throw Error(std::string("metadata '") + key + "' is '" + text + "', expected a positive number");
    return v;
  }
};

/// @brief A loaded model: the network and its metadata.
template <typename Backend = kernels::SimdBackend>
struct Model {
  ModelInfo info;      ///< Metadata.
  UNet<Backend> unet;  ///< The network.

  /// @brief Loads a model file, with weights kept as `storage`.
  static Model load(const std::string& path, WeightStorage storage = WeightStorage::F32) {
    const WeightFile file = WeightFile::read(path);
    try {
      ModelInfo info = ModelInfo::from(file);
      if (info.architecture != "unet")
        throw Error("architecture '" + info.architecture +
                    "' is not a U-Net; PoseModel::load runs U-Nets and FCNs, train::load_model every architecture");
      UNet<Backend> net = UNet<Backend>::from_tensors(file.tensors, info.width, info.bn_eps, storage);
      return Model{std::move(info), std::move(net)};
    } catch (const Error& e) {
      throw Error("model file '" + path + "': " + e.what());
    }
  }
};

}  // namespace glovepose::nn
