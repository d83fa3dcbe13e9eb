/// @file collision_threshold.hpp
/// @brief The paper's outlier threshold on the collision energy (collision.hpp computes the energy),
/// apart from the geometry: the contact stage's settings name it.
#pragma once

namespace glovepose::hand {

/// @brief The paper's outlier threshold on the collision energy (mm^2).
inline constexpr double kCollisionOutlierThreshold = 80.0;

}  // namespace glovepose::hand
