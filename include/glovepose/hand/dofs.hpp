/// @file dofs.hpp
/// @brief The 25 finger degrees of freedom the glove estimates, their names, joint limits and the
/// normalisation of angles to [-1, 1].
///
/// Source: the hand model of Tkach et al. 2017 ("Online Generative Model Personalization for Hand
/// Tracking"), public repository anastasia-tkach/honline-cpp-public, tracker/HModel/ModelSemantics.cpp.
/// The glove estimates theta[9..33] of the model's
/// 34 pose parameters; theta[0..8] (global pose, wrist) cannot be sensed by stretch sensors.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <string>

#include "../config.hpp"

namespace glovepose::hand {

/// @brief Number of finger DoFs the glove estimates (theta 9..33 of the reference hand model).
inline constexpr std::size_t kDofCount = 25;
/// @brief Index in the reference model's 34-parameter vector of our DoF 0.
inline constexpr int kFirstTheta = 9;

/// @brief The five digits, in the order of the paper's pose map rows.
enum class Finger : unsigned char { Thumb = 0, Index, Middle, Ring, Pinky };
/// @brief Number of digits.
inline constexpr std::size_t kFingerCount = 5;
/// @brief Lower-case name of a digit, e.g. "index".
constexpr const char* to_string(Finger finger) noexcept {
  constexpr const char* names[kFingerCount] = {"thumb", "index", "middle", "ring", "pinky"};
  return name_of(finger, names, "unknown digit");
}

/// @brief The local axis a DoF rotates about (reference model: X flexion, Z abduction, Y twist).
enum class Axis : unsigned char { X, Y, Z };

/// @brief What a DoF does; also the column of the DoF in the paper's 5x5 pose map.
enum class Motion : unsigned char { Abduction = 0, BaseFlexion, MiddleFlexion, TipFlexion, Twist };

/// @brief One degree of freedom of the reference hand model.
struct Dof {
  const char* name;  ///< Stable snake_case name, e.g. "index_base_flexion".
  int theta;         ///< Index in the reference model's theta[0..33].
  Finger finger;     ///< Digit the DoF belongs to.
  Motion motion;     ///< What it does (and its pose-map column).
  int phalanx;       ///< Reference-model phalanx id the rotation is applied to (see kinematics.hpp).
  Axis axis;         ///< Local rotation axis.
  double min;        ///< Lower joint limit, radians.
  double max;        ///< Upper joint limit, radians.
};

/// @brief The 25 DoFs in the reference order theta 9..33, limits in radians.
///
/// Limits and phalanx ids: honline-cpp-public tracker/HModel/ModelSemantics.cpp. Phalanx ids: 1-3 thumb, 4-6 pinky,
/// 7-9 ring, 10-12 middle, 13-15 index (base, middle, tip).
inline constexpr std::array<Dof, kDofCount> kDofs{{
    {"thumb_base_abduction", 9, Finger::Thumb, Motion::Abduction, 1, Axis::Z, -0.1, 1.0},
    {"thumb_base_flexion", 10, Finger::Thumb, Motion::BaseFlexion, 1, Axis::X, -0.5, 1.0},
    {"thumb_middle_flexion", 11, Finger::Thumb, Motion::MiddleFlexion, 2, Axis::X, -0.9, 0.9},
    {"thumb_tip_flexion", 12, Finger::Thumb, Motion::TipFlexion, 3, Axis::X, -1.4, 0.7},
    {"index_base_abduction", 13, Finger::Index, Motion::Abduction, 13, Axis::Z, -0.30, 0.35},
    {"index_base_flexion", 14, Finger::Index, Motion::BaseFlexion, 13, Axis::X, -1.3, 1.6},
    {"index_middle_flexion", 15, Finger::Index, Motion::MiddleFlexion, 14, Axis::X, -0.1, 2.0},
    {"index_tip_flexion", 16, Finger::Index, Motion::TipFlexion, 15, Axis::X, -0.1, 2.0},
    {"middle_base_abduction", 17, Finger::Middle, Motion::Abduction, 10, Axis::Z, -0.30, 0.40},
    {"middle_base_flexion", 18, Finger::Middle, Motion::BaseFlexion, 10, Axis::X, -1.3, 1.6},
    {"middle_middle_flexion", 19, Finger::Middle, Motion::MiddleFlexion, 11, Axis::X, -0.1, 2.0},
    {"middle_tip_flexion", 20, Finger::Middle, Motion::TipFlexion, 12, Axis::X, -0.1, 2.0},
    {"ring_base_abduction", 21, Finger::Ring, Motion::Abduction, 7, Axis::Z, -0.10, 0.30},
    {"ring_base_flexion", 22, Finger::Ring, Motion::BaseFlexion, 7, Axis::X, -1.3, 1.6},
    {"ring_middle_flexion", 23, Finger::Ring, Motion::MiddleFlexion, 8, Axis::X, -0.1, 2.0},
    {"ring_tip_flexion", 24, Finger::Ring, Motion::TipFlexion, 9, Axis::X, -0.1, 2.0},
    {"pinky_base_abduction", 25, Finger::Pinky, Motion::Abduction, 4, Axis::Z, -0.20, 0.65},
    {"pinky_base_flexion", 26, Finger::Pinky, Motion::BaseFlexion, 4, Axis::X, -1.3, 1.6},
    {"pinky_middle_flexion", 27, Finger::Pinky, Motion::MiddleFlexion, 5, Axis::X, -0.1, 2.0},
    {"pinky_tip_flexion", 28, Finger::Pinky, Motion::TipFlexion, 6, Axis::X, -0.1, 2.0},
    {"thumb_base_twist", 29, Finger::Thumb, Motion::Twist, 1, Axis::Y, -0.40, 0.40},
    {"index_base_twist", 30, Finger::Index, Motion::Twist, 13, Axis::Y, -0.45, 0.05},
    {"middle_base_twist", 31, Finger::Middle, Motion::Twist, 10, Axis::Y, -0.15, 0.05},
    {"ring_base_twist", 32, Finger::Ring, Motion::Twist, 7, Axis::Y, -0.10, 0.05},
    {"pinky_base_twist", 33, Finger::Pinky, Motion::Twist, 4, Axis::Y, -0.10, 0.05},
}};

/// @brief Position in kDofs of each (finger, motion) pair: the pose map is finger x motion, so every
/// pair names exactly one DoF.
inline constexpr std::array<std::array<std::size_t, kFingerCount>, kFingerCount> kDofIndex = [] {
  std::array<std::array<std::size_t, kFingerCount>, kFingerCount> index{};
  for (std::size_t i = 0; i < kDofCount; ++i)
    index[static_cast<std::size_t>(kDofs[i].finger)][static_cast<std::size_t>(kDofs[i].motion)] = i;
  return index;
}();

/// @brief Position in kDofs of the DoF of `finger` doing `motion`.
constexpr std::size_t dof_of(Finger finger, Motion motion) noexcept {
  return kDofIndex[static_cast<std::size_t>(finger)][static_cast<std::size_t>(motion)];
}

/// @brief 25 joint angles in radians, in the order of kDofs.
using Angles = std::array<double, kDofCount>;

/// @brief Position of a DoF in kDofs from its reference-model theta index; throws for 0..8 or > 33.
inline std::size_t dof_from_theta(int theta) {
  if (theta < kFirstTheta || theta >= kFirstTheta + static_cast<int>(kDofCount))
    throw Error("dof_from_theta: theta " + std::to_string(theta) + " is not a finger DoF, expected 9..33");
  return static_cast<std::size_t>(theta - kFirstTheta);
}

/// @brief Position of a DoF in kDofs from its name; throws glovepose::Error for an unknown name.
inline std::size_t dof_from_name(const std::string& name) {
  for (std::size_t i = 0; i < kDofCount; ++i)
    if (name == kDofs[i].name) return i;
  throw Error("dof_from_name: unknown DoF '" + name + "', expected a name such as 'index_base_flexion'");
}

/// @brief A set of DoFs, one flag per entry of kDofs: e.g. those a dataset labels (the others have
/// no reference angle, are not trained and not scored).
using DofSet = std::array<bool, kDofCount>;

/// @brief Every DoF.
inline DofSet all_dofs() noexcept {
  DofSet all{};
  all.fill(true);
  return all;
}

/// @brief The set as text: its DoF names in kDofs order, comma-separated.
inline std::string dof_set_text(const DofSet& set) {
  std::string text;
  for (std::size_t d = 0; d < kDofCount; ++d)
    if (set[d]) text += (text.empty() ? "" : ",") + std::string(kDofs[d].name);
  return text;
}

/// @brief The set named by comma-separated DoF names (dof_set_text()). Throws glovepose::Error,
/// starting with `what`, for an unknown or repeated name or an empty list.
inline DofSet parse_dof_set(const std::string& text, const std::string& what) {
  DofSet set{};
  bool any = false;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string name = text.substr(start, comma - start);
    std::size_t d = 0;
    while (d < kDofCount && name != kDofs[d].name) ++d;
    if (d == kDofCount) throw Error(what + ": '" + name + "' is not a DoF, expected comma-separated names such as 'index_base_flexion'");
    if (set[d]) throw Error(what + ": '" + name + "' is listed twice, expected each DoF once");
    set[d] = any = true;
    start = comma + 1;
  }
  if (!any) throw Error(what + ": no DoF, expected at least one name");
  return set;
}

