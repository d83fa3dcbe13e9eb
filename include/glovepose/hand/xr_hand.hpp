/// @file hand/xr_hand.hpp
/// @brief One hand's 26 OpenXR joints (hand/openxr_joints.hpp) with their velocities, located from
/// a set of angles and their rate of change: what GlovePoseEstimator::joints_at() and a reader of
/// LatestHand hand to an engine (Unity's XR Hands, Godot's XRHandTracker, an OpenXR runtime's
/// xrLocateHandJointsEXT); and the hand as an input device, XR_FB_hand_tracking_aim's pinch and
/// aim state (XrHandAim, kept over time by XrAimTracker; LatestAim for reader threads).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>

#include <Eigen/Geometry>

#include "../config.hpp"
#include "dofs.hpp"
#include "handedness.hpp"
#include "openxr_joints.hpp"
#include "pinch.hpp"
#include "../core/latest.hpp"

namespace glovepose::hand {

/// @brief One hand's joints at one time, laid out for OpenXR (positions and velocities in the
/// wrist joint's frame; hand/openxr_joints.hpp).
struct XrHandJoints {
  hand::XrJointLocations locations{};                                   ///< XrHandJointLocationEXT-compatible.
  std::array<hand::XrJointVelocity, hand::kXrJointCount> velocities{};  ///< XrHandJointVelocityEXT-compatible.
  double time = 0.0;                                                    ///< The time located (the glove stream's clock, s).
  double horizon = 0.0;    ///< time minus the newest pose's timestamp: > 0 predicted ahead, < 0 from the recent poses.
  bool predicted = false;  ///< Extrapolated past the newest pose.
  bool clamped = false;    ///< Asked further ahead than the prediction bound: located at the bound.
  bool active = false;     ///< Like XrHandJointLocationsEXT::isActive: a pose exists.
  hand::Handedness side = hand::Handedness::Right;  ///< The hand located.
  /// XR_EXT_hand_tracking_data_source's XrHandTrackingDataSourceStateEXT::dataSource: the glove's
  /// joints are the hand's own, unobstructed.
  hand::XrHandDataSource data_source = hand::kXrDataSourceUnobstructed;
};

/// @brief Locates one hand's OpenXR joints from angles. Immutable after construction; every call
/// is noexcept and allocation-free, so one locator may serve any number of threads.
class XrHandLocator {
 public:
  /// @brief A locator for a hand of `model` on `side` whose angles stay within `limits`.
  XrHandLocator(hand::HandModel model, hand::Handedness side, hand::JointLimits limits = {})
      : mapper_(hand::Kinematics(std::move(model), side)), limits_(std::move(limits)) {
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      auto& list = phalanx_dofs_[static_cast<std::size_t>(hand::kDofs[d].phalanx)];
      list[static_cast<std::size_t>(list[3]++)] = static_cast<int>(d);  // slot 3 counts (at most 3 DoFs a phalanx)
    }
  }

  /// @brief The side located.
  hand::Handedness side() const noexcept { return mapper_.kinematics().side(); }
  /// @brief The skeleton-to-joints mapping (kinematics, radii).
  const hand::XrJointMapper& mapper() const noexcept { return mapper_; }
  /// @brief The limits extrapolated angles are held within.
  const hand::JointLimits& limits() const noexcept { return limits_; }

