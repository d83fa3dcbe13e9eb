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

#include "../config.hpp"

namespace glovepose::hand {

/// @brief The hand a glove is worn on.
enum class Handedness : std::uint8_t {
  Right = 0,  ///< The reference hand model's side.
  Left = 1,   ///< Its mirror image (x -> -x in the root frame).
};

/// @brief Stable name of a side: "right" or "left".
constexpr const char* to_string(Handedness side) noexcept { return side == Handedness::Left ? "left" : "right"; }

}  // namespace glovepose::hand
