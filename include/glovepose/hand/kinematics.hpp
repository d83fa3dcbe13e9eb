/// @file kinematics.hpp
/// @brief Forward kinematics of the reference hand model's chain: each phalanx's transform from
/// the 25 finger angles.
///
/// Source: Tkach et al. 2017, public repository anastasia-tkach/honline-cpp-public
/// (tracker/HModel/Model.cpp for the chain and the order of rotations, data/models/anastasia/I.txt
/// for the rest pose).
///
/// Frames: millimetres, in the model's root frame (the palm's frame at rest). Each phalanx's bone
/// points along its local +Y; X is the flexion axis, Z abduction, Y twist. The global pose
/// (theta 0..5) and the wrist (theta 7, 8) cannot be sensed by the glove; a caller may pass a root
/// transform instead.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <memory>
#include <utility>

#include <Eigen/Geometry>

#include "../config.hpp"
#include "dofs.hpp"
#include "handedness.hpp"

namespace glovepose::hand {

/// @brief Phalanx ids of the reference model (also the index into a Skeleton).
enum class Phalanx : int {
  Hand = 0,
  Thumb1,
  Thumb2,
  Thumb3,
  Pinky1,
  Pinky2,
  Pinky3,
  Ring1,
  Ring2,
  Ring3,
  Middle1,
  Middle2,
  Middle3,
  Index1,
  Index2,
  Index3,
  Wrist,
  Position,
};

/// @brief Number of phalanxes (frames) in the reference chain.
inline constexpr std::size_t kPhalanxCount = 18;

/// @brief Parent of each phalanx (-1 for the root, Position). Reference: 17 -> 0; 0 -> {1, 4, 7, 10,
/// 13, 16}; each finger is a chain base -> middle -> tip.
inline constexpr std::array<int, kPhalanxCount> kParent{17, 0, 1, 2, 0, 4, 5, 0, 7, 8, 0, 10, 11, 0, 13, 14, 0, -1};

/// @brief The order in which frames are composed: every parent before its children.
inline constexpr std::array<int, kPhalanxCount> kChainOrder{17, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16};

/// @brief A rigid rest transform typed in from the reference: rotation (row-major) and translation (mm).
struct RestTransform {
  std::array<double, 9> rotation;     ///< Row-major 3x3.
  std::array<double, 3> translation;  ///< Millimetres, in the parent's frame.
};

/// @brief Rest matrices of the template hand, one per phalanx id, relative to the parent.
///
/// Typed in from honline-cpp-public data/models/anastasia/I.txt (stored there column-major; here
/// row-major). tests/test_kinematics.cpp checks this table against
/// that file and the posed chain against the template's sphere centres (C.txt).
inline constexpr std::array<RestTransform, kPhalanxCount> kReferenceRest{{
    {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}},  // 0 hand (palm)
    {{-0.305523, 0.319439, 0.897003, -0.766703, 0.4761, -0.430691, -0.564642, -0.819321, 0.0994552},
     {9.72575, 3.87206, -7.16046}},                                                                                // 1 thumb base
    {{0.997074, -0.0749142, -0.0151859, 0.0764379, 0.977199, 0.198088, 0, -0.198669, 0.980067}, {0, 37.1409, 0}},  // 2 thumb middle
    {{0.998709, 0.0497797, 0.0100908, -0.0507922, 0.978802, 0.198413, 0, -0.198669, 0.980067}, {0, 28.436, 0}},    // 3 thumb tip
    {{-0.900232, -0.376838, 0.218117, -0.395267, 0.917393, -0.0464125, -0.182609, -0.127996, -0.974818},
     {-18.1006, 44.8872, 6.8978}},                                                  // 4 pinky base
    {{0.998521, -0.0543646, 0, 0.0543646, 0.998521, 0, 0, 0, 1}, {0, 31.9997, 0}},  // 5 pinky middle
    {{0.996917, -0.0784591, 0, 0.0784591, 0.996917, 0, 0, 0, 1}, {0, 19.1319, 0}},  // 6 pinky tip
    {{-0.98734, -0.158012, 0.0138762, -0.15862, 0.983554, -0.0863733, 0, -0.0874808, -0.996166},
     {-5.93253, 49.1046, 10.7991}},                                                 // 7 ring base
    {{0.999922, -0.012492, 0, 0.012492, 0.999922, 0, 0, 0, 1}, {0, 37.9263, 0}},    // 8 ring middle
    {{0.996917, -0.0784591, 0, 0.0784591, 0.996917, 0, 0, 0, 1}, {0, 23.9032, 0}},  // 9 ring tip
    {{-0.992608, -0.0159037, -0.120316, -0.0199468, 0.999274, 0.0324749, 0.119712, 0.0346348, -0.992204},
     {8.13206, 52.8925, 10.5463}},                                                  // 10 middle base
    {{0.996917, 0.0784591, 0, -0.0784591, 0.996917, 0, 0, 0, 1}, {0, 40.4944, 0}},  // 11 middle middle
    {{0.999891, -0.0147668, 0, 0.0147668, 0.999891, 0, 0, 0, 1}, {0, 23.2687, 0}},  // 12 middle tip
    {{-0.95871, 0.151187, -0.240868, 0.13524, 0.987454, 0.081515, 0.25017, 0.0455744, -0.967129},
     {25.3963, 50.8191, 5.28707}},                                                  // 13 index base
    {{0.99978, 0.0209711, 0, -0.0209711, 0.99978, 0, 0, 0, 1}, {0, 37.0552, 0}},    // 14 index middle
    {{0.996802, 0.0799147, 0, -0.0799147, 0.996802, 0, 0, 0, 1}, {0, 20.5967, 0}},  // 15 index tip
    {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}},                                       // 16 wrist
    {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}},                                       // 17 position (root)
}};

