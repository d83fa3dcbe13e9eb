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
  hand::XrJointLocations locations{};                                   ///< XrHandJointLocationEXT-compatible.
  std::array<hand::XrJointVelocity, hand::kXrJointCount> velocities{};  ///< XrHandJointVelocityEXT-compatible.
  double time = 0.0;                                                    ///< The time located (the glove stream's clock, s).
  double horizon = 0.0;    ///< time minus the newest pose's timestamp: > 0 predicted ahead, < 0 from the recent poses.
  bool predicted = false;  ///< Extrapolated past the newest pose.
  bool clamped = false;    ///< Asked further ahead than the prediction bound: located at the bound.
  bool active = false;     ///< Like XrHandJointLocationsEXT::isActive: a pose exists.
  hand::Handedness side = hand::Handedness::Right;  ///< The hand located.
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

}  // namespace glovepose
