/// @file pose_prediction.hpp
/// @brief The hand at a requested time: a pose extrapolated along its rate (predict) and its OpenXR
/// joints (locate), for the estimator's pose_at()/joints_at() and for readers of LatestHand that
/// predict on their own thread.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "config.hpp"
#include "hand/xr_hand.hpp"
#include "pose.hpp"
#include "status.hpp"

namespace glovepose {

/// @brief The pose of `state` extrapolated to time t along its rate, at most `max_prediction`
/// seconds ahead (a reader of LatestHand predicting for its own display time). Status::NotReady
/// before the first pose, NonFinite for a non-finite t.
GLOVEPOSE_REALTIME inline Status predict(const Pose& pose, const hand::Angles& rate, bool has_rate, const hand::XrHandLocator& locator, double t,
                                         double max_prediction, PredictedPose& out) noexcept {
  if (!pose.valid) return Status::NotReady;
  if (!std::isfinite(t)) return Status::NonFinite;
  out.time = t;
  out.horizon = std::min(t - pose.timestamp, max_prediction);
  out.clamped = t - pose.timestamp > max_prediction;
  out.predicted = out.horizon > 0.0;
  out.rate = rate;
  out.has_rate = has_rate;
  out.flags = pose.flags;
  out.trusted = pose.trusted();
  out.confidence = pose.confidence;
  out.angles = out.predicted ? locator.extrapolate(pose.angles, rate, out.horizon) : pose.angles;
  return Status::Ok;
}

/// @brief predict() from a HandState (LatestHand's value).
GLOVEPOSE_REALTIME inline Status predict(const HandState& state, const hand::XrHandLocator& locator, double t, double max_prediction,
                                         PredictedPose& out) noexcept {
  return predict(state.pose, state.rate, state.has_rate, locator, t, max_prediction, out);
}

/// @brief The OpenXR joints of a predicted pose: positions valid; a joint tracked when the newest
/// pose is trusted, the time was within the prediction bound and the joint's confidence
/// (XrHandLocator::joint_confidence) is at least kTrackedConfidence; velocities when the rate is known.
GLOVEPOSE_REALTIME inline void locate(const PredictedPose& pose, const hand::XrHandLocator& locator, hand::XrHandJoints& out) noexcept {
  constexpr std::uint64_t kTracked = hand::kXrOrientationTracked | hand::kXrPositionTracked;
  std::uint64_t flags = hand::kXrOrientationValid | hand::kXrPositionValid;
  if (pose.trusted && !pose.clamped) flags |= kTracked;
  locator.locate(pose.angles, pose.has_rate ? &pose.rate : nullptr, flags, out);
  std::array<double, hand::kXrJointCount> confidence;
  locator.joint_confidence(pose.confidence, confidence);
  for (std::size_t j = 0; j < hand::kXrJointCount; ++j)
    if (confidence[j] < kTrackedConfidence) out.locations[j].location_flags &= ~kTracked;
  out.time = pose.time;
  out.horizon = pose.horizon;
  out.predicted = pose.predicted;
  out.clamped = pose.clamped;
  out.active = true;
}

}  // namespace glovepose
