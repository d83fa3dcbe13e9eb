/// @file floating_cells.hpp
/// @brief Cells that stopped being measured, found and stood in for: a torn trace leaves the cells
/// beyond the break connected to nothing (they float), and every solve then reads them as about
/// 0 pF while the other cells stay right (the readout is overdetermined: 180 rows for 44 cells).
///
/// A connected cell never reads below a quarter of the least it read in the calibration (its
/// relaxed capacitance); a floating one reads about 0. Such a cell is replaced at once by its
/// conditional mean given the connected cells, x_f = mu_f + C_fo (C_oo + ridge)^-1 (x_o - mu_o),
/// from a running mean and covariance of the cells over the recent intact frames (forgetting over
/// FloatingCellsConfig::memory_seconds), or by the middle of its calibrated range before min_seconds
/// of them were seen. It rejoins after reading above the bound for hold_seconds. Measured on the
/// shipped model (docs/results.md, "A torn trace"): a regression from the connected cells costs 2%
/// over the intact glove, the middle of the range 9%, the cells as solved 48%.
///
/// Set-up (construction) allocates; set_range(), reset() and apply() are per-frame: noexcept and
/// allocation-free (the regression is re-solved in preallocated storage when the set changes).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "../config.hpp"
#include "calibration.hpp"
#include "floating_cells_config.hpp"

namespace glovepose::sensor {

/// @brief Finds floating cells and stands in for them (see the file's description).
class FloatingCells {
 public:
  FloatingCells() = default;
  /// @brief A stand-in for `cells` cells. Throws glovepose::Error for a bad setting.
  FloatingCells(Eigen::Index cells, FloatingCellsConfig config) : config_(config) {
    if (cells < 1 || !(config_.below_share > 0.0 && config_.below_share < 1.0) || !(config_.hold_seconds >= 0.0) ||
        !std::isfinite(config_.hold_seconds) || !(config_.confirm_seconds >= 0.0) || !std::isfinite(config_.confirm_seconds) ||
        !(config_.memory_seconds > 0.0) || !(config_.min_seconds >= 0.0) || !(config_.ridge > 0.0) || !std::isfinite(config_.ridge))
      throw Error("FloatingCells: cells " + std::to_string(cells) + ", below_share " + std::to_string(config_.below_share) +
                  ", hold_seconds " + std::to_string(config_.hold_seconds) + ", confirm_seconds " + std::to_string(config_.confirm_seconds) +
                  ", memory_seconds " + std::to_string(config_.memory_seconds) + ", min_seconds " + std::to_string(config_.min_seconds) +
                  ", ridge " + std::to_string(config_.ridge) +
                  ", expected at least 1 cell, 0 < below_share < 1, hold_seconds >= 0, confirm_seconds >= 0, memory_seconds > 0, "
                  "min_seconds >= 0, ridge > 0");
    const auto n = static_cast<std::size_t>(cells);
    bound_ = Eigen::VectorXd::Constant(cells, -kInfinity);  // no range yet: nothing floats, the statistics learn
    middle_ = Eigen::VectorXd::Zero(cells);
    mean_ = Eigen::VectorXd::Zero(cells);
    covariance_ = Eigen::MatrixXd::Zero(cells, cells);
    system_ = Eigen::MatrixXd::Zero(cells, cells);
    targets_ = Eigen::MatrixXd::Zero(cells, cells);
    weights_ = Eigen::MatrixXd::Zero(cells, cells);
    deviation_ = Eigen::VectorXd::Zero(cells);
    factor_ = Eigen::LDLT<Eigen::MatrixXd>(cells);
    floating_.assign(n, 0);
    above_since_.assign(n, kNever);
    below_since_.assign(n, kNever);
    list_.reserve(n);
    reset();
  }

