/// @file estimator.hpp
/// @brief GlovePoseEstimator: the one class that composes the stages, from the glove's rows to a
/// hand pose (docs/architecture.md).
///
/// Two objects:
/// - PoseModel: what is loaded once and shared, immutable, by any number of estimators on any number
///   of threads: the network, the glove description, the capacitance solver of the glove's wiring,
///   the joint limits and the model's training-set calibration range.
/// - GlovePoseEstimator: one glove's stream. It owns the per-stream state (the readout ring, the
///   calibration, the 1-euro filter, the network's workspace) and answers every per-frame call
///   without allocating or throwing.
///
/// Inputs, whichever the glove's firmware delivers: raw rows (row, value, timestamp), whole frames
/// of compound measurements C_m, or already solved cell capacitances C_c. Each accepted input that
/// completes a frame yields a Pose: 25 angles, timestamp, status flags, and the frame's latency
/// budget (age of the oldest reading, compute time).
///
/// Both classes are narrow fronts: what they return is declared here or in the light headers of
/// pose.hpp and estimator_config.hpp, and the stages behind them (detail/estimator_core.hpp) are
/// their own headers' business. A unit that runs an estimator against the compiled library
/// (glovepose::compiled) therefore compiles declarations only; header-only use defines the members
/// inline (detail/estimator_impl.hpp). Types returned by reference that are only declared here
/// (the calibration range, the OpenXR locator and aim, the contact result) need their own header
/// where they are used: sensor/calibration.hpp, hand/xr_hand.hpp, hand/contact.hpp.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "config.hpp"
#include "core/span.hpp"
#include "estimator_config.hpp"
#include "hand/dofs.hpp"
#include "hand/joint_list_types.hpp"
#include "pose.hpp"
#include "pose_model.hpp"
#include "status.hpp"

namespace glovepose {

namespace detail {
class EstimatorCore;  // detail/estimator_core.hpp
}  // namespace detail
namespace hand {
struct ContactResult;  // hand/contact.hpp
struct XrHandJoints;   // hand/xr_hand.hpp
struct XrHandAim;      // hand/xr_hand.hpp
class XrHandLocator;   // hand/xr_hand.hpp
}  // namespace hand

/// @brief One glove stream: rows, frames or solved cells in, poses out. See the file comment.
///
/// Per-frame calls (push_*, pose(), joints(), calibration_progress(), start/cancel_calibration(),
/// reset()) are noexcept and never allocate. Calibration calls that build a range (finish, set,
/// load, save, use_training_calibration) are set-up code and throw glovepose::Error.
/// One estimator is used by one thread at a time; estimators sharing a model may run concurrently.
/// A moved-from estimator may only be assigned to or destroyed.
class GlovePoseEstimator {
 public:
  /// @brief An estimator over a shared model. Throws glovepose::Error for a null model or bad settings.
  explicit GlovePoseEstimator(std::shared_ptr<const PoseModel> model, EstimatorConfig config = {});
  GlovePoseEstimator(GlovePoseEstimator&&) noexcept;
  GlovePoseEstimator& operator=(GlovePoseEstimator&&) noexcept;
  ~GlovePoseEstimator();

  // ---- input -------------------------------------------------------------------------------

