/// @file xr_hand.hpp
/// @brief One hand's 26 OpenXR joints (hand/openxr_joints.hpp) with their velocities, located from
/// a set of angles and their rate of change: what GlovePoseEstimator::joints_at() and a reader of
/// LatestHand hand to an engine (Unity's XR Hands, Godot's XRHandTracker, an OpenXR runtime's
/// xrLocateHandJointsEXT).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>

#include <Eigen/Geometry>

#include "config.hpp"
#include "hand/dofs.hpp"
#include "hand/handedness.hpp"
#include "hand/openxr_joints.hpp"

namespace glovepose {

/// @brief One hand's joints at one time, laid out for OpenXR (positions and velocities in the
/// wrist joint's frame; hand/openxr_joints.hpp).
struct XrHandJoints {
  hand::XrJointLocations locations{};                                ///< XrHandJointLocationEXT-compatible.
  std::array<hand::XrJointVelocity, hand::kXrJointCount> velocities{};  ///< XrHandJointVelocityEXT-compatible.
  double time = 0.0;        ///< The time located (the glove stream's clock, s).
  double horizon = 0.0;     ///< time minus the newest pose's timestamp: > 0 predicted ahead, < 0 from the recent poses.
  bool predicted = false;   ///< Extrapolated past the newest pose.
  bool clamped = false;     ///< Asked further ahead than the prediction bound: located at the bound.
  bool active = false;      ///< Like XrHandJointLocationsEXT::isActive: a pose exists.
  hand::Handedness side = hand::Handedness::Right;  ///< The hand located.
};

/// @brief Locates one hand's OpenXR joints from angles. Immutable after construction; every call
/// is noexcept and allocation-free, so one locator may serve any number of threads.
class XrHandLocator {
 public:
  /// @brief Time step (s) of the central difference that turns the angles' rate into joint velocities.
  static constexpr double kVelocityStep = 0.002;

  /// @brief A locator for a hand of `model` on `side` whose angles stay within `limits`.
  XrHandLocator(hand::HandModel model, hand::Handedness side, hand::JointLimits limits = {})
      : mapper_(hand::Kinematics(std::move(model), side)), limits_(std::move(limits)) {}

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
    hand::Skeleton skeleton;
    mapper_.kinematics().pose(angles, skeleton);
    mapper_.locate(skeleton, location_flags, out.locations);
    out.side = side();
    if (rate == nullptr) {
      for (auto& v : out.velocities) v = hand::XrJointVelocity{};
      return;
    }
    // Central difference of the joints along the rate: d/dt of joints(angles + rate t) at t = 0.
    hand::XrJointLocations ahead, behind;
    hand::Angles shifted{};
    for (std::size_t i = 0; i < hand::kDofCount; ++i) shifted[i] = angles[i] + (*rate)[i] * kVelocityStep;
    mapper_.kinematics().pose(shifted, skeleton);
    mapper_.locate(skeleton, 0, ahead);
    for (std::size_t i = 0; i < hand::kDofCount; ++i) shifted[i] = angles[i] - (*rate)[i] * kVelocityStep;
    mapper_.kinematics().pose(shifted, skeleton);
    mapper_.locate(skeleton, 0, behind);
    const double scale = 1.0 / (2.0 * kVelocityStep);
    for (std::size_t j = 0; j < hand::kXrJointCount; ++j) {
      const hand::XrPose& a = ahead[j].pose;
      const hand::XrPose& b = behind[j].pose;
      hand::XrJointVelocity& v = out.velocities[j];
      v.velocity_flags = hand::kXrLinearVelocityValid | hand::kXrAngularVelocityValid;
      v.linear_velocity = {static_cast<float>((a.position.x - b.position.x) * scale),
                           static_cast<float>((a.position.y - b.position.y) * scale),
                           static_cast<float>((a.position.z - b.position.z) * scale)};
      // The rotation from `behind` to `ahead`, in the wrist frame, as an axis times an angle.
      const Eigen::Quaterniond qa(a.orientation.w, a.orientation.x, a.orientation.y, a.orientation.z);
      const Eigen::Quaterniond qb(b.orientation.w, b.orientation.x, b.orientation.y, b.orientation.z);
      const Eigen::AngleAxisd turn(qa * qb.conjugate());  // angle in [0, pi]: the short way round
      const Eigen::Vector3d w = turn.axis() * turn.angle() * scale;
      v.angular_velocity = {static_cast<float>(w.x()), static_cast<float>(w.y()), static_cast<float>(w.z())};
    }
  }

  /// @brief `angles` moved along `rate` for `horizon` seconds, held within limits().
  GLOVEPOSE_REALTIME hand::Angles extrapolate(const hand::Angles& angles, const hand::Angles& rate, double horizon) const noexcept {
    hand::Angles out{};
    for (std::size_t i = 0; i < hand::kDofCount; ++i)
      out[i] = std::clamp(angles[i] + rate[i] * horizon, limits_.min()[i], limits_.max()[i]);
    return out;
  }

 private:
  hand::XrJointMapper mapper_;
  hand::JointLimits limits_;
};

}  // namespace glovepose
