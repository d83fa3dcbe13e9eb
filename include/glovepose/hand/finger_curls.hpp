/// @file finger_curls.hpp
/// @brief The 25 joint angles as per-finger curls and splays: what OpenGloves (LucidVR's SteamVR
/// driver, Monado's driver) and hand rigs driven by a curl per finger take. One mapping, documented
/// in docs/pose_stream.md ("OpenGloves"):
/// - a joint's curl is its flexion over the flexion of its upper limit (JointLimits: the model's),
///   clamped to [0, 1]: 0 straight or bent back, 1 fully bent;
/// - a finger's curl is the mean of its three flexion joints' curls (what a driver given one curl
///   per finger bends every joint by);
/// - a finger's splay is its base abduction over kFullSplay (20 degrees), clamped to [-1, 1],
///   positive toward the thumb's side: the drivers turn a finger by splay x 20 degrees
///   (opengloves-driver, driver/src/hand_tracking/hand_tracking.cpp, k_max_splay_angle), so a
///   finger turns by its own abduction up to 20 degrees.
/// Twist has no counterpart and is left out. Per frame: noexcept and allocation-free.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>

#include "../config.hpp"
#include "../core/units.hpp"
#include "dofs.hpp"

namespace glovepose::hand {

/// @brief The abduction a splay of 1 stands for: the OpenGloves drivers' full splay, 20 degrees.
inline constexpr double kFullSplay = 20.0 * core::kRadiansPerDegree;

/// @brief Joints per finger in OpenGloves' order, base to tip: thumb metacarpal (CMC), proximal
/// (MCP), distal (IP) and an unused 4th; a finger's metacarpal, proximal (MCP), middle (PIP),
/// distal (DIP).
inline constexpr std::size_t kCurlJoints = 4;

/// @brief A pose as curls and splays, fingers thumb to pinky.
struct FingerCurls {
  /// Each joint's curl, [0, 1], in OpenGloves' joint order (kCurlJoints). A finger's metacarpal
  /// (joint 0) has no DoF in the hand model and reads 0; the thumb's unused 4th repeats its tip.
  std::array<std::array<double, kCurlJoints>, kFingerCount> joints{};
  /// Each finger's curl, [0, 1]: the mean of its three flexion joints' curls.
  std::array<double, kFingerCount> curl{};
  /// Each finger's splay, [-1, 1]: its base abduction over kFullSplay, positive toward the thumb.
  std::array<double, kFingerCount> splay{};
};

/// @brief The curl of one flexion: `angle` over the DoF's upper limit, clamped to [0, 1].
GLOVEPOSE_REALTIME inline double joint_curl(double angle, double upper_limit) noexcept {
  return std::clamp(angle / upper_limit, 0.0, 1.0);
}

/// @brief `angles` (radians, kDofs order) as curls and splays; `limits` give each flexion's fully
/// bent angle (a model's JointLimits; the reference model's by default).
GLOVEPOSE_REALTIME inline FingerCurls finger_curls(const Angles& angles, const JointLimits& limits = JointLimits()) noexcept {
  FingerCurls out;
  constexpr Motion kFlexions[3] = {Motion::BaseFlexion, Motion::MiddleFlexion, Motion::TipFlexion};
  for (std::size_t f = 0; f < kFingerCount; ++f) {
    const auto finger = static_cast<Finger>(f);
    const bool thumb = finger == Finger::Thumb;
    double sum = 0.0;
    for (std::size_t k = 0; k < 3; ++k) {
      const std::size_t d = dof_of(finger, kFlexions[k]);
      const double curl = joint_curl(angles[d], limits.max()[d]);
      out.joints[f][thumb ? k : k + 1] = curl;
      sum += curl;
    }
    if (thumb) out.joints[f][3] = out.joints[f][2];
    out.curl[f] = sum / 3.0;
    out.splay[f] = std::clamp(angles[dof_of(finger, Motion::Abduction)] / kFullSplay, -1.0, 1.0);
  }
  return out;
}

}  // namespace glovepose::hand