  /// @brief One reading of measurement row `row` at `timestamp` (s). Returns Status::Solved when it
  /// completed a frame and a new pose is in pose(); Status::Ok or Status::NotReady when accepted
  /// without a new pose; Status::Uncalibrated when a frame was solved but no calibration range is
  /// set; a rejection status (sensor/readout.hpp) otherwise, or Status::UnknownIndex when the model
  /// has no wiring. A rejected reading changes nothing but the count in Pose::rejected.
  GLOVEPOSE_REALTIME Status push_row(int row, double value, double timestamp) noexcept;
  /// @brief A whole frame of `count` compound measurements C_m at `timestamp`, solved at once. Bad
  /// rows are skipped (their previous readings stay in use) and counted; see Readout::push_frame.
  GLOVEPOSE_REALTIME Status push_measurements(const double* values, int count, double timestamp) noexcept;
  /// @brief A frame of `count` already solved cell capacitances C_c at `timestamp` (firmware that
  /// solves on board). `oldest_age` is the age of its oldest reading, if the firmware knows it.
  /// After a gap (ReadoutConfig::gap_seconds) or a clock restart (clock_restart_frames frames
  /// timestamped backwards in a row; fewer are rejected) the smoothing starts over.
  GLOVEPOSE_REALTIME Status push_cells(const double* cells, int count, double timestamp, double oldest_age = 0.0) noexcept;

  // ---- output ------------------------------------------------------------------------------

  /// @brief The latest pose (Pose::valid is false before the first).
  const Pose& pose() const noexcept;
  /// @brief The latest joint list (metres, quaternions; hand/joint_list_types.hpp), when joint_transforms is on.
  const hand::JointList& joints() const noexcept;
  /// @brief The latest cells before calibration: the solved capacitances C_c, each input the glove
  /// description conditions less its rolling mean (demean_seconds), as training saw them.
  core::Span<const double> cells() const noexcept;
  /// @brief The latest calibrated cells in [-1, 1] (the network's input), when a pose came from them.
  core::Span<const double> normalized_cells() const noexcept;
  /// @brief The latest pose, joint list, calibration progress and rate together (for LatestHand).
  /// The rate is filter::Trend::slope(), kept as poses arrive: a few dozen nanoseconds.
  HandState state() const noexcept;
  /// @brief What the contact stage (EstimatorConfig::contact) did to the latest pose: the pairs in
  /// contact and the one adjusted (none when the stage is off).
  const hand::ContactResult& contact() const noexcept;

  /// @brief The pose at time t (the stream's clock): from the recent poses when t is not after the
  /// newest (interpolated; the oldest held for earlier times), else extrapolated along the recent
  /// poses' slope for at most EstimatorConfig::max_prediction seconds, held within the joint limits.
  /// Status::NotReady before the first pose (since the last reset), NonFinite for a non-finite t.
  GLOVEPOSE_REALTIME Status pose_at(double t, PredictedPose& out) const noexcept;
  /// @brief The OpenXR joints (hand/xr_hand.hpp) at time t, located from pose_at(t), with velocities.
  GLOVEPOSE_REALTIME Status joints_at(double t, hand::XrHandJoints& out) const noexcept;
  /// @brief The pinch and aim state of the latest pose (hand/xr_hand.hpp, XR_FB_hand_tracking_aim):
  /// pinch strengths, the pinching flags with their hysteresis kept from pose to pose, the aim pose
  /// in the wrist frame. active is false before the first pose. Publish it to reader threads with a
  /// hand::LatestAim beside the LatestHand.
  const hand::XrHandAim& aim() const noexcept;
  /// @brief The locator of this estimator's hand (side, hand model, joint limits), for readers of
  /// LatestHand that locate joints on their own thread (pose_prediction.hpp: predict() and locate()).
  const hand::XrHandLocator& locator() const noexcept;
  /// @brief The cells of the latest frame that stopped being measured (a torn trace) and were stood
  /// in for from the others (EstimatorConfig::floating_cells; the pose carries kPoseMaskedCells), in
  /// index order; empty when every cell is measured.
  const std::vector<int>& masked_cells() const noexcept;
  /// @brief Whether the cells look like the glove lying off the hand (EstimatorConfig::donning; poses
  /// carry kPoseGloveOff meanwhile). CalibrationProgress::donnings counts the times it was put on again.
  bool glove_off() const noexcept;

  // ---- calibration -------------------------------------------------------------------------

