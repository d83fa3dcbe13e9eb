/// @file handedness.hpp
/// @brief Which hand a glove is on, and the mirror that turns a right hand's geometry into a left's.
///
/// A left hand is the mirror image of a right hand through the plane that contains the fingers'
/// length and the back-of-hand direction: in the hand model's root frame (and in the OpenXR wrist
/// frame) that is x -> -x. A frame mirrored that way and kept right-handed is S R S with
/// S = diag(-1, 1, 1): its bone (y) and back-of-finger (z) directions are mirrored, its x axis
/// follows from them. The 25 angles keep their anatomical meaning on both hands (flexion closes the
/// finger, abduction spreads it from the middle finger), so one set of angles poses either hand.
#pragma once

#include <cstdint>

#include <Eigen/Geometry>

#include "../config.hpp"

namespace glovepose::hand {

/// @brief The hand a glove is worn on.
enum class Handedness : std::uint8_t {
  Right = 0,  ///< The reference hand model's side.
  Left = 1,   ///< Its mirror image (x -> -x in the root frame).
};

/// @brief Stable name of a side: "right" or "left".
constexpr const char* to_string(Handedness side) noexcept { return side == Handedness::Left ? "left" : "right"; }

/// @brief The mirror image of a rigid transform through the x = 0 plane, kept right-handed:
/// S T S with S = diag(-1, 1, 1) (translation x negated; rotation rows and columns 0 negated).
GLOVEPOSE_REALTIME inline Eigen::Affine3d mirrored(const Eigen::Affine3d& transform) noexcept {
  Eigen::Affine3d out = transform;
  out.linear().row(0) *= -1.0;
  out.linear().col(0) *= -1.0;
  out.translation().x() = -out.translation().x();
  return out;
}

}  // namespace glovepose::hand