/// @brief Length (mm) of each finger's distal phalanx, which has no child frame to end it.
/// Thumb, index, middle, ring, pinky; from honline-cpp-public's template (its phalanx lengths).
inline constexpr std::array<double, kFingerCount> kReferenceTipLength{14.032, 12.833, 15.907, 13.601, 12.821};

/// @brief Phalanx id of each finger's base (proximal) phalanx, fingers in pose-map order.
inline constexpr std::array<Phalanx, kFingerCount> kFingerBase{Phalanx::Thumb1, Phalanx::Index1, Phalanx::Middle1, Phalanx::Ring1,
                                                               Phalanx::Pinky1};

/// @brief Global transform (root frame, mm) of every phalanx, indexed by phalanx id.
using Skeleton = std::array<Eigen::Affine3d, kPhalanxCount>;

/// @brief The world direction (root frame, unit) of each DoF's rotation axis in a pose, kDofs
/// order: turning DoF d by a small angle e turns everything beyond it by e about this axis through
/// its phalanx's origin. What joint velocities are made of (xr_hand.hpp in this folder).
using DofAxes = std::array<Eigen::Vector3d, kDofCount>;

/// @brief A hand's rest geometry: rest transform of each phalanx relative to its parent, and the
/// distal phalanx lengths. The default is the reference template hand; the simulator scales it.
struct HandModel {
  std::array<Eigen::Affine3d, kPhalanxCount> rest;  ///< Per phalanx id, relative to the parent.
  std::array<double, kFingerCount> tip_length{};    ///< Distal phalanx lengths, mm.

  /// @brief The reference template hand (kReferenceRest, kReferenceTipLength).
  static HandModel reference() {
    HandModel model;
    for (std::size_t p = 0; p < kPhalanxCount; ++p) {
      const RestTransform& r = kReferenceRest[p];
      Eigen::Matrix3d rotation;
      rotation << r.rotation[0], r.rotation[1], r.rotation[2], r.rotation[3], r.rotation[4], r.rotation[5], r.rotation[6], r.rotation[7],
          r.rotation[8];
      model.rest[p] = Eigen::Affine3d::Identity();
      model.rest[p].linear() = rotation;
      model.rest[p].translation() = Eigen::Vector3d(r.translation[0], r.translation[1], r.translation[2]);
    }
    for (std::size_t f = 0; f < kFingerCount; ++f) model.tip_length[f] = kReferenceTipLength[f];
    return model;
  }

  /// @brief The hand a configuration names (EstimatorConfig::hand): `chosen`, or the reference
  /// hand where none is chosen.
  static HandModel chosen_or_reference(const std::shared_ptr<const HandModel>& chosen) { return chosen ? *chosen : reference(); }
};

/// @brief The mirror image of a rigid transform through the x = 0 plane, kept right-handed:
/// S T S with S = diag(-1, 1, 1) (translation x negated; rotation rows and columns 0 negated).
GLOVEPOSE_REALTIME inline Eigen::Affine3d mirrored(const Eigen::Affine3d& transform) noexcept {
  Eigen::Affine3d out = transform;
  out.linear().row(0) *= -1.0;
  out.linear().col(0) *= -1.0;
  out.translation().x() = -out.translation().x();
  return out;
}

