/// @file pinch_rule.hpp
/// @brief The pinch rule's distances, its hysteresis step and strength (pinch.hpp explains the
/// numbers), apart from the geometry so that a unit configuring an estimator needs no Eigen.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <string>

#include "../config.hpp"
#include "dofs.hpp"

namespace glovepose::hand {

/// @brief Thumb-tip-to-fingertip distance (mm) below which a pinch starts (see the file comment).
inline constexpr double kPinchThresholdMm = 15.0;
/// @brief Distance (mm) beyond which a pinch that is on ends (hysteresis against chatter).
inline constexpr double kPinchReleaseMm = 18.0;
/// @brief Distance (mm) at and beyond which the pinch strength is 0 (see the file comment).
inline constexpr double kPinchFarMm = 40.0;
/// @brief Number of pinch pairs: the thumb with index, middle, ring and pinky.
inline constexpr std::size_t kPinchPairCount = kFingerCount - 1;

/// @brief A distance (mm) per pair, thumb with index, middle, ring, pinky.
using PinchDistances = std::array<double, kPinchPairCount>;
/// @brief A flag per pair, same order.
using PinchFlags = std::array<bool, kPinchPairCount>;

/// @brief The pinch rule's distances. Defaults: kPinchThresholdMm, kPinchReleaseMm, kPinchFarMm.
struct PinchRule {
  double threshold_mm = kPinchThresholdMm;  ///< A pinch starts below this distance; strength 1 at or below it.
  double release_mm = kPinchReleaseMm;      ///< ... and ends beyond this one (>= threshold_mm).
  double far_mm = kPinchFarMm;              ///< Strength 0 at or beyond this distance (> threshold_mm).

  /// @brief Throws glovepose::Error naming the first distance out of range.
  void validate() const {
    if (!(threshold_mm > 0.0 && std::isfinite(threshold_mm)))
      throw Error("PinchRule: threshold_mm is " + std::to_string(threshold_mm) + ", expected a positive distance (mm)");
    if (!(release_mm >= threshold_mm && std::isfinite(release_mm)))
      throw Error("PinchRule: release_mm is " + std::to_string(release_mm) + ", expected a distance (mm) at least threshold_mm (" +
                  std::to_string(threshold_mm) + ")");
    if (!(far_mm > threshold_mm && std::isfinite(far_mm)))
      throw Error("PinchRule: far_mm is " + std::to_string(far_mm) + ", expected a distance (mm) beyond threshold_mm (" +
                  std::to_string(threshold_mm) + ")");
  }
};

/// @brief The hysteresis step: whether a pair pinches now, given whether it pinched at the previous
/// frame and its distance now (mm). On when closer than the threshold; once on, while closer than
/// the release (off at 18.0 mm exactly). A non-finite distance is no pinch.
GLOVEPOSE_REALTIME constexpr bool pinch_next(bool was_on, double distance_mm, const PinchRule& rule) noexcept {
  return distance_mm < (was_on ? rule.release_mm : rule.threshold_mm);  // false for NaN
}

/// @brief Pinch strength in [0, 1] of a distance (mm): 1 at or below rule.threshold_mm, 0 at or
/// beyond rule.far_mm (and for a non-finite distance), the smoothstep 3u^2 - 2u^3 of
/// u = (far - d) / (far - threshold) in between. See the file comment for why.
GLOVEPOSE_REALTIME inline double pinch_strength(double distance_mm, const PinchRule& rule = {}) noexcept {
  if (!std::isfinite(distance_mm) || distance_mm >= rule.far_mm) return 0.0;
  if (distance_mm <= rule.threshold_mm) return 1.0;
  const double u = (rule.far_mm - distance_mm) / (rule.far_mm - rule.threshold_mm);
  return u * u * (3.0 - 2.0 * u);
}

}  // namespace glovepose::hand
