/// @file contact_config.hpp
/// @brief The contact stage's settings (contact.hpp), apart from the stage so that a unit
/// configuring an estimator needs no Eigen.
#pragma once

#include <cmath>
#include <string>

#include "../config.hpp"
#include "collision_threshold.hpp"
#include "pinch_rule.hpp"

namespace glovepose::hand {

/// @brief Settings of the contact stage. Defaults: the pinch rule's 15 / 18 mm.
struct ContactConfig {
  PinchRule detection{};      ///< In contact below threshold_mm, until beyond release_mm (far_mm unused).
  double apart_mm = kPinchReleaseMm;  ///< Pairs not in contact are not brought closer than this by the adjustment (mm).
  double change_weight = 1.0;         ///< Pull toward the estimated angles, mm^2 of residual per rad^2.
  int max_iterations = 10;            ///< Damped least squares iterations at most.
  double step_tolerance = 1e-4;       ///< Stop when no angle moves more than this (rad).
  double max_collision = kCollisionOutlierThreshold;  ///< Collision energy (mm^2) the adjusted pose may reach (or the estimate's, if higher).

  /// @brief Throws glovepose::Error naming the first setting out of range.
  void validate() const {
    detection.validate();
    if (!(apart_mm >= 0.0 && std::isfinite(apart_mm)))
      throw Error("ContactConfig: apart_mm is " + std::to_string(apart_mm) + ", expected a distance (mm) of 0 or more");
    if (!(change_weight > 0.0 && std::isfinite(change_weight)))
      throw Error("ContactConfig: change_weight is " + std::to_string(change_weight) + ", expected a positive weight");
    if (max_iterations < 1 || max_iterations > 1000)
      throw Error("ContactConfig: max_iterations is " + std::to_string(max_iterations) + ", expected 1..1000");
    if (!(step_tolerance > 0.0 && std::isfinite(step_tolerance)))
      throw Error("ContactConfig: step_tolerance is " + std::to_string(step_tolerance) + ", expected a positive angle (rad)");
    if (!(max_collision >= 0.0 && std::isfinite(max_collision)))
      throw Error("ContactConfig: max_collision is " + std::to_string(max_collision) + ", expected 0 or more (mm^2)");
  }
};

}  // namespace glovepose::hand
