/// @file pose.hpp
/// @brief What an estimator answers: a Pose (angles, flags, latency), its calibration's progress,
/// the hand at a requested time (PredictedPose; pose_prediction.hpp predicts and locates it), and
/// HandState, the plain copy a glove's thread publishes to readers on other threads (LatestHand).
#pragma once

#include <cstdint>

#include "config.hpp"
#include "core/latest.hpp"
#include "hand/dofs.hpp"
#include "hand/joint_list_types.hpp"
#include "sensor/readout_config.hpp"
#include "status.hpp"

namespace glovepose {

/// @brief How far an on-the-fly calibration has come.
struct CalibrationProgress {
  bool collecting = false;  ///< Between start_calibration() and finish/cancel.
  long frames = 0;          ///< Frames taken so far.
  int frames_needed = 0;    ///< Frames before finish_calibration() can succeed (the median window).
  bool ready = false;       ///< finish_calibration() would succeed now.
  /// Guided calibration: seconds since the sequence started (its first frame), and the step under
  /// way (index into the sequence's steps; -1 before the first frame and after the last step).
  double sequence_seconds = 0.0;
  int step = -1;
  /// Continuous calibration: the free motion it has taken so far, in effective frames (frames that
  /// moved the cells, older ones forgotten; calibration/free_motion.hpp); 0 otherwise.
  double motion_frames = 0.0;
  /// Times the glove was noticed put on again after being off the hand (EstimatorConfig::donning;
  /// calibration/donning.hpp) since the estimator was made.
  long donnings = 0;
};

/// @brief Bits of Pose::flags: reasons to trust a pose less. 0 means none applies.
enum PoseFlag : std::uint32_t {
  kPoseReadingsRejected =
      1u << 0,  ///< Readings were rejected since the previous pose (dropped, NaN, negative, out of order): their rows kept older values.
  kPoseInputClamped =
      1u << 1,  ///< A calibrated cell lay beyond the clamp limit: the glove stretched beyond the calibrated range, or a glitch.
  kPoseTrainingCalibration =
      1u << 2,  ///< Normalised with the model's training-set range, not the user's own (expect larger errors: paper Table 1 (3)).
  kPoseCalibrating = 1u << 3,  ///< Produced while an on-the-fly calibration was collecting (with the range set before it).
  kPoseStaleReadings =
      1u << 4,  ///< Some rows stopped arriving (lost on the link): their newest reading is older than ReadoutConfig::stale_cycles cycles.
  kPoseRecovering = 1u << 5,        ///< Some rows hold fewer readings than the mean window: just after the start, a gap or a clock restart.
  kPoseStuckRows = 1u << 6,         ///< A row repeats one value (ReadoutConfig::stuck_readings): a stuck sensor.
  kPoseDisconnectedRows =
      1u << 7,  ///< Rows read (near) zero (ReadoutConfig::disconnected_below) and the solve could not leave them out (max_excluded_share).
  kPoseOutlierRows =
      1u << 8,  ///< A row disagrees with the least-squares solve (ReadoutConfig::max_reading_residual): a spike or a failing cell.
  kPoseMaskedCells = 1u << 9,  ///< Cells stopped being measured (a torn trace): they were stood in for from the others (not a fault).
  kPoseGloveOff = 1u << 10,    ///< The cells look like a glove lying off the hand (EstimatorConfig::donning): there is no hand to estimate.
};

/// @brief Number of PoseFlag bits (bits 0 .. kPoseFlagCount - 1).
inline constexpr int kPoseFlagCount = 11;
static_assert(kPoseGloveOff == 1u << (kPoseFlagCount - 1), "kPoseFlagCount: the last PoseFlag is its highest bit");

/// @brief A short, stable name of PoseFlag bit `bit` (for logs and displays).
constexpr const char* pose_flag_name(int bit) noexcept {
  constexpr const char* names[] = {"readings rejected", "input clamped",     "training calibration",
                                   "calibrating",       "stale readings",    "recovering",
                                   "stuck rows",        "disconnected rows", "outlier rows",
                                   "masked cells",      "glove off"};  // in bit order
  static_assert(sizeof names / sizeof names[0] == kPoseFlagCount, "one name per PoseFlag bit");
  return name_of(bit, names, "unknown flag");  // a negative bit wraps to a large index: unknown
}

/// @brief The flags that mean the pose cannot be trusted: the readout saw a fault in the frame, or
/// the glove is off the hand.
inline constexpr std::uint32_t kPoseFaultFlags =
    kPoseStaleReadings | kPoseRecovering | kPoseStuckRows | kPoseDisconnectedRows | kPoseOutlierRows | kPoseGloveOff;

/// @brief One estimated hand pose.
struct Pose {
  hand::Angles angles{};         ///< The 25 angles, radians (hand::kDofs order, theta 9..33); smoothed when smoothing is on.
  hand::Angles raw_angles{};     ///< The network's angles before smoothing.
  double timestamp = 0.0;        ///< Timestamp of the newest reading behind the pose (the stream's clock, s).
  double oldest_age = 0.0;       ///< timestamp minus the timestamp of the oldest reading behind it (s): the readout's share of the latency.
  double compute_seconds = 0.0;  ///< Wall time the estimator spent on this pose (solve to joint transforms).
  std::uint64_t sequence = 0;    ///< Poses produced so far, this one included.
  std::uint32_t rejected = 0;    ///< Readings rejected since the previous pose.
  std::uint32_t flags = 0;       ///< PoseFlag bits.
  bool valid = false;            ///< False until the first pose.
  sensor::ReadoutHealth health;  ///< The readout's view of the frame (rows and C_m frames; zero for C_c frames).
  /// Per DoF (hand::kDofs order), 0..1: the probability that the angle is within
  /// EstimatorConfig::confidence_tolerance of the truth, from the model's own errors measured on new
  /// people (model/pose_error.hpp) under the calibration in use, the DoF's speed and the cells stood
  /// in for. 0 for every DoF of a pose that is not trusted(); 1 for every DoF of a trusted pose when
  /// the model carries no measured errors (PoseModel::pose_error()).
  hand::Angles confidence{};
  /// @brief Whether no fault flag (kPoseFaultFlags) is set.
  bool trusted() const noexcept { return valid && (flags & kPoseFaultFlags) == 0; }
};

/// @brief The hand at a requested time (GlovePoseEstimator::pose_at).
struct PredictedPose {
  hand::Angles angles{};    ///< Radians, within the joint limits.
  hand::Angles rate{};      ///< Rate of change (rad/s): the slope of the recent poses.
  bool has_rate = false;    ///< Whether rate comes from at least two poses.
  double time = 0.0;        ///< The time asked for (the stream's clock, s).
  double horizon = 0.0;     ///< Time located minus the newest pose's timestamp: > 0 predicted, <= 0 from the recent poses.
  bool predicted = false;   ///< Extrapolated past the newest pose.
  bool clamped = false;     ///< Asked further ahead than EstimatorConfig::max_prediction: located at the bound.
  std::uint32_t flags = 0;  ///< The newest pose's PoseFlag bits.
  bool trusted = false;     ///< The newest pose's trusted().
  hand::Angles confidence{};  ///< The newest pose's Pose::confidence.
};

/// @brief The confidence at or above which an OpenXR joint is reported tracked (locate()): the
/// joint's angles more likely within the tolerance than not.
inline constexpr double kTrackedConfidence = 0.5;

/// @brief The hand at one moment, as a plain copy: what the glove's thread hands to an engine's
/// update and render threads through LatestHand.
struct HandState {
  Pose pose;                        ///< The pose (pose.valid false before the first).
  hand::JointList joints{};         ///< Its joint list (when EstimatorConfig::joint_transforms is on).
  CalibrationProgress calibration;  ///< Where the calibration is.
  hand::Angles rate{};              ///< The angles' rate of change (rad/s), for predicting ahead.
  bool has_rate = false;            ///< Whether rate is known.
};

/// @brief The newest HandState of one estimator for any number of reader threads (core/latest.hpp):
/// the estimator's thread calls latest.publish(estimator.state()) after each pose; readers never
/// block it and never see a torn state.
using LatestHand = core::Latest<HandState>;

}  // namespace glovepose
