/// @file openxr_joints.hpp
/// @brief The hand as OpenXR's XR_EXT_hand_tracking describes it: 26 joints in XrHandJointEXT
/// order, each a pose (orientation, position), a radius and location flags, with plain structs laid
/// out like XrHandJointLocationEXT and XrHandJointVelocityEXT so that an engine copies them as they
/// are (tests/test_openxr_joints.cpp checks order, sizes and offsets against <openxr/openxr.h>).
///
/// Conventions (OpenXR 1.0, XR_EXT_hand_tracking, "Conventions of hand joints"): metres,
/// right-handed; a joint sits at the start of its bone; its +Z runs along the bone away from the
/// fingertip, its +Y out of the back of the finger (the nail side), X = Y x Z; a tip has its distal
/// bone's orientation. The wrist joint is the wrist's pivot, its +Z along the line from it to the
/// middle finger's metacarpal joint (away from the fingers), +Y out of the back of the hand; the
/// palm joint is the centre of the middle finger's metacarpal bone, oriented like the wrist.
///
/// Every pose is given in the wrist joint's frame (the wrist is the identity pose): the glove
/// senses the fingers, not where the hand is, so an engine places the hand by composing these
/// poses with the wrist pose its tracker reports. In that frame the fingers point along -Z, the back
/// of the hand faces +Y, and the thumb lies towards +X on a right hand, -X on a left one.
///
/// Where the hand model (hand/kinematics.hpp) has no joint, as OpenXR's index-to-little metacarpal
/// joints (the template's palm is one rigid body), an assumption of ours fills it: each finger's
/// metacarpal joint lies kMetacarpalStart of the way from the wrist pivot to its knuckle, inside
/// the template's carpal spheres. The thumb's metacarpal is the model's first thumb phalanx.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include <Eigen/Geometry>

#include "../config.hpp"
#include "kinematics.hpp"