  /// @brief Starts (or restarts) an on-the-fly calibration: from now on solved frames also feed the
  /// per-sensor min/max (median of calibration_median_window frames). The user moves through
  /// extreme poses; poses keep coming from the previous range, if any, flagged kPoseCalibrating.
  /// With a pose-guided calibration the user follows the model's calibration sequence, whose clock
  /// starts at the first frame taken (calibration_progress() says which step is under way).
  void start_calibration() noexcept;
  /// @brief How far the calibration has come.
  CalibrationProgress calibration_progress() const noexcept;
  /// @brief Ends the calibration and uses its range. Throws glovepose::Error (and keeps collecting)
  /// when fewer frames than the median window arrived or no calibration was started. The range's
  /// flat sensors (too small a range) are listed by CalibrationRange::flat_sensors().
  /// With CalibrationMethod::PoseGuided (or Auto when the model carries one and the whole sequence
  /// was performed) it also estimates the user's angle offsets (calibration_offsets()); PoseGuided
  /// throws glovepose::Error naming the first step that was not held. Bounded time: one network
  /// forward per held frame of the sequence.
  const sensor::CalibrationRange& finish_calibration();
  /// @brief Stops collecting and keeps the previous range.
  void cancel_calibration() noexcept;
  /// @brief Uses a range the caller has (e.g. a saved user calibration). Throws glovepose::Error
  /// when its size or sensor names differ from the glove's.
  void set_calibration(const sensor::CalibrationRange& range);
  /// @brief Uses a range and the pose-guided angle offsets (radians) the caller has.
  void set_calibration(const sensor::CalibrationRange& range, const hand::Angles& offsets);
  /// @brief Loads a calibration saved by save_calibration() for this glove (its range and, when it
  /// was pose-guided, its angle offsets).
  void load_calibration(const std::string& path);
  /// @brief Saves the calibration in use, range and pose-guided offsets (to load it for the same
  /// user and glove later).
  void save_calibration(const std::string& path) const;
  /// @brief Uses the model's training-set range. Throws glovepose::Error when the file has none.
  void use_training_calibration();
  /// @brief Calibrates from the wearer's free motion from now on (EstimatorConfig::continuous_calibration,
  /// what a new estimator does when the model carries a range map): the model's prior range at
  /// once, refined as the wearer moves. Throws glovepose::Error when the model carries no range map.
  void use_continuous_calibration();
  /// @brief Forgets the calibration in use (range and offsets): no pose until a range is set
  /// (Status::Uncalibrated), for an application that wants poses only after its own calibration step.
  void clear_calibration() noexcept;
  /// @brief The range in use, if any (while the calibration is continuous, it moves with the wearer).
  const std::optional<sensor::CalibrationRange>& calibration() const noexcept;
  /// @brief Where the range in use came from.
  CalibrationSource calibration_source() const noexcept;
  /// @brief The method of the calibration in use: PoseGuided when angle offsets are applied, MinMax otherwise.
  CalibrationMethod calibration_method() const noexcept;
  /// @brief The angle offsets (radians) added to every pose; zero unless pose-guided.
  const hand::Angles& calibration_offsets() const noexcept;

  // ---- state -------------------------------------------------------------------------------

  /// @brief Forgets the stream (readings, filter, timestamps, the pinch flags' history), e.g. after
  /// the glove was unplugged or its clock restarted; keeps the calibration and the last pose (marked
  /// by its sequence) and its aim().
  void reset() noexcept;
  /// @brief The shared model.
  const PoseModel& model() const noexcept;
  /// @brief The settings in use, the glove's filled in where the given ones said "the glove's"
  /// (calibration_median_window 0, a negative calibration.min_relative_range or min_range_to_noise).
  const EstimatorConfig& config() const noexcept;

 private:
  std::unique_ptr<detail::EstimatorCore> core_;
};

}  // namespace glovepose

#ifndef GLOVEPOSE_COMPILED_LIB
#include "detail/estimator_impl.hpp"
#endif