  /// @brief Fills out.locations from `angles` (radians) with `location_flags`, and out.velocities
  /// from `rate` (rad/s) when given (their flags 0 otherwise). Leaves out's timing fields alone.
  GLOVEPOSE_REALTIME void locate(const hand::Angles& angles, const hand::Angles* rate, std::uint64_t location_flags,
                                 XrHandJoints& out) const noexcept {
    hand::Skeleton skeleton;  // in the wrist joint's frame (mm)
    hand::DofAxes axes;
    hand::XrJointFrames joints;
    if (rate != nullptr)
      mapper_.kinematics().pose(angles, skeleton, axes, mapper_.root());
    else
      mapper_.kinematics().pose(angles, skeleton, mapper_.root());
    mapper_.frames(skeleton, joints);
    mapper_.write(joints, location_flags, out.locations);
    out.side = side();
    for (auto& v : out.velocities) v = hand::XrJointVelocity{};
    if (rate == nullptr) return;
    // Velocities in closed form: DoF d turning at rate r about its axis a through its phalanx's
    // origin o moves a point p beyond it at r a x (p - o) and turns its frame at r a. The palm,
    // the wrist and the finger metacarpals sit on the palm, which the glove does not move.
    for (auto& v : out.velocities) v.velocity_flags = hand::kXrLinearVelocityValid | hand::kXrAngularVelocityValid;
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      const auto base = static_cast<std::size_t>(hand::kFingerBase[f]);
      const std::size_t phalanx_joint = hand::XrJointMapper::digit_joint(f);
      Eigen::Vector3d angular = Eigen::Vector3d::Zero();
      for (std::size_t k = 0; k < 3; ++k) {  // phalanx base + k: its DoFs move the joints from phalanx_joint + k + 1 on
        const std::size_t phalanx = base + k;
        const Eigen::Vector3d origin = skeleton[phalanx].translation() * 1e-3;
        const auto& dofs = phalanx_dofs_[phalanx];
        for (int n = 0; n < dofs[3]; ++n) {
          const auto d = static_cast<std::size_t>(dofs[static_cast<std::size_t>(n)]);
          const Eigen::Vector3d turn = (*rate)[d] * axes[d];
          angular += turn;
          for (std::size_t j = phalanx_joint + k + 1; j <= phalanx_joint + 3; ++j)
            add(out.velocities[j].linear_velocity, turn.cross(joints.position[j] - origin));
        }
        set(out.velocities[phalanx_joint + k].angular_velocity, angular);
      }
      set(out.velocities[phalanx_joint + 3].angular_velocity, angular);  // the tip turns with its distal bone
    }
  }

  /// @brief Per OpenXR joint, the confidence of the angles that place and turn it: the product of
  /// the per-DoF `confidence` (Pose::confidence) of its phalanx and the phalanxes before it on the
  /// digit (the tip: its distal phalanx's); joints on the palm, which no angle moves: 1.
  GLOVEPOSE_REALTIME void joint_confidence(const hand::Angles& confidence, std::array<double, hand::kXrJointCount>& out) const noexcept {
    out.fill(1.0);
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      const auto base = static_cast<std::size_t>(hand::kFingerBase[f]);
      const std::size_t joint = hand::XrJointMapper::digit_joint(f);
      double chain = 1.0;
      for (std::size_t k = 0; k < 3; ++k) {
        const auto& dofs = phalanx_dofs_[base + k];
        for (int n = 0; n < dofs[3]; ++n) chain *= confidence[static_cast<std::size_t>(dofs[static_cast<std::size_t>(n)])];
        out[joint + k] = chain;
      }
      out[joint + 3] = chain;
    }
  }

  /// @brief `angles` moved along `rate` for `horizon` seconds, held within limits().
  GLOVEPOSE_REALTIME hand::Angles extrapolate(const hand::Angles& angles, const hand::Angles& rate, double horizon) const noexcept {
    hand::Angles out{};
    for (std::size_t i = 0; i < hand::kDofCount; ++i) {
      const double moved = angles[i] + rate[i] * horizon;
      out[i] = std::isfinite(moved) ? std::clamp(moved, limits_.min()[i], limits_.max()[i]) : angles[i];
    }
    return out;
  }

 private:
  static void set(hand::XrVector3& out, const Eigen::Vector3d& v) noexcept {
    out = {static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z())};
  }
  static void add(hand::XrVector3& out, const Eigen::Vector3d& v) noexcept {
    out.x += static_cast<float>(v.x());
    out.y += static_cast<float>(v.y());
    out.z += static_cast<float>(v.z());
  }

  hand::XrJointMapper mapper_;
  hand::JointLimits limits_;
  std::array<std::array<int, 4>, hand::kPhalanxCount> phalanx_dofs_{};  // DoFs turning each phalanx; [3]: how many
};