namespace glovepose::hand {

/// @brief The joints in XrHandJointEXT order.
enum class XrJoint : int {
  Palm = 0,
  Wrist,
  ThumbMetacarpal,
  ThumbProximal,
  ThumbDistal,
  ThumbTip,
  IndexMetacarpal,
  IndexProximal,
  IndexIntermediate,
  IndexDistal,
  IndexTip,
  MiddleMetacarpal,
  MiddleProximal,
  MiddleIntermediate,
  MiddleDistal,
  MiddleTip,
  RingMetacarpal,
  RingProximal,
  RingIntermediate,
  RingDistal,
  RingTip,
  LittleMetacarpal,
  LittleProximal,
  LittleIntermediate,
  LittleDistal,
  LittleTip,
};

/// @brief Number of joints (XR_HAND_JOINT_COUNT_EXT).
inline constexpr std::size_t kXrJointCount = 26;

/// @brief Stable names of the joints, in XrHandJointEXT order.
inline constexpr std::array<const char*, kXrJointCount> kXrJointNames{"palm",
                                                                      "wrist",
                                                                      "thumb_metacarpal",
                                                                      "thumb_proximal",
                                                                      "thumb_distal",
                                                                      "thumb_tip",
                                                                      "index_metacarpal",
                                                                      "index_proximal",
                                                                      "index_intermediate",
                                                                      "index_distal",
                                                                      "index_tip",
                                                                      "middle_metacarpal",
                                                                      "middle_proximal",
                                                                      "middle_intermediate",
                                                                      "middle_distal",
                                                                      "middle_tip",
                                                                      "ring_metacarpal",
                                                                      "ring_proximal",
                                                                      "ring_intermediate",
                                                                      "ring_distal",
                                                                      "ring_tip",
                                                                      "little_metacarpal",
                                                                      "little_proximal",
                                                                      "little_intermediate",
                                                                      "little_distal",
                                                                      "little_tip"};

/// @brief Parent of each joint (-1 for the wrist): the palm and each digit's metacarpal hang off
/// the wrist, every other joint off the previous joint of its digit.
inline constexpr std::array<int, kXrJointCount> kXrJointParent{1,  -1, 1,  2, 3,  4,  1,  6,  7, 8,  9,  1,  11,
                                                               12, 13, 14, 1, 16, 17, 18, 19, 1, 21, 22, 23, 24};

/// @brief First joint of each digit (its metacarpal), digits in pose-map order (thumb .. little).
inline constexpr std::array<XrJoint, kFingerCount> kXrDigitFirst{
    XrJoint::ThumbMetacarpal, XrJoint::IndexMetacarpal, XrJoint::MiddleMetacarpal, XrJoint::RingMetacarpal, XrJoint::LittleMetacarpal};

/// @brief Share of the wrist-to-knuckle line at which a finger's metacarpal joint lies (assumption,
/// see the file comment).
inline constexpr double kMetacarpalStart = 0.2;

/// @brief Radius (mm) of each joint on the reference hand, from the template's spheres
/// (honline-cpp-public data/models/anastasia/R.txt and C.txt, the hand model's source; numbers
/// carried as facts): a finger joint takes the sphere centred on it; a finger's metacarpal joint the
/// palm sphere over its knuckle (the palm's thickness there); the palm the palm sphere over the
/// middle finger; the wrist the mean of the template's two wrist spheres.
inline constexpr std::array<double, kXrJointCount> kXrReferenceRadius{10.726, 12.943, 15.683, 10.312, 7.308, 7.031, 9.505, 8.441,  7.553,
                                                                      5.853,  5.174,  10.726, 7.688,  7.643, 5.676, 5.584, 10.217, 7.268,
                                                                      6.971,  5.012,  4.850,  8.985,  7.846, 6.226, 4.772, 4.180};

/// @brief Bits of XrJointLocation::location_flags (the values of XrSpaceLocationFlags).
enum XrLocationFlag : std::uint64_t {
  kXrOrientationValid = 0x1,    ///< XR_SPACE_LOCATION_ORIENTATION_VALID_BIT
  kXrPositionValid = 0x2,       ///< XR_SPACE_LOCATION_POSITION_VALID_BIT
  kXrOrientationTracked = 0x4,  ///< XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT
  kXrPositionTracked = 0x8,     ///< XR_SPACE_LOCATION_POSITION_TRACKED_BIT
};
/// @brief Values of XrHandTrackingDataSourceEXT (XR_EXT_hand_tracking_data_source): where the joints
/// come from. A data glove measures the hand itself, free to move: "unobstructed", which the
/// extension names for data gloves and optical tracking alike.
enum XrHandDataSource : std::uint32_t {
  kXrDataSourceUnobstructed = 1,  ///< XR_HAND_TRACKING_DATA_SOURCE_UNOBSTRUCTED_EXT
  kXrDataSourceController = 2,    ///< XR_HAND_TRACKING_DATA_SOURCE_CONTROLLER_EXT
};
/// @brief Bits of XrJointVelocity::velocity_flags (the values of XrSpaceVelocityFlags).
enum XrVelocityFlag : std::uint64_t {
  kXrLinearVelocityValid = 0x1,   ///< XR_SPACE_VELOCITY_LINEAR_VALID_BIT
  kXrAngularVelocityValid = 0x2,  ///< XR_SPACE_VELOCITY_ANGULAR_VALID_BIT
};

/// @brief Like XrVector3f.
struct XrVector3 {
  float x = 0, y = 0, z = 0;
};
/// @brief Like XrQuaternionf (x, y, z, w).
struct XrQuaternion {
  float x = 0, y = 0, z = 0, w = 1;
};
/// @brief Like XrPosef: orientation, then position.
struct XrPose {
  XrQuaternion orientation;
  XrVector3 position;
};
/// @brief Like XrHandJointLocationEXT: flags, pose (metres), radius (metres).
struct XrJointLocation {
  std::uint64_t location_flags = 0;
  XrPose pose;
  float radius = 0;
};
/// @brief Like XrHandJointVelocityEXT: flags, linear (m/s) and angular (rad/s) velocity, both in
/// the wrist frame.
struct XrJointVelocity {
  std::uint64_t velocity_flags = 0;
  XrVector3 linear_velocity;
  XrVector3 angular_velocity;
};

/// @brief All joint locations, in XrHandJointEXT order.
using XrJointLocations = std::array<XrJointLocation, kXrJointCount>;

/// @brief The joints' frames in double precision, in the wrist joint's frame: positions (metres)
/// and rotations (columns X, Y, Z), XrHandJointEXT order.
struct XrJointFrames {
  std::array<Eigen::Vector3d, kXrJointCount> position;
  std::array<Eigen::Matrix3d, kXrJointCount> rotation;
};

/// @brief Turns a posed skeleton into the 26 OpenXR joint locations of one hand model.
///
/// The palm is one rigid body whatever the angles (no DoF turns it), so the wrist joint's frame,
/// the palm joint and the finger metacarpal joints are fixed: found once here. A skeleton posed
/// with root() comes out in the wrist joint's frame, leaving only the digits to convert per pose.
/// Immutable after construction; every call is noexcept and allocation-free.
class XrJointMapper {
 public:
  /// @brief A mapper for the given kinematics (its hand model sets the joint radii: the reference
  /// radii scaled by the middle finger's length from the wrist against the reference hand's).
  explicit XrJointMapper(const Kinematics& kinematics) : kinematics_(kinematics) {
    const double scale = middle_length(kinematics.model()) / middle_length(HandModel::reference());
    for (std::size_t j = 0; j < kXrJointCount; ++j) radius_[j] = static_cast<float>(kXrReferenceRadius[j] * scale * 1e-3);
    palm_joints(kinematics);
  }

