/// @file joint_list_types.hpp
/// @brief The hand's joints as an engine-friendly list: 21 joints, each a position in metres and a
/// unit quaternion, in the order of the common 21-point hand convention (wrist/palm, then per finger
/// from the knuckle to the tip; thumb, index, middle, ring, pinky).
///
/// What an engine drives a skeleton with. The frames come from hand::Kinematics (the reference chain
/// of Tkach et al. 2017): each joint's position is the origin of the phalanx that starts there, its
/// rotation that phalanx's orientation; a tip takes the orientation of its distal phalanx and lies
/// at the end of it. Coordinates: the hand model's root frame (right hand), right-handed, metres.
/// At rest the fingers point along +Y, +X points from the pinky side towards the thumb side, and
/// flexing a finger moves its tip towards -Z: the palm faces -Z, the back of the hand +Z
/// (tests/test_estimator.cpp checks these directions). A left hand's list (Kinematics of
/// Handedness::Left) is the right hand's mirrored: x -> -x, the thumb towards -X. An engine with a
/// left-handed, Y-up frame (e.g. Unity) mirrors X (x -> -x) and negates the quaternion's y and z.
/// OpenXR's 26-joint layout with its own conventions: openxr_joints.hpp.
#pragma once

#include <array>
#include <cstddef>

namespace glovepose::hand {

/// @brief The joints of the list, in list order.
enum class Joint : int {
  Palm = 0,  ///< Root of the fingers (the palm frame).
  ThumbMetacarpal,
  ThumbProximal,
  ThumbDistal,
  ThumbTip,  ///< Thumb: CMC, MCP, IP joints and the tip.
  IndexProximal,
  IndexIntermediate,
  IndexDistal,
  IndexTip,  ///< Index: MCP, PIP, DIP joints and the tip.
  MiddleProximal,
  MiddleIntermediate,
  MiddleDistal,
  MiddleTip,  ///< Middle finger.
  RingProximal,
  RingIntermediate,
  RingDistal,
  RingTip,  ///< Ring finger.
  PinkyProximal,
  PinkyIntermediate,
  PinkyDistal,
  PinkyTip,  ///< Pinky.
};

/// @brief Number of joints in the list.
inline constexpr std::size_t kJointCount = 21;

/// @brief Stable names of the joints, in list order (for logs, files and bindings).
inline constexpr std::array<const char*, kJointCount> kJointNames{"palm",       "thumb_metacarpal", "thumb_proximal",      "thumb_distal",
                                                                  "thumb_tip",  "index_proximal",   "index_intermediate",  "index_distal",
                                                                  "index_tip",  "middle_proximal",  "middle_intermediate", "middle_distal",
                                                                  "middle_tip", "ring_proximal",    "ring_intermediate",   "ring_distal",
                                                                  "ring_tip",   "pinky_proximal",   "pinky_intermediate",  "pinky_distal",
                                                                  "pinky_tip"};

/// @brief Parent of each joint in the list (-1 for the palm): the previous joint of the same finger,
/// or the palm for a finger's first joint.
inline constexpr std::array<int, kJointCount> kJointParent{-1, 0, 1, 2, 3, 0, 5, 6, 7, 0, 9, 10, 11, 0, 13, 14, 15, 0, 17, 18, 19};

/// @brief One joint: position and orientation in the root frame.
struct JointTransform {
  std::array<float, 3> position{};            ///< Metres: x, y, z.
  std::array<float, 4> rotation{0, 0, 0, 1};  ///< Unit quaternion: x, y, z, w.
};

/// @brief All joints, indexed by Joint.
using JointList = std::array<JointTransform, kJointCount>;

}  // namespace glovepose::hand