/// @brief Bits of XrHandAim::status: the values of XrHandTrackingAimFlagsFB (XR_FB_hand_tracking_aim).
enum XrAimFlag : std::uint64_t {
  kXrAimComputed = 0x1,         ///< XR_HAND_TRACKING_AIM_COMPUTED_BIT_FB: aim from sources beyond the hand data (never set here).
  kXrAimValid = 0x2,            ///< XR_HAND_TRACKING_AIM_VALID_BIT_FB: the aim data is valid (a pose exists and is trusted).
  kXrAimIndexPinching = 0x4,    ///< XR_HAND_TRACKING_AIM_INDEX_PINCHING_BIT_FB.
  kXrAimMiddlePinching = 0x8,   ///< XR_HAND_TRACKING_AIM_MIDDLE_PINCHING_BIT_FB.
  kXrAimRingPinching = 0x10,    ///< XR_HAND_TRACKING_AIM_RING_PINCHING_BIT_FB.
  kXrAimLittlePinching = 0x20,  ///< XR_HAND_TRACKING_AIM_LITTLE_PINCHING_BIT_FB.
  kXrAimSystemGesture = 0x40,   ///< XR_HAND_TRACKING_AIM_SYSTEM_GESTURE_BIT_FB (never set: the glove knows no system gesture).
  kXrAimDominantHand = 0x80,    ///< XR_HAND_TRACKING_AIM_DOMINANT_HAND_BIT_FB (never set: the application knows which hand leads).
  kXrAimMenuPressed = 0x100,    ///< XR_HAND_TRACKING_AIM_MENU_PRESSED_BIT_FB (never set).
};

/// @brief The pinching bit of pinch pair k (0: thumb-index .. 3: thumb-little).
constexpr std::uint64_t xr_aim_pinching_bit(std::size_t pair) noexcept { return std::uint64_t{kXrAimIndexPinching} << pair; }

/// @brief One hand's pinch and aim state, as XR_FB_hand_tracking_aim's XrHandTrackingAimStateFB
/// carries it (status, aim pose, four pinch strengths), with what it was computed from.
///
/// The aim pose, in the wrist joint's frame like the joints (metres; hand/openxr_joints.hpp): the
/// index finger's proximal joint (its knuckle) as it stands at the rest pose, every angle 0, the
/// index straight: its -Z points along the straight index towards its tip, +Y out of the back of
/// the hand, the convention of OpenXR's aim poses (a ray along -Z). The palm is rigid in the hand
/// model, so this pose is fixed in the wrist frame: the glove has no global tracking, and the
/// engine composes it with the wrist pose its tracker reports (world_from_aim = world_from_wrist *
/// aim_pose), so the ray follows the hand as a whole. It does not follow the estimated fingers on
/// purpose: a ray that moved with the index would move when the user pinches to select (away
/// from the target being selected), and with the fingers' estimation error (about 11 mm at the
/// fingertips, docs/results.md) it would wobble by degrees.
///
/// Pinches (hand/pinch.hpp): per finger, index to little, the strength of the thumb-tip-to-
/// fingertip distance and the pinching flag of the 15 / 18 mm hysteresis, kept by XrAimTracker
/// from pose to pose. kXrAimValid is set when the pose is valid and trusted (no fault flag); the
/// strengths and flags are those of the pose either way. Trivially copyable (for Latest).
struct XrHandAim {
  std::uint64_t status = 0;                                   ///< XrAimFlag bits (XrHandTrackingAimFlagsFB).
  hand::XrPose aim_pose;                                      ///< XrPosef-compatible: the aim pose in the wrist joint's frame (metres).
  std::array<float, hand::kPinchPairCount> pinch_strength{};  ///< [0, 1], index, middle, ring, little.
  hand::PinchDistances distance_mm{};                         ///< Thumb tip to fingertip, mm (NaN when an angle was not finite).
  double timestamp = 0.0;                                     ///< The pose's timestamp (the glove stream's clock, s).
  std::uint64_t sequence = 0;                                 ///< The pose's sequence (Pose::sequence); 0: no pose yet.
  bool active = false;                                        ///< A pose exists (sequence > 0).
  hand::Handedness side = hand::Handedness::Right;            ///< The hand.
};

