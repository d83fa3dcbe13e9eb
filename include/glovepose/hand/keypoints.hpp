/// @file keypoints.hpp
/// @brief A hand tracker's 3D keypoints on the hand model: the two common layouts (MediaPipe's 21
/// hand landmarks, OpenXR's 26 XR_EXT_hand_tracking joints), where each keypoint sits on the
/// model's chain, and the keypoints' positions and derivatives for a pose.
///
/// What a keypoint is on the model (the tracker's definitions, carried as facts):
/// - MediaPipe Hands (Google, "Hand landmarks detection guide", the HandLandmark enum): the wrist,
///   then per digit four points from the palm out: thumb CMC, MCP, IP, tip; a finger's MCP, PIP, DIP,
///   tip. On the model: the wrist pivot, the origin of each phalanx (the joint it turns about) and
///   the end of the distal phalanx.
/// - OpenXR (XR_EXT_hand_tracking): the joints of hand/openxr_joints.hpp, as XrJointMapper places
///   them (its assumption for the finger metacarpals included).
/// A keypoint is fixed to one phalanx (a joint to the phalanx before it, a tip to the distal one), so
/// the DoFs that move it are those of that phalanx and its ancestors.
#pragma once

#include <array>
#include <cstddef>
#include <string>

#include <Eigen/Geometry>

#include "../config.hpp"
#include "dofs.hpp"
#include "kinematics.hpp"
#include "openxr_joints.hpp"

namespace glovepose::hand {

/// @brief The keypoint sets a hand tracker reports.
enum class KeypointLayout : unsigned char { MediaPipe = 0, OpenXr };
/// @brief Number of layouts.
inline constexpr std::size_t kKeypointLayoutCount = 2;
/// @brief The layout's name as a command line takes it: "mediapipe", "openxr".
constexpr const char* to_string(KeypointLayout layout) noexcept {
  constexpr const char* names[] = {"mediapipe", "openxr"};
  static_assert(sizeof(names) / sizeof(names[0]) == kKeypointLayoutCount, "one name per layout");
  return name_of(layout, names, "unknown layout");
}

/// @brief Number of MediaPipe hand landmarks.
inline constexpr std::size_t kMediaPipeKeypointCount = 21;
/// @brief MediaPipe's landmark names (its HandLandmark enum, lower case), in its order.
inline constexpr std::array<const char*, kMediaPipeKeypointCount> kMediaPipeNames{
    "wrist",          "thumb_cmc",         "thumb_mcp",         "thumb_ip",          "thumb_tip",         "index_finger_mcp",
    "index_finger_pip", "index_finger_dip", "index_finger_tip",  "middle_finger_mcp", "middle_finger_pip", "middle_finger_dip",
    "middle_finger_tip", "ring_finger_mcp",  "ring_finger_pip",   "ring_finger_dip",   "ring_finger_tip",   "pinky_mcp",
    "pinky_pip",        "pinky_dip",         "pinky_tip"};

/// @brief Most keypoints of any layout.
inline constexpr std::size_t kMaxKeypoints = kXrJointCount;

/// @brief Number of keypoints of a layout.
constexpr std::size_t keypoint_count(KeypointLayout layout) noexcept {
  return layout == KeypointLayout::MediaPipe ? kMediaPipeKeypointCount : kXrJointCount;
}
/// @brief Name of keypoint k of a layout (MediaPipe's or OpenXR's joint names), "" past the end.
constexpr const char* keypoint_name(KeypointLayout layout, std::size_t k) noexcept {
  if (k >= keypoint_count(layout)) return "";
  return layout == KeypointLayout::MediaPipe ? kMediaPipeNames[k] : kXrJointNames[k];
}

/// @brief Positions of a layout's keypoints (mm); entries past the layout's count are unused. A
/// missing keypoint is NaN.
using KeypointPositions = std::array<Eigen::Vector3d, kMaxKeypoints>;

/// @brief Where a keypoint sits: on a phalanx (by id), at a fixed point of its frame (mm).
struct KeypointAnchor {
  int phalanx = 0;
  Eigen::Vector3d local = Eigen::Vector3d::Zero();
};

/// @brief A layout's keypoints on one hand model: their positions for a pose and how they move.
/// Immutable after construction; per-pose calls are noexcept and allocation-free.
class KeypointModel {
 public:
  /// @brief The layout's keypoints placed on `kinematics`' hand (its rest pose defines them).
  KeypointModel(KeypointLayout layout, const Kinematics& kinematics) : layout_(layout), kinematics_(kinematics) {
    Skeleton rest;
    std::array<Eigen::Vector3d, kMaxKeypoints> point;
    std::array<int, kMaxKeypoints> phalanx{};
    const auto origin_of = [&](Phalanx p) { return Eigen::Vector3d(rest[static_cast<std::size_t>(p)].translation()); };
    // A digit's keypoints from the palm out: the three phalanx origins, then the tip.
    const auto digit = [&](std::size_t first, std::size_t f) {
      const int base = static_cast<int>(kFingerBase[f]);
      for (int k = 0; k < 3; ++k) {
        point[first + static_cast<std::size_t>(k)] = origin_of(static_cast<Phalanx>(base + k));
        phalanx[first + static_cast<std::size_t>(k)] = k == 0 ? static_cast<int>(Phalanx::Hand) : base + k - 1;
      }
      point[first + 3] = kinematics.fingertip(rest, static_cast<Finger>(f));
      phalanx[first + 3] = base + 2;
    };
    if (layout == KeypointLayout::MediaPipe) {
      kinematics.pose(Angles{}, rest);
      point[0] = origin_of(Phalanx::Wrist);
      phalanx[0] = static_cast<int>(Phalanx::Hand);
      for (std::size_t f = 0; f < kFingerCount; ++f) digit(1 + 4 * f, f);
    } else {
      const XrJointMapper mapper(kinematics);
      kinematics.pose(Angles{}, rest, mapper.root());
      for (std::size_t f = 0; f < kFingerCount; ++f) digit(XrJointMapper::digit_joint(f), f);
      XrJointFrames frames;
      mapper.frames(rest, frames);
      for (XrJoint j : {XrJoint::Palm, XrJoint::Wrist, XrJoint::IndexMetacarpal, XrJoint::MiddleMetacarpal, XrJoint::RingMetacarpal,
                        XrJoint::LittleMetacarpal}) {
        point[static_cast<std::size_t>(j)] = frames.position[static_cast<std::size_t>(j)] * 1e3;
        phalanx[static_cast<std::size_t>(j)] = static_cast<int>(Phalanx::Hand);
      }
    }
    for (std::size_t k = 0; k < count(); ++k) {
      anchor_[k].phalanx = phalanx[k];
      anchor_[k].local = rest[static_cast<std::size_t>(phalanx[k])].inverse() * point[k];
    }
  }