/// @brief Lower and upper limit of each DoF, used to map angles to [-1, 1] and back.
///
/// The default is the reference model's limits. A model file records the limits it was trained with
/// (they define what its [-1, 1] outputs mean), so a model can carry other limits than these.
class JointLimits {
 public:
  /// @brief The reference model's limits (kDofs).
  JointLimits() noexcept {
    for (std::size_t i = 0; i < kDofCount; ++i) {
      min_[i] = kDofs[i].min;
      max_[i] = kDofs[i].max;
    }
  }

  /// @brief Custom limits; throws glovepose::Error naming the DoF when a limit is not finite,
  /// min >= max, or max - min overflows (denormalize() would then give infinite or NaN angles).
  JointLimits(const Angles& min, const Angles& max) : min_(min), max_(max) {
    for (std::size_t i = 0; i < kDofCount; ++i) {
      if (!std::isfinite(min_[i]) || !std::isfinite(max_[i]) || !(min_[i] < max_[i]) || !std::isfinite(max_[i] - min_[i]))
        throw Error(std::string("JointLimits: DoF ") + kDofs[i].name + " has limits [" + std::to_string(min_[i]) + ", " +
                    std::to_string(max_[i]) + "], expected finite values with min < max and a finite range max - min");
    }
  }

  /// @brief Lower limits, radians.
  const Angles& min() const noexcept { return min_; }
  /// @brief Upper limits, radians.
  const Angles& max() const noexcept { return max_; }