  /// @brief The calibration the bound is taken from: a cell floats below below_share x its minimum
  /// (cells whose minimum is not positive, or that the calibration maps to 0, are never taken as
  /// floating). Forgets which cells float.
  GLOVEPOSE_REALTIME void set_range(const CalibrationRange& range) noexcept {
    if (range.size() != bound_.size()) return;
    follow_range(range);
    clear_floating();
  }

  /// @brief Follows a range that moved (a continuous calibration's): the bounds move, the cells
  /// that float go on floating.
  GLOVEPOSE_REALTIME void follow_range(const CalibrationRange& range) noexcept {
    if (range.size() != bound_.size()) return;
    for (Eigen::Index c = 0; c < bound_.size(); ++c) {
      const double low = range.min()(c);
      bound_(c) = low > 0.0 && !range.is_flat(static_cast<int>(c)) ? config_.below_share * low : -kInfinity;
      middle_(c) = 0.5 * (low + range.max()(c));
    }
  }

  /// @brief Forgets which cells float (a new stream); the statistics stay.
  GLOVEPOSE_REALTIME void reset() noexcept {
    clear_floating();
    last_time_ = -kInfinity;
  }

  /// @brief One frame of cells (solved capacitances) at `timestamp` (s): floating cells replaced in
  /// place; an intact frame updates the statistics. Returns the number of cells stood in for.
  /// `consistent` says the solve fitted every row (no outlier rows); the statistics learn only from
  /// such frames. A row spike drags the cells it touches below the bound while it stays in its
  /// row's mean, and the solve flags that row: a cell below the bound starts floating at once on a
  /// consistent frame (a torn trace's cells stay low once its rows are all read after the tear),
  /// otherwise after reading so for confirm_seconds. Cells given without a readout's judgement
  /// (pushed cells) are taken as consistent.
  GLOVEPOSE_REALTIME int apply(Eigen::VectorXd& cells, double timestamp, bool consistent = true) noexcept {
    if (!config_.enabled || cells.size() != bound_.size() || !cells.allFinite()) return 0;
    bool changed = false;
    for (Eigen::Index c = 0; c < cells.size(); ++c) {
      const auto i = static_cast<std::size_t>(c);
      if (cells(c) < bound_(c)) {
        above_since_[i] = kNever;
        if (below_since_[i] == kNever) below_since_[i] = timestamp;
        if (!floating_[i] && (consistent || timestamp - below_since_[i] >= config_.confirm_seconds)) floating_[i] = 1, changed = true;
        continue;
      }
      below_since_[i] = kNever;
      if (floating_[i]) {
        if (above_since_[i] == kNever) above_since_[i] = timestamp;
        if (timestamp - above_since_[i] >= config_.hold_seconds) floating_[i] = 0, above_since_[i] = kNever, changed = true;
      }
    }
    if (changed) refresh();
    const double dt = std::isfinite(last_time_) ? std::clamp(timestamp - last_time_, 0.0, 1.0) : 0.0;
    last_time_ = timestamp;
    if (list_.empty()) {
      if (consistent) {
        seconds_ += dt;
        learn(cells, dt);
      }
      return 0;
    }
    if (!regressed_) {
      for (int c : list_) cells(c) = middle_(c);
      return static_cast<int>(list_.size());
    }
    deviation_ = cells - mean_;
    for (int c : list_) deviation_(c) = 0.0;
    for (int c : list_) cells(c) = mean_(c) + weights_.col(c).dot(deviation_);
    return static_cast<int>(list_.size());
  }

  /// @brief The cells stood in for in the latest frame, in index order.
  const std::vector<int>& floating() const noexcept { return list_; }
  /// @brief Frames and stream time the statistics have seen.
  long frames_seen() const noexcept { return frames_; }
  double seconds_seen() const noexcept { return seconds_; }
  /// @brief The running mean and covariance of the intact frames.
  const Eigen::VectorXd& mean() const noexcept { return mean_; }
  const Eigen::MatrixXd& covariance() const noexcept { return covariance_; }
  /// @brief The settings in use.
  const FloatingCellsConfig& config() const noexcept { return config_; }