  /// @brief The kinematics the skeletons come from.
  const Kinematics& kinematics() const noexcept { return kinematics_; }
  /// @brief Radius of each joint (metres).
  const std::array<float, kXrJointCount>& radii() const noexcept { return radius_; }
  /// @brief The root to pose skeletons with (Kinematics::pose) so that they lie in the wrist
  /// joint's frame (mm): the inverse of the wrist joint's pose in the kinematics' root frame.
  const Eigen::Affine3d& root() const noexcept { return root_; }

  /// @brief The joint locations of `skeleton` (posed by kinematics() with root()), each with
  /// `location_flags`.
  GLOVEPOSE_REALTIME void locate(const Skeleton& skeleton, std::uint64_t location_flags, XrJointLocations& out) const noexcept {
    XrJointFrames joints;
    frames(skeleton, joints);
    write(joints, location_flags, out);
  }

  /// @brief The joints' frames of `skeleton` (posed with root()) in the wrist joint's frame (metres).
  GLOVEPOSE_REALTIME void frames(const Skeleton& skeleton, XrJointFrames& out) const noexcept {
    for (std::size_t f = 0; f < kFingerCount; ++f) {
      const auto base = static_cast<std::size_t>(kFingerBase[f]);
      const std::size_t joint = digit_joint(f);
      for (std::size_t k = 0; k < 3; ++k) {
        out.position[joint + k] = skeleton[base + k].translation() * 1e-3;
        out.rotation[joint + k] = to_xr(skeleton[base + k].linear());
      }
      out.position[joint + 3] = kinematics_.fingertip(skeleton, static_cast<Finger>(f)) * 1e-3;
      out.rotation[joint + 3] = out.rotation[joint + 2];
    }
    for (std::size_t k = 0; k < kPalmJoints.size(); ++k) {
      const auto j = static_cast<std::size_t>(kPalmJoints[k]);
      out.position[j] = palm_.position[k];
      out.rotation[j] = palm_.rotation[k];
    }
  }

  /// @brief The first joint of digit f (kFingerBase order) that the model's phalanges move: its
  /// proximal joint, or the thumb's metacarpal (the model's first thumb phalanx).
  static constexpr std::size_t digit_joint(std::size_t f) noexcept {
    const auto first = static_cast<std::size_t>(kXrDigitFirst[f]);
    return f == 0 ? first : first + 1;
  }

  /// @brief `joints` as OpenXR locations with `location_flags` and this hand's radii.
  GLOVEPOSE_REALTIME void write(const XrJointFrames& joints, std::uint64_t location_flags, XrJointLocations& out) const noexcept {
    for (std::size_t j = 0; j < kXrJointCount; ++j) {
      const Eigen::Vector3d& p = joints.position[j];
      XrJointLocation& joint = out[j];
      joint.location_flags = location_flags;
      joint.pose.position = {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
      joint.radius = radius_[j];
    }
    // Orientations: the palm's are fixed, a tip's is its distal joint's; the rest are converted.
    for (std::size_t k = 0; k < kPalmJoints.size(); ++k)
      out[static_cast<std::size_t>(kPalmJoints[k])].pose.orientation = palm_.orientation[k];
    for (std::size_t f = 0; f < kFingerCount; ++f) {
      const std::size_t joint = digit_joint(f);
      for (std::size_t k = 0; k < 3; ++k) out[joint + k].pose.orientation = quaternion(joints.rotation[joint + k]);
      out[joint + 3].pose.orientation = out[joint + 2].pose.orientation;
    }
  }

 private:
  // The joints on the palm, which no angle moves.
  static constexpr std::array<XrJoint, 6> kPalmJoints{
      XrJoint::Palm,           XrJoint::Wrist,           XrJoint::IndexMetacarpal, XrJoint::MiddleMetacarpal,
      XrJoint::RingMetacarpal, XrJoint::LittleMetacarpal};

  // A rotation as a unit quaternion with w >= 0 (one of the two signs, the same on both hands).
  static XrQuaternion quaternion(const Eigen::Matrix3d& rotation) noexcept {
    Eigen::Quaterniond q(rotation);
    q.normalize();
    if (q.w() < 0) q.coeffs() = -q.coeffs();
    return {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()), static_cast<float>(q.w())};
  }

