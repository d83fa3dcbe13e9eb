/// @file model_info.hpp
/// @brief The metadata of a model file (weights_format.md), read, parsed and checked in one place
/// into typed fields: the architecture, the glove it was trained for (and its description), how
/// its inputs were calibrated, what its outputs mean (joint limits), the DoFs it was trained on,
/// the training set's per-cell range and its pose-guided calibration. Written back from the same
/// fields, so a file this code wrote reads and writes again byte for byte.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "../calibration/free_motion.hpp"
#include "../calibration/pose_offset.hpp"
#include "../config.hpp"
#include "../grid/glove_description.hpp"
#include "../hand/dofs.hpp"
#include "../nn/unet.hpp"
#include "../nn/weights.hpp"
#include "../sensor/calibration.hpp"
#include "architecture.hpp"
#include "pose_error.hpp"

namespace glovepose::model {

/// @brief How cell values are normalised before the network.
/// Continuous (the wearer's free motion through the model's range map, calibration/free_motion.hpp)
/// is a way to evaluate a model, never one to train it.
enum class CalibrationMode : unsigned char { None, Training, OnTheFly, Continuous };

/// @brief "none", "training", "onthefly" or "continuous".
constexpr const char* to_string(CalibrationMode mode) noexcept {
  switch (mode) {
    case CalibrationMode::None: return "none";
    case CalibrationMode::Training: return "training";
    case CalibrationMode::OnTheFly: return "onthefly";
    case CalibrationMode::Continuous: return "continuous";
  }
  return "none";
}

/// @brief Parses a way to train: "none", "training" or "onthefly"; throws glovepose::Error otherwise.
inline CalibrationMode calibration_mode(const std::string& text) {
  if (text == "none") return CalibrationMode::None;
  if (text == "training") return CalibrationMode::Training;
  if (text == "onthefly") return CalibrationMode::OnTheFly;
  throw Error("calibration mode '" + text + "', expected none, training or onthefly");
}

/// @brief Parses a way to evaluate: calibration_mode()'s or "continuous".
inline CalibrationMode evaluation_calibration_mode(const std::string& text) {
  return text == "continuous" ? CalibrationMode::Continuous : calibration_mode(text);
}

/// @brief The metadata of a model file.
struct ModelInfo {
  Architecture architecture = Architecture::UNet;  ///< The network the file holds.
  int width = 0;                  ///< U-Net base width, FCN hidden width; 0 for linear.
  int inputs = 44;                ///< Cell values per frame the model takes.
  std::string glove;              ///< Sensor layout id the model was trained for.
  /// The glove as data (metadata 'glove_description'); none: the built-in glove `glove`.
  std::optional<grid::GloveDescription> glove_description;
  CalibrationMode calibration = CalibrationMode::OnTheFly;  ///< How inputs were normalised in training.
  double bn_eps = 1e-5;                                     ///< Batch-norm epsilon.
  std::vector<double> joint_limits_min;                     ///< Per DoF, radians: what output -1 means.
  std::vector<double> joint_limits_max;                     ///< Per DoF, radians: what output +1 means.
  std::optional<std::vector<double>> calibration_min;       ///< Per cell, training-set minimum (optional).
  std::optional<std::vector<double>> calibration_max;       ///< Per cell, training-set maximum (optional).
  /// The pose-guided calibration fitted for this model, with its calibration sequence (metadata
  /// 'pose_offset'); none: min-max calibration only.
  std::optional<calibration::PoseOffsetModel> pose_offset;
  /// The map from a wearer's free motion to their calibration range, fitted for this model
  /// (metadata 'range_map'); none: no calibration without a calibration step.
  std::optional<calibration::RangeMap> range_map;
  /// The model's own per-DoF errors on people it was not trained on, from which poses get their
  /// per-joint confidence (metadata 'pose_error'; pose_error.hpp); none: the confidence says only
  /// whether the pose is trusted.
  std::optional<PoseErrorModel> pose_error;
  /// The DoFs the model was trained on reference angles for (metadata 'labelled_dofs', absent when
  /// all 25). The others were trained toward the rest pose and read it (PoseModel).
  hand::DofSet labelled_dofs = hand::all_dofs();

  /// @brief The architecture as the file spells it ("unet", "fcn" or "linear").
  std::string architecture_name() const { return to_string(architecture); }

  /// @brief What the network's outputs -1 and +1 mean, per DoF.
  hand::JointLimits joint_limits() const {
    hand::Angles lo{}, hi{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      lo[d] = joint_limits_min[d];
      hi[d] = joint_limits_max[d];
    }
    return hand::JointLimits(lo, hi);
  }

  /// @brief The glove the model reads: its description in the file, else the built-in glove the id
  /// names. Throws glovepose::Error when neither is there or its cell count differs from `inputs`.
  grid::GloveDescription glove_of_model() const {
    grid::GloveDescription described = glove_description ? *glove_description : grid::GloveDescription::of_model(glove, "");
    if (described.cell_count() != inputs)
      throw Error("metadata 'inputs' is " + std::to_string(inputs) + " but glove '" + described.id() + "' has " +
                  std::to_string(described.cell_count()) + " cells");
    return described;
  }