 private:
  static constexpr double kInfinity = std::numeric_limits<double>::infinity();
  static constexpr double kNever = -std::numeric_limits<double>::infinity();

  void clear_floating() noexcept {
    std::fill(floating_.begin(), floating_.end(), 0);
    std::fill(above_since_.begin(), above_since_.end(), kNever);
    std::fill(below_since_.begin(), below_since_.end(), kNever);
    list_.clear();
    regressed_ = false;
  }

  // Exponentially weighted mean and covariance (West 1979): weight 1/n while fewer frames than the
  // memory holds, then dt / memory_seconds.
  void learn(const Eigen::VectorXd& cells, double dt) noexcept {
    ++frames_;
    const double a = std::max(1.0 / static_cast<double>(frames_), dt / config_.memory_seconds);
    deviation_ = cells - mean_;
    mean_ += a * deviation_;
    for (Eigen::Index j = 0; j < covariance_.cols(); ++j)
      for (Eigen::Index i = j; i < covariance_.rows(); ++i) covariance_(i, j) = (1.0 - a) * (covariance_(i, j) + a * deviation_(i) * deviation_(j));
  }

  // The floating list and, with enough statistics, the regression of each floating cell on the
  // connected ones: (C_oo + ridge I) W = C_of, floating rows and columns of the system made identity.
  void refresh() noexcept {
    list_.clear();
    for (std::size_t i = 0; i < floating_.size(); ++i)
      if (floating_[i]) list_.push_back(static_cast<int>(i));
    regressed_ = false;
    const Eigen::Index connected = bound_.size() - static_cast<Eigen::Index>(list_.size());
    if (list_.empty() || seconds_ < config_.min_seconds || frames_ < 2 || connected == 0) return;
    double variance = 0.0;
    for (Eigen::Index c = 0; c < bound_.size(); ++c) variance += floating_[static_cast<std::size_t>(c)] ? 0.0 : covariance_(c, c);
    const double ridge = config_.ridge * variance / static_cast<double>(connected) + std::numeric_limits<double>::min();
    system_ = covariance_.selfadjointView<Eigen::Lower>();
    targets_.setZero();
    for (int f : list_) {
      targets_.col(f) = system_.col(f);
      system_.row(f).setZero();
      system_.col(f).setZero();
    }
    for (int f : list_) targets_.row(f).setZero();
    system_.diagonal().array() += ridge;
    for (int f : list_) system_(f, f) = 1.0;
    factor_.compute(system_);
    if (factor_.info() != Eigen::Success) return;
    regressed_ = true;
    for (int f : list_) {  // only the floating cells' columns: the others are never read
      weights_.col(f) = factor_.solve(targets_.col(f));
      regressed_ = regressed_ && weights_.col(f).allFinite();
    }
  }

  FloatingCellsConfig config_;
  Eigen::VectorXd bound_;        // below this a cell floats (-inf: never)
  Eigen::VectorXd middle_;       // the middle of each cell's calibrated range
  Eigen::VectorXd mean_;         // running mean of the intact frames
  Eigen::MatrixXd covariance_;   // their running covariance (lower triangle)
  Eigen::MatrixXd system_;       // C_oo + ridge, floating rows and columns identity
  Eigen::MatrixXd targets_;      // C_of in the floating columns
  Eigen::MatrixXd weights_;      // the regression: column f gives floating cell f from the deviations
  Eigen::VectorXd deviation_;    // scratch
  Eigen::LDLT<Eigen::MatrixXd> factor_;
  std::vector<unsigned char> floating_;  // per cell
  std::vector<double> above_since_;      // per floating cell: since when it reads above the bound
  std::vector<double> below_since_;      // per cell: since when it reads below the bound
  std::vector<int> list_;                // the floating cells, in index order
  bool regressed_ = false;
  long frames_ = 0;
  double seconds_ = 0.0;
  double last_time_ = -std::numeric_limits<double>::infinity();
};

}  // namespace glovepose::sensor
