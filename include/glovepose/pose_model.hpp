/// @file pose_model.hpp
/// @brief PoseModel: what is loaded once and shared, immutable, by any number of estimators on any
/// number of threads: the network (U-Net or FCN), the glove description, the capacitance solver of
/// the glove's wiring, the joint limits, the labelled DoFs, the model's training-set calibration
/// range and its pose-guided calibration. Loading is set-up code and throws glovepose::Error.
///
/// The class is a narrow front: its parts are types of their own headers, declared here only, so a
/// unit that loads a model and runs an estimator compiles no Eigen, network or file code. Header-only
/// use (glovepose::glovepose) defines the members inline (detail/pose_model_impl.hpp); the compiled
/// library (glovepose::compiled, GLOVEPOSE_COMPILED_LIB) holds them.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "config.hpp"
#include "hand/dofs.hpp"

namespace glovepose {

namespace calibration {
class PoseOffsetModel;  // calibration/pose_offset.hpp
class RangeMap;         // calibration/free_motion.hpp
}  // namespace calibration
namespace grid {
class GloveDescription;  // grid/glove_description.hpp
}  // namespace grid
namespace model {
class PoseNetwork;     // model/pose_network.hpp
class PoseErrorModel;  // model/pose_error.hpp
struct ModelInfo;   // model/model_info.hpp
}  // namespace model
namespace sensor {
class CalibrationRange;   // sensor/calibration.hpp
class CapacitanceSolver;  // sensor/solver.hpp
}  // namespace sensor
struct PoseModelOptions;  // pose_model_options.hpp

/// @brief A loaded model with everything the estimators share. Immutable; share it with
/// std::shared_ptr<const PoseModel> between estimators and threads.
class PoseModel {
 public:
  /// @brief The solver of a glove wiring of any size.
  using Solver = sensor::CapacitanceSolver;
  /// @brief The network: the U-Net or the FCN the model file holds.
  using Network = model::PoseNetwork;

  /// @brief Loads a model file (weights_format.md) with the default options (F32 weights, the glove
  /// and wiring the file names). Throws glovepose::Error naming the file and what is wrong:
  /// unreadable or malformed file, not a U-Net or FCN, or a glove or wiring that does not fit it.
  static std::shared_ptr<const PoseModel> load(const std::string& path);
  /// @brief Loads a model file with `options` (pose_model_options.hpp).
  static std::shared_ptr<const PoseModel> load(const std::string& path, const PoseModelOptions& options);

  /// @brief A model from its parts (see load()). Throws glovepose::Error when the glove's cell count
  /// or id differs from the model's, or the wiring's cells differ from the glove's.
  PoseModel(model::ModelInfo info, Network network, PoseModelOptions options);
  PoseModel(PoseModel&&) noexcept;
  PoseModel& operator=(PoseModel&&) noexcept;
  ~PoseModel();

  /// @brief The file's metadata.
  const model::ModelInfo& info() const noexcept;
  /// @brief The network.
  const Network& network() const noexcept;
  /// @brief The glove the model reads.
  const grid::GloveDescription& glove() const noexcept;
  /// @brief Number of sensor cells.
  int cell_count() const noexcept;
  /// @brief The solver of the glove's wiring; null when no wiring is known (C_c input only).
  const std::shared_ptr<const Solver>& solver() const noexcept;
  /// @brief What the network's outputs -1 and +1 mean, per DoF.
  const hand::JointLimits& joint_limits() const noexcept;
  /// @brief The DoFs the model was trained on reference angles for; the others read the rest pose
  /// (hand::JointLimits::rest()) whatever the glove does.
  const hand::DofSet& labelled_dofs() const noexcept;
  /// @brief The network's normalised outputs as the model reads them: DoFs outside labelled_dofs()
  /// at the rest pose. Not yet held within the joint limits (the FCN's last layer is linear and can
  /// overshoot them): a pose is held there as its last step, after any pose-guided offsets.
  GLOVEPOSE_REALTIME hand::Angles model_outputs(const hand::Angles& normalized) const noexcept;
  /// @brief A pose's angles (radians) from the network's normalised outputs, without pose-guided
  /// offsets: model_outputs() in the joint limits' units, held within them. What predict() and an
  /// estimator without offsets give.
  GLOVEPOSE_REALTIME hand::Angles held_angles(const hand::Angles& normalized) const noexcept;
  /// @brief The training data's per-cell range, when the file records one.
  const std::optional<sensor::CalibrationRange>& training_range() const noexcept;
  /// @brief The pose-guided calibration fitted for the model (with its calibration sequence), if any.
  const std::optional<calibration::PoseOffsetModel>& pose_offset() const noexcept;
  /// @brief The map from a wearer's free motion to their calibration range (the continuous
  /// calibration's; calibration/free_motion.hpp), if the model carries one.
  const std::optional<calibration::RangeMap>& range_map() const noexcept;
  /// @brief The model's own per-DoF errors (model/pose_error.hpp), behind each pose's confidence, if
  /// the model carries them.
  const std::optional<model::PoseErrorModel>& pose_error() const noexcept;

  /// @brief The batch path, for evaluation and tests: `frames` rows of `cell_count()` solved
  /// capacitances C_c, normalised by `range`, through the network on `threads` threads -> one
  /// Angles per frame (radians, unsmoothed). Set-up code: allocates; throws glovepose::Error for a
  /// range of another size or a non-finite value (naming the frame).
  std::vector<hand::Angles> predict(const float* cells, long frames, const sensor::CalibrationRange& range, int threads = 1) const;

 private:
  struct Parts;  // detail/pose_model_impl.hpp
  std::unique_ptr<Parts> parts_;
};

}  // namespace glovepose

#ifndef GLOVEPOSE_COMPILED_LIB
#include "detail/pose_model_impl.hpp"
#endif