/// @brief Forward kinematics: angles -> the global transform of every phalanx.
///
/// Local transform of phalanx p: rest[p] * Rx(flexion) * Rz(abduction) * Ry(twist), the reference
/// tracker's order (it right-multiplies all flexions, then all abductions, then all twists); a
/// phalanx without a DoF on an axis gets the identity there. Global = parent global * local.
/// A left hand's chain is the right hand's mirrored (handedness.hpp): the same angles give the
/// mirror image of the right hand's pose.
class Kinematics {
 public:
  /// @brief Kinematics of the given hand (default: the reference template hand, right side).
  explicit Kinematics(HandModel model = HandModel::reference(), Handedness side = Handedness::Right)
      : model_(std::move(model)), side_(side) {
    flexion_.fill(-1);
    abduction_.fill(-1);
    twist_.fill(-1);
    for (std::size_t i = 0; i < kDofCount; ++i) {
      const auto p = static_cast<std::size_t>(kDofs[i].phalanx);
      auto& slot = kDofs[i].axis == Axis::X ? flexion_ : (kDofs[i].axis == Axis::Z ? abduction_ : twist_);
      slot[p] = static_cast<int>(i);
    }
  }

  /// @brief The hand geometry in use.
  const HandModel& model() const noexcept { return model_; }
  /// @brief The side the chain is for.
  Handedness side() const noexcept { return side_; }

  /// @brief Global transform of every phalanx for the given angles (radians, kDofs order), with the
  /// root (Position) frame at `root`. A left hand: the right hand's frames mirrored, then `root`.
  GLOVEPOSE_REALTIME void pose(const Angles& angles, Skeleton& out,
                               const Eigen::Affine3d& root = Eigen::Affine3d::Identity()) const noexcept {
    compose(angles, out, root, nullptr);
  }

  /// @brief pose() and the axis of every DoF in the same frame.
  GLOVEPOSE_REALTIME void pose(const Angles& angles, Skeleton& out, DofAxes& axes,
                               const Eigen::Affine3d& root = Eigen::Affine3d::Identity()) const noexcept {
    compose(angles, out, root, &axes);
  }

  /// @brief End point of a finger's distal phalanx (its tip), in the root frame.
  GLOVEPOSE_REALTIME Eigen::Vector3d fingertip(const Skeleton& skeleton, Finger finger) const noexcept {
    const auto f = static_cast<std::size_t>(finger);
    const auto tip = static_cast<std::size_t>(static_cast<int>(kFingerBase[f]) + 2);
    return skeleton[tip] * Eigen::Vector3d(0.0, model_.tip_length[f], 0.0);
  }

 private:
  void compose(const Angles& angles, Skeleton& out, const Eigen::Affine3d& root, DofAxes* axes) const noexcept {
    const bool left = side_ == Handedness::Left;
    for (int p : kChainOrder) {
      const auto i = static_cast<std::size_t>(p);
      const Eigen::Affine3d& parent = kParent[i] < 0 ? (left ? identity_ : root) : out[static_cast<std::size_t>(kParent[i])];
      Eigen::Affine3d local = model_.rest[i];
      // Each rotation turns about the frame's local axis as it stands after the rotations before
      // it; `turned` is that frame's orientation in the root frame (only when axes are asked for).
      Eigen::Matrix3d turned;
      if (axes) turned = parent.linear() * local.linear();
      // Turning about local axis a by theta mixes the two other columns (i, j) = (a+1, a+2) of a
      // frame M: M R_a(theta) has columns c M_i + s M_j and c M_j - s M_i there (a 3x3 product
      // written out, a quarter of the work).
      const auto turn = [&](int dof, int axis) {
        if (dof < 0) return;
        const double angle = angles[static_cast<std::size_t>(dof)];
        const double c = std::cos(angle), s = std::sin(angle);
        const Eigen::Index first = (axis + 1) % 3, second = (axis + 2) % 3;
        const auto rotate = [&](auto&& frame) {
          const Eigen::Vector3d m_first = frame.col(first), m_second = frame.col(second);
          frame.col(first) = c * m_first + s * m_second;
          frame.col(second) = c * m_second - s * m_first;
        };
        if (axes) {
          (*axes)[static_cast<std::size_t>(dof)] = turned.col(axis);
          rotate(turned);
        }
        rotate(local.linear());
      };
      turn(flexion_[i], 0);
      turn(abduction_[i], 2);
      turn(twist_[i], 1);
      out[i] = parent * local;
    }
    if (!left) return;
    for (Eigen::Affine3d& frame : out) frame = root * mirrored(frame);
    // Mirrored, a turn by +e about axis a becomes a turn by +e about -S a (S = diag(-1, 1, 1)).
    if (axes)
      for (Eigen::Vector3d& a : *axes) a = root.linear() * Eigen::Vector3d(a.x(), -a.y(), -a.z());
  }

  HandModel model_;
  Handedness side_ = Handedness::Right;
  Eigen::Affine3d identity_ = Eigen::Affine3d::Identity();
  std::array<int, kPhalanxCount> flexion_{};    // DoF index rotating phalanx p about X, or -1
  std::array<int, kPhalanxCount> abduction_{};  // ... about Z
  std::array<int, kPhalanxCount> twist_{};      // ... about Y
};

}  // namespace glovepose::hand