  /// @brief The training set's per-cell range the file records (none when it records none), for
  /// cells named `names` and calibrated by `config`. Throws glovepose::Error when the file's range
  /// holds another number of cells.
  std::optional<sensor::CalibrationRange> training_range(const std::vector<std::string>& names,
                                                         const sensor::CalibrationConfig& config) const {
    if (!calibration_min || !calibration_max) return std::nullopt;
    if (calibration_min->size() != names.size())
      throw Error("metadata 'calibration_min' holds " + std::to_string(calibration_min->size()) + " numbers, expected " +
                  std::to_string(names.size()) + " (one per cell)");
    const auto n = static_cast<Eigen::Index>(names.size());
    return sensor::CalibrationRange(Eigen::Map<const Eigen::VectorXd>(calibration_min->data(), n),
                                    Eigen::Map<const Eigen::VectorXd>(calibration_max->data(), n), names, config);
  }

  /// @brief Reads and checks the metadata; throws glovepose::Error naming the key that is missing or wrong.
  static ModelInfo from(const nn::WeightFile& file) {
    ModelInfo info;
    if (file.meta("format") != "glovepose-model")
      throw Error("metadata 'format' is '" + file.meta("format") + "', expected 'glovepose-model'");
    if (file.meta("format_version") != "1") throw Error("metadata 'format_version' is '" + file.meta("format_version") + "', expected '1'");
    try {
      info.architecture = model::architecture(file.meta("architecture"));
    } catch (const Error& e) {
      throw Error(std::string("metadata 'architecture': ") + e.what());
    }
    if (info.architecture != Architecture::Linear) info.width = parse_int(file.meta("width"), "width");
    if (file.metadata.count("inputs")) info.inputs = parse_int(file.meta("inputs"), "inputs");
    if (file.metadata.count("glove_description")) {
      try {
        info.glove_description = grid::GloveDescription::from_metadata(file.meta("glove_description"));
      } catch (const Error& e) {
        throw Error(std::string("metadata 'glove_description': ") + e.what());
      }
    }
    if (file.metadata.count("calibration")) {
      try {
        info.calibration = calibration_mode(file.meta("calibration"));
      } catch (const Error& e) {
        throw Error(std::string("metadata 'calibration': ") + e.what());
      }
    }
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
    if (file.metadata.count("pose_offset"))  // the one parse of the pose offset's JSON
      info.pose_offset = calibration::PoseOffsetModel::parse(file.meta("pose_offset"), "metadata 'pose_offset'");
    if (file.metadata.count("range_map")) info.range_map = calibration::RangeMap::parse(file.meta("range_map"), "metadata 'range_map'");
    if (file.metadata.count("pose_error")) info.pose_error = PoseErrorModel::parse(file.meta("pose_error"), "metadata 'pose_error'");
    if (file.metadata.count("labelled_dofs")) info.labelled_dofs = hand::parse_dof_set(file.meta("labelled_dofs"), "metadata 'labelled_dofs'");
    return info;
  }

  /// @brief Writes the metadata into a file's metadata map, each typed field in the text from()
  /// reads. Throws glovepose::Error when labelled_dofs names no DoF (no file could say so).
  void to(nn::WeightFile& file) const {
    if (labelled_dofs == hand::DofSet{}) throw Error("labelled_dofs names no DoF, expected at least one (or all: the key left out)");
    file.metadata["format"] = "glovepose-model";
    file.metadata["format_version"] = "1";
    file.metadata["architecture"] = to_string(architecture);
    if (architecture != Architecture::Linear) file.metadata["width"] = std::to_string(width);
    file.metadata["inputs"] = std::to_string(inputs);
    file.metadata["glove"] = glove;
    if (glove_description) file.metadata["glove_description"] = glove_description->to_metadata();
    file.metadata["calibration"] = to_string(calibration);
    char eps[32];
    std::snprintf(eps, sizeof eps, "%.17g", bn_eps);
    file.metadata["bn_eps"] = eps;
    file.metadata["joint_limits_min"] = nn::WeightFile::format_numbers(joint_limits_min);
    file.metadata["joint_limits_max"] = nn::WeightFile::format_numbers(joint_limits_max);
    if (calibration_min) file.metadata["calibration_min"] = nn::WeightFile::format_numbers(*calibration_min);
    if (calibration_max) file.metadata["calibration_max"] = nn::WeightFile::format_numbers(*calibration_max);
    if (pose_offset) file.metadata["pose_offset"] = pose_offset->to_json();
    if (range_map) file.metadata["range_map"] = range_map->to_json();
    if (pose_error) file.metadata["pose_error"] = pose_error->to_json();
    if (labelled_dofs != hand::all_dofs()) file.metadata["labelled_dofs"] = hand::dof_set_text(labelled_dofs);
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
    if (used != text.size() || v < 1 || v > nn::kMaxWidth)
      throw Error(std::string("metadata '") + key + "' is '" + text + "', expected an integer 1.." + std::to_string(nn::kMaxWidth));
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

}  // namespace glovepose::model
