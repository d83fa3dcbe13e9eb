/// @file estimator_config.hpp
/// @brief The settings of one GlovePoseEstimator (one glove stream): readout, calibration,
/// smoothing, joints, prediction and threads, with their defaults.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>

#include "calibration/donning.hpp"
#include "filter/one_euro_config.hpp"
#include "hand/contact_config.hpp"
#include "hand/handedness.hpp"
#include "sensor/calibration_config.hpp"
#include "sensor/floating_cells_config.hpp"
#include "sensor/readout_config.hpp"

namespace glovepose {

namespace hand {
struct HandModel;  // hand/kinematics.hpp
}  // namespace hand

/// @brief How finish_calibration() calibrates (docs/calibration.md).
enum class CalibrationMethod : std::uint8_t {
  /// Pose-guided when the model carries a pose-guided calibration, the whole sequence was performed
  /// and the calibration looks like it (PoseOffsetModel::followed: a user who moved freely gets
  /// min-max, not offsets fitted for poses they did not make); min-max otherwise.
  /// calibration_method() tells which one was applied.
  Auto,
  MinMax,      ///< The paper's per-sensor min-max only (Sec. 4.3).
  PoseGuided,  ///< Min-max plus the per-user angle offsets of the model's pose-guided calibration; finish_calibration() throws when it
               ///< cannot.
};

/// @brief The estimator's default readout: the paper's solve cadence (every 16 rows) on each row's
/// latest reading instead of the mean of its last 5. The 5-reading mean makes the pose trail the
/// hand by about 30-47 ms; the latest reading by about 5-11 ms, and the shipped networks (trained on
/// cells of 2-reading means) lose nothing by it (docs/results.md, "Lag"). The outlier bound
/// scales with the readings averaged (ReadoutConfig::max_reading_residual). Set mean_window = 5 for
/// the paper's filter.
inline sensor::ReadoutConfig realtime_readout() noexcept {
  sensor::ReadoutConfig config;
  config.mean_window = 1;
  return config;
}

/// @brief EstimatorConfig::calibration.min_relative_range that means "the glove's flat rule".
inline constexpr double kGlovesFlatRule = -1.0;
/// @brief EstimatorConfig::calibration.min_range_to_noise that means "the glove's noise rule".
inline constexpr double kGlovesNoiseRule = -1.0;

/// @brief Settings of one estimator (one glove stream).
struct EstimatorConfig {
  sensor::ReadoutConfig readout = realtime_readout();  ///< Mean window and solve cadence of the row stream (default 1, 16; paper: 5, 16).
  /// Flat-sensor and noise-only thresholds and the clamp of normalised values. A negative
  /// min_relative_range (the default) takes the glove's: its description's
  /// calibration.flat_relative_range (0.01 unless the description says otherwise); a negative
  /// min_range_to_noise (the default) its calibration.min_range_to_noise (12 unless it says otherwise).
  sensor::CalibrationConfig calibration{kGlovesFlatRule, sensor::CalibrationConfig{}.clamp_limit, kGlovesNoiseRule};
  /// Frames of the on-the-fly calibration's median. 0 (the default): the glove's
  /// calibration.median_seconds over the time between two frames taken (20 frames for the built-in
  /// glove: a third of a second, as in the paper and in the training data's calibration).
  int calibration_median_window = 0;
  /// Stream time between two frames the on-the-fly calibration takes (s), or more when the glove's
  /// description gives a slower rate_hz (then every frame). The median's window then spans the same
  /// time however often the readout solves.
  double calibration_sample_period = 1.0 / 60.0;
  /// Min-max, or min-max plus the pose-guided offsets: then the user follows the model's calibration
  /// sequence (PoseModel::pose_offset()->sequence()) from start_calibration() on.
  CalibrationMethod calibration_method = CalibrationMethod::Auto;
  /// Until a range is set (finish_calibration(), set_calibration(), load_calibration(),
  /// use_training_calibration()), calibrate from the wearer's free motion where the model carries a
  /// range map (PoseModel::range_map(); calibration/free_motion.hpp): poses from the first frame,
  /// the range refined as the wearer moves (CalibrationSource::Continuous). Off: Status::Uncalibrated
  /// until a range is set.
  bool continuous_calibration = true;
  /// Taking the glove off and putting it on again, noticed from the calibrated cells
  /// (calibration/donning.hpp; paused while a calibration collects). While the glove is off, poses
  /// carry kPoseGloveOff (not trusted) and the continuous calibration takes no frames. When it is on
  /// again, the calibration restarts as a continuous one from the range in use before the glove
  /// came off (the wearer's profile), refined from their motion, where the model carries a range
  /// map; without one the range is kept. None: not watched.
  std::optional<calibration::DonningConfig> donning = calibration::DonningConfig{};
  /// For C_c frames (push_cells): this many consecutive frames timestamped before the last accepted
  /// one mean the clock restarted; the estimator then follows the new clock. Rows and C_m frames:
  /// ReadoutConfig::clock_restart_readings.
  int clock_restart_frames = 10;
  /// Cells a torn trace left floating (reading below a quarter of their calibrated minimum) stood in
  /// for by a regression on the connected cells (sensor/floating_cells.hpp); poses carry
  /// kPoseMaskedCells and stay trusted. Off with a glove whose frames are de-meaned.
  sensor::FloatingCellsConfig floating_cells;
  std::optional<filter::OneEuroConfig> smoothing;       ///< 1-euro smoothing of the angles; none: the network's output.
  bool joint_transforms = false;                        ///< Compute the joint list with every pose (the skeleton is always posed).
  /// The contact stage (hand/contact.hpp), after the smoothing: when the pose says thumb and a
  /// finger touch (the pinch rule, 15 mm on / 18 mm off), the two chains' angles are adjusted so
  /// that the tips meet; other poses are untouched. None (the default): off. It cannot make a pinch
  /// the pose does not show, nor drop one it does: detection is the pose's own (docs/results.md,
  /// "Contact-consistent poses").
  std::optional<hand::ContactConfig> contact;
  /// The hand the skeleton, the joint list and the OpenXR joints are computed for (hand/kinematics.hpp;
  /// e.g. one fitted to the user's hand). None (the default): the reference template hand.
  std::shared_ptr<const hand::HandModel> hand;
  /// The hand the glove is on. A left glove is the right glove's sensor sheet turned over, so the
  /// mirrored hand stretches every cell as the right hand does: the same model and inputs serve,
  /// and only the skeleton, the joint list and the OpenXR joints are mirrored (hand/handedness.hpp).
  hand::Handedness handedness = hand::Handedness::Right;
  /// Seconds of recent poses whose least-squares slope gives the angles' rate of change, for
  /// pose_at()/joints_at() ahead of the newest pose and the joints' velocities (filter/trend.hpp;
  /// at most the newest 128 poses: 0.19 s at the default cadence). Shorter windows follow turns
  /// sooner but carry more of the network's pose-to-pose noise into the prediction: 0.03 s made
  /// 40 ms ahead worse than holding the newest pose (docs/results.md, "Poses at a requested time").
  double prediction_window = 0.15;
  /// How far (s) past the newest pose pose_at()/joints_at() extrapolate; later times are located at
  /// this bound and flagged clamped.
  double max_prediction = 0.05;
  /// Threads a U-Net's forward runs on: the calling thread plus network_threads - 1 workers of the
  /// estimator's own (core/team.hpp), each computing part of every large layer; the same poses as
  /// with 1. Worth it for wide U-Nets on an otherwise idle second core (docs/performance.md); the
  /// workers park when no frame comes, so an idle estimator costs no CPU. An FCN runs on one.
  /// Parking is a mutex and a condition variable: with more than 1 (and a U-Net) a frame that finds
  /// the workers parked takes that lock to wake them, so the per-frame calls then keep
  /// GLOVEPOSE_REALTIME's no-allocation promise but not its no-lock one (tests/test_realtime.cpp
  /// counts both).
  int network_threads = 1;
  /// What Pose::confidence measures: per DoF, the probability that the angle's error is within this
  /// tolerance (radians; default 10 degrees), from the model's own measured errors (model/pose_error.hpp).
  double confidence_tolerance = 10.0 * 3.14159265358979323846 / 180.0;
};

/// @brief Where the estimator's calibration range comes from.
enum class CalibrationSource : std::uint8_t {
  None,      ///< No range yet: no pose can be computed (Status::Uncalibrated).
  OnTheFly,  ///< This user's range, from start_calibration() ... finish_calibration().
  User,      ///< A range set or loaded by the caller (e.g. the user's saved calibration).
  Training,  ///< The model's training-set range (the paper's "without calibration").
  Continuous,  ///< Kept from the wearer's free motion by the model's range map (EstimatorConfig::continuous_calibration).
};

}  // namespace glovepose