/// @brief Keeps one hand's pinch and aim state from pose to pose: the hysteresis of the four
/// pinch flags lives here, with the writer of the poses (GlovePoseEstimator holds one), not with
/// the readers. Per frame noexcept and allocation-free.
class XrAimTracker {
 public:
  /// @brief A tracker for the hand of `mapper` (its kinematics: hand model and side), with the
  /// pinch `rule` (validated: throws glovepose::Error).
  explicit XrAimTracker(const hand::XrJointMapper& mapper, const hand::PinchRule& rule = {})
      : kinematics_(mapper.kinematics()), pinch_(rule) {
    hand::Skeleton skeleton;
    mapper.kinematics().pose(hand::Angles{}, skeleton, mapper.root());
    hand::XrJointFrames frames;
    mapper.frames(skeleton, frames);
    hand::XrJointLocations locations;
    mapper.write(frames, 0, locations);
    aim_.aim_pose = locations[static_cast<std::size_t>(hand::XrJoint::IndexProximal)].pose;
    aim_.side = mapper.kinematics().side();
  }

  /// @brief The aim pose (fixed in the wrist joint's frame; XrHandAim says why).
  const hand::XrPose& aim_pose() const noexcept { return aim_.aim_pose; }
  /// @brief The pinch rule.
  const hand::PinchRule& rule() const noexcept { return pinch_.rule(); }

  /// @brief The state after a new pose: its angles (radians), whether it is trusted, its timestamp
  /// and sequence. Non-finite angles make the pairs they touch read no pinch (strength 0).
  GLOVEPOSE_REALTIME const XrHandAim& update(const hand::Angles& angles, bool trusted, double timestamp, std::uint64_t sequence) noexcept {
    return update(hand::pinch_distances(kinematics_, angles), trusted, timestamp, sequence);
  }

  /// @brief The same from the pose's thumb-tip-to-fingertip distances (mm, hand::pinch_distances),
  /// for a caller that has posed the skeleton already (the estimator: forward kinematics once).
  GLOVEPOSE_REALTIME const XrHandAim& update(const hand::PinchDistances& distance_mm, bool trusted, double timestamp,
                                             std::uint64_t sequence) noexcept {
    const hand::PinchState pinch = pinch_.update(distance_mm);
    std::uint64_t status = trusted ? std::uint64_t{kXrAimValid} : 0;
    for (std::size_t k = 0; k < hand::kPinchPairCount; ++k)
      if (pinch.pinching[k]) status |= xr_aim_pinching_bit(k);
    aim_.status = status;
    aim_.pinch_strength = pinch.strength;
    aim_.distance_mm = pinch.distance_mm;
    aim_.timestamp = timestamp;
    aim_.sequence = sequence;
    aim_.active = true;
    return aim_;
  }

  /// @brief The state after the last update (active false before the first).
  const XrHandAim& aim() const noexcept { return aim_; }

  /// @brief Forgets the pinch flags' history (every pair off until its distance falls below the
  /// threshold again); keeps the last state for aim().
  void reset() noexcept { pinch_.reset(); }

 private:
  hand::Kinematics kinematics_;
  hand::PinchTracker pinch_;
  XrHandAim aim_;
};

/// @brief The newest aim state of one estimator for reader threads (core/latest.hpp): the estimator's
/// thread publishes estimator.aim() beside its HandState (LatestHand); a reader matches the two by
/// XrHandAim::sequence and Pose::sequence when it needs both of one pose.
using LatestAim = core::Latest<XrHandAim>;

}  // namespace glovepose::hand
