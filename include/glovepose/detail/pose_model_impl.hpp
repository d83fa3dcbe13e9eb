/// @file pose_model_impl.hpp
/// @brief PoseModel's members (pose_model.hpp): inline in header-only use, compiled once into
/// glovepose::compiled otherwise (src/pose_model.cpp).
#pragma once

#include <algorithm>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "../calibration/free_motion.hpp"
#include "../calibration/pose_offset.hpp"
#include "../config.hpp"
#include "../grid/glove_description.hpp"
#include "../grid/grid_map.hpp"
#include "../hand/dofs.hpp"
#include "../model/model_file.hpp"
#include "../model/model_info.hpp"
#include "../model/pose_network.hpp"
#include "../pose_model.hpp"
#include "../pose_model_options.hpp"
#include "../sensor/calibration.hpp"
#include "../sensor/layout.hpp"
#include "../sensor/solver.hpp"

namespace glovepose {

struct PoseModel::Parts {
  Parts(model::ModelInfo info, PoseModel::Network network, PoseModelOptions options)
      : info_(std::move(info)), network_(std::move(network)), glove_(choose_glove(info_, options.glove)) {
    if (glove_.cell_count() != info_.inputs)
      throw Error("glove '" + glove_.id() + "' has " + std::to_string(glove_.cell_count()) + " cells, expected " +
                  std::to_string(info_.inputs) + " (the model's inputs)");
    if (network_.required_cells() != 0 && network_.required_cells() != info_.inputs)
      throw Error("the network reads " + std::to_string(network_.required_cells()) + " cells, expected " + std::to_string(info_.inputs) +
                  " (metadata 'inputs')");
    if (glove_.id() != info_.glove) throw Error("glove '" + glove_.id() + "' given, expected the model's glove '" + info_.glove + "'");
    if (network_.architecture() == model::Architecture::UNet && network_.extra_inputs() != glove_.map().extra_input_count())
      throw Error("the U-Net reads " + std::to_string(network_.extra_inputs()) + " extra input planes (enc1.weight), expected " +
                  std::to_string(glove_.map().extra_input_count()) + " (glove '" + glove_.id() + "' has that many extra inputs)");
    std::optional<sensor::TraceLayout> layout = std::move(options.layout);
    if (!layout && glove_.id() == grid::GloveDescription::glauser2019().id()) layout = sensor::TraceLayout::glauser2019();
    if (layout) {
      if (layout->cell_count() != glove_.cell_count())
        throw Error("wiring '" + layout->id() + "' has " + std::to_string(layout->cell_count()) + " cells, expected " +
                    std::to_string(glove_.cell_count()) + " (the glove's)");
      solver_ = std::make_shared<const PoseModel::Solver>(*layout);
    }
    limits_ = info_.joint_limits();
    all_labelled_ = info_.labelled_dofs == hand::all_dofs();
    rest_normalized_ = limits_.normalize(limits_.rest());
    if (info_.pose_offset && info_.pose_offset->cells() != glove_.cell_count())
      throw Error("metadata 'pose_offset' reads " + std::to_string(info_.pose_offset->cells()) + " cells, expected " +
                  std::to_string(glove_.cell_count()) + " (the glove's)");
    if (info_.range_map && info_.range_map->cells() != glove_.cell_count())
      throw Error("metadata 'range_map' reads " + std::to_string(info_.range_map->cells()) + " cells, expected " +
                  std::to_string(glove_.cell_count()) + " (the glove's)");
    if (info_.pose_error && info_.pose_error->cells() != glove_.cell_count())
      throw Error("metadata 'pose_error' covers " + std::to_string(info_.pose_error->cells()) + " cells, expected " +
                  std::to_string(glove_.cell_count()) + " (the glove's)");
    training_range_ = info_.training_range(glove_.cell_names(), glove_.calibration().config());
  }

  static grid::GloveDescription choose_glove(const model::ModelInfo& info, std::optional<grid::GloveDescription>& given) {
    if (given) return std::move(*given);
    try {
      return info.glove_of_model();
    } catch (const Error& e) {
      throw Error(std::string(e.what()) + " (or a glove given as PoseModelOptions::glove)");
    }
  }

