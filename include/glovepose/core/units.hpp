/// @file units.hpp
/// @brief The unit conversions' one home: angles are radians inside glovepose, degrees where people
/// read or write them (files, reports, the tool).
#pragma once

namespace glovepose::core {

/// @brief pi.
inline constexpr double kPi = 3.14159265358979323846;
/// @brief Degrees per radian (180 / pi).
inline constexpr double kDegreesPerRadian = 57.295779513082320876798;
/// @brief Radians per degree (pi / 180).
inline constexpr double kRadiansPerDegree = kPi / 180.0;

}  // namespace glovepose::core
