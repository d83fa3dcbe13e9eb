/// @file pose_model.hpp
/// @brief PoseModel: what is loaded once and shared, immutable, by any number of estimators on any
/// number of threads: the network (U-Net or FCN), the glove description, the capacitance solver of
/// the glove's wiring, the joint limits, the labelled DoFs, the model's training-set calibration
/// range and its pose-guided calibration. Loading is set-up code and throws glovepose::Error.
#pragma once

#include <algorithm>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "calibration/pose_offset.hpp"
#include "config.hpp"
#include "grid/glove_description.hpp"
#include "grid/grid_map.hpp"
#include "hand/dofs.hpp"
#include "model/model_file.hpp"
#include "model/model_info.hpp"
#include "model/pose_network.hpp"
#include "sensor/calibration.hpp"
#include "sensor/layout.hpp"
#include "sensor/solver.hpp"

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

/// @brief A loaded model with everything the estimators share. Immutable; share it with
/// std::shared_ptr<const PoseModel> between estimators and threads.
class PoseModel {
 public:
  /// @brief The solver of a glove wiring of any size.
  using Solver = sensor::CapacitanceSolver;
  /// @brief The network: the U-Net or the FCN the model file holds.
  using Network = model::PoseNetwork;

  /// @brief Loads a model file (weights_format.md). Throws glovepose::Error naming the file and what
  /// is wrong: unreadable or malformed file, not a U-Net or FCN, or a glove or wiring that does not fit it.
  static std::shared_ptr<const PoseModel> load(const std::string& path, PoseModelOptions options = {}) {
    return model::load_model_file(path, [&options](model::ModelFile&& file) {
      Network network = Network::from_tensors(file.info, file.tensors, options.storage);
      return std::make_shared<const PoseModel>(std::move(file.info), std::move(network), std::move(options));
    });
  }

  /// @brief A model from its parts (see load()). Throws glovepose::Error when the glove's cell count
  /// or id differs from the model's, or the wiring's cells differ from the glove's.
  PoseModel(model::ModelInfo info, Network network, PoseModelOptions options)
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
      solver_ = std::make_shared<const Solver>(*layout);
    }
    limits_ = info_.joint_limits();
    all_labelled_ = info_.labelled_dofs == hand::all_dofs();
    rest_normalized_ = limits_.normalize(limits_.rest());
    if (info_.pose_offset && info_.pose_offset->cells() != glove_.cell_count())
      throw Error("metadata 'pose_offset' reads " + std::to_string(info_.pose_offset->cells()) + " cells, expected " +
                  std::to_string(glove_.cell_count()) + " (the glove's)");
    training_range_ = info_.training_range(glove_.cell_names(), glove_.calibration().config());
  }

  /// @brief The file's metadata.
  const model::ModelInfo& info() const noexcept { return info_; }
  /// @brief The network.
  const Network& network() const noexcept { return network_; }
  /// @brief The glove the model reads.
  const grid::GloveDescription& glove() const noexcept { return glove_; }
  /// @brief Number of sensor cells.
  int cell_count() const noexcept { return glove_.cell_count(); }
  /// @brief The solver of the glove's wiring; null when no wiring is known (C_c input only).
  const std::shared_ptr<const Solver>& solver() const noexcept { return solver_; }
  /// @brief What the network's outputs -1 and +1 mean, per DoF.
  const hand::JointLimits& joint_limits() const noexcept { return limits_; }
  /// @brief The DoFs the model was trained on reference angles for; the others read the rest pose
  /// (hand::JointLimits::rest()) whatever the glove does.
  const hand::DofSet& labelled_dofs() const noexcept { return info_.labelled_dofs; }
  /// @brief The network's normalised outputs as the model reads them: DoFs outside labelled_dofs()
  /// at the rest pose.
  GLOVEPOSE_REALTIME hand::Angles model_outputs(const hand::Angles& normalized) const noexcept {
    if (all_labelled_) return normalized;
    hand::Angles out = normalized;  // the rest pose computed once at load, not per frame
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      if (!info_.labelled_dofs[d]) out[d] = rest_normalized_[d];
    return out;
  }
  /// @brief The training data's per-cell range, when the file records one.
  const std::optional<sensor::CalibrationRange>& training_range() const noexcept { return training_range_; }
  /// @brief The pose-guided calibration fitted for the model (with its calibration sequence), if any.
  const std::optional<calibration::PoseOffsetModel>& pose_offset() const noexcept { return info_.pose_offset; }

  /// @brief The batch path, for evaluation and tests: `frames` rows of `cell_count()` solved
  /// capacitances C_c, normalised by `range`, through the network on `threads` threads -> one
  /// Angles per frame (radians, unsmoothed). Set-up code: allocates; throws glovepose::Error for a
  /// range of another size or a non-finite value (naming the frame).
  std::vector<hand::Angles> predict(const float* cells, long frames, const sensor::CalibrationRange& range, int threads = 1) const {
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
      angles = network_.normalized_dofs_batch(glove_.map(), normalized_cells.data(), n, frames, threads);
    } catch (const Error& e) {
      throw Error(std::string("PoseModel::predict: ") + e.what());
    }
    for (hand::Angles& a : angles) a = limits_.denormalize(model_outputs(a));
    return angles;
  }

 private:
  static grid::GloveDescription choose_glove(const model::ModelInfo& info, std::optional<grid::GloveDescription>& given) {
    if (given) return std::move(*given);
    try {
      return info.glove_of_model();
    } catch (const Error& e) {
      throw Error(std::string(e.what()) + " (or a glove given as PoseModelOptions::glove)");
    }
  }

  model::ModelInfo info_;
  Network network_;
  grid::GloveDescription glove_;
  std::shared_ptr<const Solver> solver_;
  hand::JointLimits limits_;
  bool all_labelled_ = true;
  hand::Angles rest_normalized_{};
  std::optional<sensor::CalibrationRange> training_range_;
};

}  // namespace glovepose