  model::ModelInfo info_;
  PoseModel::Network network_;
  grid::GloveDescription glove_;
  std::shared_ptr<const PoseModel::Solver> solver_;
  hand::JointLimits limits_;
  bool all_labelled_ = true;
  hand::Angles rest_normalized_{};
  std::optional<sensor::CalibrationRange> training_range_;
};

GLOVEPOSE_INLINE std::shared_ptr<const PoseModel> PoseModel::load(const std::string& path) { return load(path, PoseModelOptions{}); }

GLOVEPOSE_INLINE std::shared_ptr<const PoseModel> PoseModel::load(const std::string& path, const PoseModelOptions& options) {
  return model::load_model_file(path, [&options](model::ModelFile&& file) {
    Network network = Network::from_tensors(file.info, file.tensors, options.storage);
    return std::make_shared<const PoseModel>(std::move(file.info), std::move(network), options);
  });
}

GLOVEPOSE_INLINE PoseModel::PoseModel(model::ModelInfo info, Network network, PoseModelOptions options)
    : parts_(std::make_unique<Parts>(std::move(info), std::move(network), std::move(options))) {}
GLOVEPOSE_INLINE PoseModel::PoseModel(PoseModel&&) noexcept = default;
GLOVEPOSE_INLINE PoseModel& PoseModel::operator=(PoseModel&&) noexcept = default;
GLOVEPOSE_INLINE PoseModel::~PoseModel() = default;

GLOVEPOSE_INLINE const model::ModelInfo& PoseModel::info() const noexcept { return parts_->info_; }
GLOVEPOSE_INLINE const PoseModel::Network& PoseModel::network() const noexcept { return parts_->network_; }
GLOVEPOSE_INLINE const grid::GloveDescription& PoseModel::glove() const noexcept { return parts_->glove_; }
GLOVEPOSE_INLINE int PoseModel::cell_count() const noexcept { return parts_->glove_.cell_count(); }
GLOVEPOSE_INLINE const std::shared_ptr<const PoseModel::Solver>& PoseModel::solver() const noexcept { return parts_->solver_; }
GLOVEPOSE_INLINE const hand::JointLimits& PoseModel::joint_limits() const noexcept { return parts_->limits_; }
GLOVEPOSE_INLINE const hand::DofSet& PoseModel::labelled_dofs() const noexcept { return parts_->info_.labelled_dofs; }
GLOVEPOSE_INLINE const std::optional<sensor::CalibrationRange>& PoseModel::training_range() const noexcept { return parts_->training_range_; }
GLOVEPOSE_INLINE const std::optional<calibration::PoseOffsetModel>& PoseModel::pose_offset() const noexcept {
  return parts_->info_.pose_offset;
}
GLOVEPOSE_INLINE const std::optional<calibration::RangeMap>& PoseModel::range_map() const noexcept { return parts_->info_.range_map; }
GLOVEPOSE_INLINE const std::optional<model::PoseErrorModel>& PoseModel::pose_error() const noexcept { return parts_->info_.pose_error; }

GLOVEPOSE_INLINE hand::Angles PoseModel::model_outputs(const hand::Angles& normalized) const noexcept {
  if (parts_->all_labelled_) return normalized;
  hand::Angles out = normalized;  // the rest pose computed once at load, not per frame
  for (std::size_t d = 0; d < hand::kDofCount; ++d)
    if (!parts_->info_.labelled_dofs[d]) out[d] = parts_->rest_normalized_[d];
  return out;
}

GLOVEPOSE_INLINE hand::Angles PoseModel::held_angles(const hand::Angles& normalized) const noexcept {
  return parts_->limits_.clamp(parts_->limits_.denormalize(model_outputs(normalized)));
}

GLOVEPOSE_INLINE std::vector<hand::Angles> PoseModel::predict(const float* cells, long frames, const sensor::CalibrationRange& range,
                                                            int threads) const {
  const int n = cell_count();
  if (range.size() != n)
    throw Error("PoseModel::predict: calibration range of " + std::to_string(range.size()) + " cells, expected " + std::to_string(n));
  std::vector<float> normalized_cells(static_cast<std::size_t>(frames) * static_cast<std::size_t>(n));
  Eigen::VectorXd raw(n), normalized(n);
  for (long f = 0; f < frames; ++f) {
    for (int c = 0; c < n; ++c) raw(c) = cells[f * n + c];
    if (range.normalize(raw, normalized) != Status::Ok)
      throw Error("PoseModel::predict: frame " + std::to_string(f) + " has a non-finite cell value, expected finite C_c");
    for (int c = 0; c < n; ++c) normalized_cells[static_cast<std::size_t>(f * n + c)] = static_cast<float>(normalized(c));
  }
  std::vector<hand::Angles> angles;
  try {
    angles = parts_->network_.normalized_dofs_batch(parts_->glove_.map(), normalized_cells.data(), n, frames, threads);
  } catch (const Error& e) {
    throw Error(std::string("PoseModel::predict: ") + e.what());
  }
  for (hand::Angles& a : angles) a = held_angles(a);
  return angles;
}

}  // namespace glovepose