  /// @brief The layout.
  KeypointLayout layout() const noexcept { return layout_; }
  /// @brief Number of keypoints.
  std::size_t count() const noexcept { return keypoint_count(layout_); }
  /// @brief The kinematics the keypoints sit on.
  const Kinematics& kinematics() const noexcept { return kinematics_; }
  /// @brief Where keypoint k sits.
  const KeypointAnchor& anchor(std::size_t k) const noexcept { return anchor_[k]; }
  /// @brief Whether no DoF moves keypoint k (it is fixed to the palm).
  bool on_palm(std::size_t k) const noexcept { return anchor_[k].phalanx == static_cast<int>(Phalanx::Hand); }
  /// @brief The digit whose DoFs move keypoint k, or -1 for a keypoint on the palm.
  int digit_of(std::size_t k) const noexcept {
    for (std::size_t f = 0; f < kFingerCount; ++f) {
      const int base = static_cast<int>(kFingerBase[f]);
      if (anchor_[k].phalanx >= base && anchor_[k].phalanx < base + 3) return static_cast<int>(f);
    }
    return -1;
  }
  /// @brief Whether DoF d moves keypoint k: d turns the keypoint's phalanx or one of its ancestors.
  bool moves(std::size_t d, std::size_t k) const noexcept {
    for (int p = anchor_[k].phalanx; p >= 0; p = kParent[static_cast<std::size_t>(p)])
      if (p == kDofs[d].phalanx) return true;
    return false;
  }

  /// @brief The keypoints' positions (mm) in a skeleton posed by kinematics().
  GLOVEPOSE_REALTIME void positions(const Skeleton& skeleton, KeypointPositions& out) const noexcept {
    for (std::size_t k = 0; k < count(); ++k) out[k] = skeleton[static_cast<std::size_t>(anchor_[k].phalanx)] * anchor_[k].local;
  }

 private:
  KeypointLayout layout_;
  Kinematics kinematics_;
  std::array<KeypointAnchor, kMaxKeypoints> anchor_{};
};

}  // namespace glovepose::hand
