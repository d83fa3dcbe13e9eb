/// @file calibration_config.hpp
/// @brief The calibrations' shared settings and their flat and noise-only rules (calibration.hpp),
/// apart from the calibration so that a unit configuring an estimator needs no Eigen.
#pragma once

#include <algorithm>
#include <cmath>

namespace glovepose::sensor {

/// @brief Settings shared by the calibrations.
struct CalibrationConfig {
  /// A sensor whose max - min is below this fraction of max(|min|, |max|) is "flat": too small a
  /// range to normalise by (its readings would be mostly noise scaled up). 1% is far above the
  /// readout noise of the paper's sensors and far below the stretch of any cell that moves
  /// (capacitance ~ area^2, eq. 1: 5% stretch is 10% capacitance).
  double min_relative_range = 0.01;
  /// Normalised values are clamped to [-clamp_limit, clamp_limit] so a glitch cannot drive the
  /// network arbitrarily far from its training range; readings beyond the calibrated range still
  /// pass through up to this bound (a fit seldom covers every extreme).
  double clamp_limit = 1.5;
  /// A sensor whose range is below this many times the SD of its noise is "noise only": a dead
  /// channel whose readings wander by noise alone, which min-max would stretch to full scale. The
  /// noise is the high-frequency residual of its readings in the same calibration
  /// (NoiseEstimator), as much of it as reaches the range (on the fly: after the running median,
  /// median_noise_factor()). White noise alone spans about 5 such SDs; of 20,000 simulated
  /// calibrations of a dead channel (150 frames at 10 Hz, a 3-frame median) 0.01% reached 12 with
  /// Gaussian noise, 0.14% with Laplace noise. The weakest cell calibration of simulated corpora
  /// reaches 39.8 (fitted world, 6600 cell calibrations at 60 Hz), 113 (clean world, 264) and 119
  /// (the README's 20-sensor example glove at 20 Hz, 80). 0: off.
  double min_range_to_noise = 12.0;
};

/// @brief Whether a sensor whose readings spanned [min, max] is "flat" under `config`: its range is
/// not above config.min_relative_range x max(|min|, |max|), or is not positive. A calibration maps a
/// flat sensor to 0; an import refuses a calibration take where one is flat.
inline bool is_flat_range(double min, double max, const CalibrationConfig& config) noexcept {
  const double scale = std::max(std::abs(min), std::abs(max));
  return max - min <= config.min_relative_range * scale || max - min <= 0.0;
}

/// @brief Whether a sensor whose readings spanned [min, max] with noise SD `noise` (0: unknown) is
/// "noise only" under `config`: its range is below config.min_range_to_noise x noise.
inline bool is_noise_only(double min, double max, double noise, const CalibrationConfig& config) noexcept {
  return noise > 0.0 && max - min < config.min_range_to_noise * noise;
}

}  // namespace glovepose::sensor