  // The model's phalanx frames: bone along +y, flexion turns +y towards +z, so the back of the
  // digit is -z; OpenXR's (x, y, z) = (-x, -z, -y) of the phalanx frame.
  static Eigen::Matrix3d to_xr(const Eigen::Matrix3d& phalanx) noexcept {
    Eigen::Matrix3d r;
    r.col(0) = -phalanx.col(0);
    r.col(1) = -phalanx.col(2);
    r.col(2) = -phalanx.col(1);
    return r;
  }

  // An OpenXR joint frame for a bone running along `bone` on a hand whose back faces `back`:
  // +Z = -bone, +Y = back made perpendicular to it, X = Y x Z.
  static Eigen::Matrix3d frame(const Eigen::Vector3d& bone, const Eigen::Vector3d& back) noexcept {
    const Eigen::Vector3d z = -bone.normalized();
    const Eigen::Vector3d y = (back - back.dot(z) * z).normalized();
    Eigen::Matrix3d r;
    r.col(0) = y.cross(z);
    r.col(1) = y;
    r.col(2) = z;
    return r;
  }

  // The wrist joint's pose (root()) and the palm's joints in its frame, from the rest pose.
  void palm_joints(const Kinematics& kinematics) {
    Skeleton skeleton;
    kinematics.pose(Angles{}, skeleton);
    const Eigen::Vector3d wrist = skeleton[static_cast<std::size_t>(Phalanx::Wrist)].translation();
    const Eigen::Vector3d back = skeleton[static_cast<std::size_t>(Phalanx::Hand)].linear().col(2);
    const auto knuckle = [&](Finger f) {
      return Eigen::Vector3d(skeleton[static_cast<std::size_t>(kFingerBase[static_cast<std::size_t>(f)])].translation());
    };
    std::array<Eigen::Vector3d, 6> position;
    std::array<Eigen::Matrix3d, 6> rotation;
    const Finger fingers[] = {Finger::Index, Finger::Middle, Finger::Ring, Finger::Pinky};
    for (std::size_t k = 0; k < 4; ++k) {
      position[k + 2] = wrist + kMetacarpalStart * (knuckle(fingers[k]) - wrist);
      rotation[k + 2] = frame(knuckle(fingers[k]) - position[k + 2], back);
    }
    const Eigen::Vector3d& middle_metacarpal = position[3];
    position[1] = wrist;
    rotation[1] = frame(middle_metacarpal - wrist, back);
    position[0] = 0.5 * (middle_metacarpal + knuckle(Finger::Middle));
    rotation[0] = frame(knuckle(Finger::Middle) - middle_metacarpal, back);
    root_ = Eigen::Affine3d::Identity();
    root_.linear() = rotation[1].transpose();
    root_.translation() = -(rotation[1].transpose() * wrist);
    for (std::size_t k = 0; k < 6; ++k) {
      palm_.position[k] = root_.linear() * (position[k] - wrist) * 1e-3;
      palm_.rotation[k] = root_.linear() * rotation[k];
      palm_.orientation[k] = quaternion(palm_.rotation[k]);
    }
  }

  // Wrist pivot to the middle fingertip along the bones at rest (mm): the hand's size.
  static double middle_length(const HandModel& model) {
    const auto base = static_cast<std::size_t>(Phalanx::Middle1);
    return model.rest[base].translation().norm() + model.rest[base + 1].translation().norm() + model.rest[base + 2].translation().norm() +
           model.tip_length[static_cast<std::size_t>(Finger::Middle)];
  }

  Kinematics kinematics_;
  std::array<float, kXrJointCount> radius_{};
  Eigen::Affine3d root_;
  struct {
    std::array<Eigen::Vector3d, kPalmJoints.size()> position;
    std::array<Eigen::Matrix3d, kPalmJoints.size()> rotation;
    std::array<XrQuaternion, kPalmJoints.size()> orientation;
  } palm_;
};

}  // namespace glovepose::hand
