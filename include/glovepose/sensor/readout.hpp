/// @file readout.hpp
/// @brief The streaming front end: measurement rows arrive one at a time (or as whole frames), are
/// mean-filtered per row, and are solved into cell capacitances every few row updates.
///
/// The paper's scheme (Sec. 3.1): the micro-controller measures the 180 compound capacitances one
/// after another; the host keeps the latest values, mean-filters the last five frames of C_m and
/// solves for C_c every 16 row updates (about 60 Hz). The oldest reading in a solve is what limits
/// latency (the paper: 45-90 ms of its 125-200 ms), so every solved frame says how old it is.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../status.hpp"
#include "solver.hpp"

namespace glovepose::sensor {

/// @brief Settings of the streaming readout.
struct ReadoutConfig {
  int mean_window = 5;   ///< Readings per row averaged before solving (paper: last 5 frames).
  int solve_every = 16;  ///< Solve after this many accepted row updates (paper: 16).
};

/// @brief One solved frame of cell capacitances.
template <int Cells>
struct CapacitanceFrame {
  Eigen::Matrix<double, Cells, 1> cells;  ///< C_c, one value per cell.
  double timestamp = 0.0;                 ///< Timestamp of the newest reading that went into the solve.
  double oldest_age = 0.0;                ///< timestamp minus the timestamp of the oldest reading used.
  std::uint32_t rejected = 0;             ///< Readings rejected since the previous solve.
  std::uint64_t sequence = 0;             ///< Number of frames solved so far, this one included.
};

/// @brief Per-stream readout state: a ring of recent readings per measurement row.
///
/// The solver is shared (immutable); the rings are this stream's own and are allocated once, at
/// construction. All per-reading calls are noexcept and allocation-free.
template <int Rows = kGlauser2019Rows, int Cells = kGlauser2019Cells>
class Readout {
 public:
  /// @brief The solver type this readout feeds.
  using Solver = CapacitanceSolver<Rows, Cells>;
  /// @brief One frame of compound measurements.
  using Measurements = typename Solver::Measurements;
  /// @brief A solved frame.
  using Frame = CapacitanceFrame<Cells>;

  /// @brief A readout over a shared solver. Throws glovepose::Error for a null solver or a window
  /// or solve interval below 1.
  explicit Readout(std::shared_ptr<const Solver> solver, ReadoutConfig config = {})
      : solver_(std::move(solver)), config_(config) {
    if (!solver_) throw Error("Readout: no solver given, expected a CapacitanceSolver");
    if (config_.mean_window < 1)
      throw Error("Readout: mean_window " + std::to_string(config_.mean_window) + ", expected at least 1");
    if (config_.solve_every < 1)
      throw Error("Readout: solve_every " + std::to_string(config_.solve_every) + ", expected at least 1");
    rows_ = solver_->layout().row_count();
    const auto slots = static_cast<std::size_t>(rows_) * static_cast<std::size_t>(config_.mean_window);
    values_.assign(slots, 0.0);
    times_.assign(slots, 0.0);
    count_.assign(static_cast<std::size_t>(rows_), 0);
    head_.assign(static_cast<std::size_t>(rows_), 0);
    mean_ = Measurements::Zero(rows_);
    frame_.cells = Solver::Capacitances::Zero(solver_->layout().cell_count());
    reset();
  }

  /// @brief Forgets every reading (e.g. after the glove was unplugged or its clock restarted).
  void reset() noexcept {
    std::fill(count_.begin(), count_.end(), 0);
    std::fill(head_.begin(), head_.end(), 0);
    rows_seen_ = 0;
    updates_since_solve_ = 0;
    rejected_since_solve_ = 0;
    last_timestamp_ = -std::numeric_limits<double>::infinity();
  }

  /// @brief Offers one reading of measurement row `row` taken at `timestamp` (seconds).
  ///
  /// Rejected without changing any state: an unknown row (Status::UnknownIndex), a NaN or infinite
  /// value or timestamp (Status::NonFinite), a negative capacitance (Status::Negative), a timestamp
  /// before the last accepted one (Status::TimestampBackwards). Accepted readings return
  /// Status::Solved when they completed a solve (see frame()), Status::NotReady while some row has
  /// never been read, and Status::Ok otherwise.
  GLOVEPOSE_REALTIME Status push_row(int row, double value, double timestamp) noexcept {
    const Status check = validate(row, value, timestamp);
    if (check != Status::Ok) {
      ++rejected_since_solve_;
      return check;
    }
    store(row, value, timestamp);
    // Solves fall on every solve_every-th accepted reading counted from the start of the stream, so
    // with solve_every equal to the row count they coincide with the ends of full cycles.
    const bool due = ++updates_since_solve_ >= config_.solve_every;
    if (due) updates_since_solve_ = 0;
    if (rows_seen_ < rows_) return Status::NotReady;
    return due ? solve() : Status::Ok;
  }

