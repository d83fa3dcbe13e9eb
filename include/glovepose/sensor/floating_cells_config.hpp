/// @file floating_cells_config.hpp
/// @brief The floating-cell stand-in's settings (floating_cells.hpp), apart from it so that a unit
/// configuring an estimator needs no Eigen.
#pragma once

namespace glovepose::sensor {

/// @brief Settings of the floating-cell stand-in (EstimatorConfig::floating_cells).
struct FloatingCellsConfig {
  bool enabled = true;          ///< Off: cells are passed on as solved, torn or not.
  double below_share = 0.25;    ///< A cell reading below this share of its calibrated minimum floats.
  double hold_seconds = 0.5;    ///< A floating cell rejoins after reading above the bound this long.
  /// A cell below the bound on frames the solve did not fit (outlier rows) floats once it has read
  /// so this long: longer than a row spike stays in its row's mean (5 cycles, 83 ms at 60 Hz), so
  /// that a glove with a row that never fits again still gets its torn cells stood in for.
  double confirm_seconds = 0.25;
  double memory_seconds = 120;  ///< Time over which the running statistics forget (exponential weights).
  double min_seconds = 2.0;     ///< Stream time of statistics before the regression is used (before: mid-range).
  double ridge = 1e-3;          ///< Ridge of the regression, relative to the connected cells' mean variance.
};

}  // namespace glovepose::sensor