  /// @brief Maps angles (radians) linearly to [-1, 1]: min -> -1, max -> +1. Values outside the
  /// limits map outside [-1, 1]; nothing is clamped.
  GLOVEPOSE_REALTIME Angles normalize(const Angles& angles) const noexcept {
    Angles out{};
    for (std::size_t i = 0; i < kDofCount; ++i) out[i] = 2.0 * (angles[i] - min_[i]) / (max_[i] - min_[i]) - 1.0;
    return out;
  }

  /// @brief Inverse of normalize(): [-1, 1] back to radians.
  GLOVEPOSE_REALTIME Angles denormalize(const Angles& normalized) const noexcept {
    Angles out{};
    for (std::size_t i = 0; i < kDofCount; ++i) out[i] = min_[i] + 0.5 * (normalized[i] + 1.0) * (max_[i] - min_[i]);
    return out;
  }

  /// @brief The rest pose within the limits: every angle 0 rad, clamped into [min, max]. What a DoF
  /// without reference angles is trained to, and reads, in a model (DofSet).
  Angles rest() const noexcept { return clamp(Angles{}); }

  /// @brief `normalized` outputs with every DoF outside `labelled` replaced by the rest pose (in
  /// normalised units): what a model reads for a DoF it had no reference angles for.
  GLOVEPOSE_REALTIME Angles rest_unlabelled(const Angles& normalized, const DofSet& labelled) const noexcept {
    Angles out = normalized;
    const Angles rest_normalized = normalize(rest());
    for (std::size_t i = 0; i < kDofCount; ++i)
      if (!labelled[i]) out[i] = rest_normalized[i];
    return out;
  }

  /// @brief Clamps angles into the limits (e.g. for a simulator's pose generator).
  GLOVEPOSE_REALTIME Angles clamp(const Angles& angles) const noexcept {
    Angles out{};
    for (std::size_t i = 0; i < kDofCount; ++i) out[i] = angles[i] < min_[i] ? min_[i] : (angles[i] > max_[i] ? max_[i] : angles[i]);
    return out;
  }

 private:
  Angles min_{};
  Angles max_{};
};

}  // namespace glovepose::hand