  /// @brief Offers a whole frame of measurements taken at `timestamp` and solves once.
  ///
  /// A frame with a bad timestamp or size is rejected whole. Otherwise each row is validated on its
  /// own: bad rows are skipped (their previous readings stay in use) and counted in
  /// Frame::rejected. Returns Status::Solved, Status::NotReady (a row has never had a good reading),
  /// or the rejection status.
  GLOVEPOSE_REALTIME Status push_frame(const Measurements& measurements, double timestamp) noexcept {
    if (measurements.size() != rows_) return Status::SizeMismatch;
    if (!std::isfinite(timestamp)) return Status::NonFinite;
    if (timestamp < last_timestamp_) return Status::TimestampBackwards;
    for (int row = 0; row < rows_; ++row) {
      const double value = measurements(row);
      if (validate(row, value, timestamp) == Status::Ok)
        store(row, value, timestamp);
      else
        ++rejected_since_solve_;
    }
    if (rows_seen_ < rows_) return Status::NotReady;
    return solve();
  }

  /// @brief The latest solved frame (valid once a call returned Status::Solved).
  const Frame& frame() const noexcept { return frame_; }
  /// @brief The mean-filtered measurements that went into the latest solve.
  const Measurements& filtered_measurements() const noexcept { return mean_; }
  /// @brief The settings in use.
  const ReadoutConfig& config() const noexcept { return config_; }
  /// @brief The shared solver.
  const Solver& solver() const noexcept { return *solver_; }

 private:
  Status validate(int row, double value, double timestamp) const noexcept {
    if (row < 0 || row >= rows_) return Status::UnknownIndex;
    if (!std::isfinite(value) || !std::isfinite(timestamp)) return Status::NonFinite;
    if (value < 0.0) return Status::Negative;
    if (timestamp < last_timestamp_) return Status::TimestampBackwards;
    return Status::Ok;
  }

  void store(int row, double value, double timestamp) noexcept {
    const auto r = static_cast<std::size_t>(row);
    const auto window = static_cast<std::size_t>(config_.mean_window);
    const std::size_t slot = r * window + static_cast<std::size_t>(head_[r]);
    values_[slot] = value;
    times_[slot] = timestamp;
    head_[r] = (head_[r] + 1) % config_.mean_window;
    if (count_[r] == 0) ++rows_seen_;
    if (count_[r] < config_.mean_window) ++count_[r];
    last_timestamp_ = timestamp;
  }

  Status solve() noexcept {
    const auto window = static_cast<std::size_t>(config_.mean_window);
    double oldest = std::numeric_limits<double>::infinity();
    for (int row = 0; row < rows_; ++row) {
      const auto r = static_cast<std::size_t>(row);
      const auto n = static_cast<std::size_t>(count_[r]);
      double sum = 0.0;
      for (std::size_t k = 0; k < n; ++k) {
        sum += values_[r * window + k];
        oldest = std::min(oldest, times_[r * window + k]);
      }
      mean_(row) = sum / static_cast<double>(n);
    }
    const Status status = solver_->solve(mean_, frame_.cells);
    if (status != Status::Ok) return status;
    frame_.timestamp = last_timestamp_;
    frame_.oldest_age = last_timestamp_ - oldest;
    frame_.rejected = rejected_since_solve_;
    ++frame_.sequence;
    updates_since_solve_ = 0;  // a whole frame restarts the cadence too
    rejected_since_solve_ = 0;
    return Status::Solved;
  }

  std::shared_ptr<const Solver> solver_;
  ReadoutConfig config_;
  int rows_ = 0;
  std::vector<double> values_;  // rows x mean_window ring buffers, row-major
  std::vector<double> times_;   // timestamps of values_
  std::vector<int> count_;      // readings held per row (<= mean_window)
  std::vector<int> head_;       // next slot to write per row
  int rows_seen_ = 0;           // rows with at least one reading
  int updates_since_solve_ = 0;
  std::uint32_t rejected_since_solve_ = 0;
  double last_timestamp_ = 0.0;
  Measurements mean_;
  Frame frame_;
};

/// @brief The readout of the paper's glove.
using GloveReadout = Readout<kGlauser2019Rows, kGlauser2019Cells>;

}  // namespace glovepose::sensor
