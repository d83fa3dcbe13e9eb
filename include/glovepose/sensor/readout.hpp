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

#include <Eigen/Cholesky>

#include "../config.hpp"
#include "../status.hpp"
#include "readout_config.hpp"
#include "solver.hpp"

namespace glovepose::sensor {

/// @brief One solved frame of cell capacitances.
struct CapacitanceFrame {
  Eigen::VectorXd cells;       ///< C_c, one value per cell.
  double timestamp = 0.0;      ///< Timestamp of the newest reading that went into the solve.
  double oldest_age = 0.0;     ///< timestamp minus the timestamp of the oldest reading used.
  std::uint32_t rejected = 0;  ///< Readings rejected since the previous solve.
  std::uint64_t sequence = 0;  ///< Number of frames solved so far, this one included.
  ReadoutHealth health;        ///< What makes this frame less trustworthy.
};

/// @brief Per-stream readout state: a ring of recent readings per measurement row.
///
/// The solver is shared (immutable); the rings are this stream's own and are allocated once, at
/// construction. All per-reading calls are noexcept and allocation-free.
class Readout {
 public:
  /// @brief The solver type this readout feeds.
  using Solver = CapacitanceSolver;
  /// @brief One frame of compound measurements.
  using Measurements = Solver::Measurements;
  /// @brief A solved frame.
  using Frame = CapacitanceFrame;

  /// @brief A readout over a shared solver. Throws glovepose::Error for a null solver or a window
  /// or solve interval below 1.
  explicit Readout(std::shared_ptr<const Solver> solver, ReadoutConfig config = {}) : solver_(std::move(solver)), config_(config) {
    if (!solver_) throw Error("Readout: no solver given, expected a CapacitanceSolver");
    if (config_.mean_window < 1) throw Error("Readout: mean_window " + std::to_string(config_.mean_window) + ", expected at least 1");
    if (config_.solve_every < 1) throw Error("Readout: solve_every " + std::to_string(config_.solve_every) + ", expected at least 1");
    if (!(config_.gap_seconds > 0.0) || config_.clock_restart_readings < 0 || config_.stuck_readings < 2 ||
        !(config_.max_reading_residual > 0.0) || !(config_.stale_cycles > 1.0) || std::isnan(config_.disconnected_below) ||
        !(config_.max_excluded_share >= 0.0 && config_.max_excluded_share <= 1.0))
      throw Error(
          "Readout: gap_seconds " + std::to_string(config_.gap_seconds) + ", clock_restart_readings " +
          std::to_string(config_.clock_restart_readings) + ", stuck_readings " + std::to_string(config_.stuck_readings) +
          ", max_reading_residual " + std::to_string(config_.max_reading_residual) + ", stale_cycles " +
          std::to_string(config_.stale_cycles) + ", max_excluded_share " + std::to_string(config_.max_excluded_share) +
          ", expected gap_seconds > 0, clock_restart_readings >= 0, stuck_readings >= 2, max_reading_residual > 0, stale_cycles > 1, "
          "max_excluded_share in [0, 1]");
    rows_ = solver_->layout().row_count();
    if (config_.clock_restart_readings == 0) config_.clock_restart_readings = rows_;
    const auto slots = static_cast<std::size_t>(rows_) * static_cast<std::size_t>(config_.mean_window);
    values_.assign(slots, 0.0);
    times_.assign(slots, 0.0);
    count_.assign(static_cast<std::size_t>(rows_), 0);
    head_.assign(static_cast<std::size_t>(rows_), 0);
    repeats_.assign(static_cast<std::size_t>(rows_), 0);
    newest_age_.assign(static_cast<std::size_t>(rows_), 0.0);
    age_scratch_.assign(static_cast<std::size_t>(rows_), 0.0);
    mean_ = Measurements::Zero(rows_);
    residual_ = Measurements::Zero(rows_);
    frame_.cells = Solver::Capacitances::Zero(solver_->layout().cell_count());
    const Eigen::MatrixXd& m = solver_->measurement_matrix();
    full_normal_ = m.transpose() * m;
    normal_ = full_normal_;
    kept_rhs_ = Solver::Capacitances::Zero(m.cols());
    kept_mean_ = Measurements::Zero(rows_);
    kept_factor_ = Eigen::LDLT<Eigen::MatrixXd>(m.cols());
    excluded_.assign(static_cast<std::size_t>(rows_), 0);
    candidate_.assign(static_cast<std::size_t>(rows_), 0);
    reset();
  }

  /// @brief Forgets every reading (e.g. after the glove was unplugged or its clock restarted).
  void reset() noexcept {
    std::fill(count_.begin(), count_.end(), 0);
    std::fill(head_.begin(), head_.end(), 0);
    std::fill(repeats_.begin(), repeats_.end(), 0);
    backwards_run_ = 0;
    rows_seen_ = 0;
    updates_since_solve_ = 0;
    rejected_since_solve_ = 0;
    last_timestamp_ = -std::numeric_limits<double>::infinity();
  }

  /// @brief Offers one reading of measurement row `row` taken at `timestamp` (seconds).
  ///
  /// Rejected without changing any state: an unknown row (Status::UnknownIndex), a NaN or infinite
  /// value or timestamp (Status::NonFinite), a negative capacitance (Status::Negative), a timestamp
  /// before the last accepted one (Status::TimestampBackwards; after clock_restart_readings of
  /// them in a row the readout starts over on the new clock and accepts it). Accepted readings
  /// return Status::Solved when they completed a solve (see frame()), Status::NotReady while some
  /// row has not been read since the start (or since a restart after a gap), Status::Ok otherwise.
  GLOVEPOSE_REALTIME Status push_row(int row, double value, double timestamp) noexcept {
    Status check = validate(row, value, timestamp);
    if (check == Status::TimestampBackwards && ++backwards_run_ >= config_.clock_restart_readings) {
      restart();
      check = validate(row, value, timestamp);
    }
    if (check != Status::Ok) {
      ++rejected_since_solve_;
      return check;
    }
    if (std::isfinite(last_timestamp_) && timestamp - last_timestamp_ > config_.gap_seconds) restart();
    const bool was_incomplete = rows_seen_ < rows_;
    store(row, value, timestamp);
    // Solves fall on every solve_every-th accepted reading counted from the start of the stream, so
    // with solve_every equal to the row count they coincide with the ends of full cycles.
    const bool due = ++updates_since_solve_ >= config_.solve_every;
    if (due) updates_since_solve_ = 0;
    if (rows_seen_ < rows_) return Status::NotReady;
    if (due) return solve();
    if (!was_incomplete) return Status::Ok;
    // The first complete picture (at the start or after a restart) is solved at once, off the
    // cadence, which it leaves as it was.
    const int cadence = updates_since_solve_;
    const Status status = solve();
    updates_since_solve_ = cadence;
    return status;
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
    if (std::isfinite(last_timestamp_) && timestamp - last_timestamp_ > config_.gap_seconds) restart();
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
  /// @brief The settings in use (clock_restart_readings resolved).
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

  // Starts over after a gap or a clock restart; the frame's counters survive.
  void restart() noexcept {
    reset();
    ++restarts_;
  }

  void store(int row, double value, double timestamp) noexcept {
    const auto r = static_cast<std::size_t>(row);
    const auto window = static_cast<std::size_t>(config_.mean_window);
    const std::size_t previous = r * window + static_cast<std::size_t>((head_[r] + config_.mean_window - 1) % config_.mean_window);
    repeats_[r] = count_[r] > 0 && values_[previous] == value ? repeats_[r] + 1 : 1;
    backwards_run_ = 0;
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
      double sum = 0.0, newest = -std::numeric_limits<double>::infinity();
      for (std::size_t k = 0; k < n; ++k) {
        sum += values_[r * window + k];
        oldest = std::min(oldest, times_[r * window + k]);
        newest = std::max(newest, times_[r * window + k]);
      }
      mean_(row) = sum / static_cast<double>(n);
      newest_age_[r] = last_timestamp_ - newest;
    }
    if (!mean_.allFinite()) return Status::NonFinite;
    const int excluded = exclude_disconnected_rows();
    if (excluded == 0) {
      const Status status = solver_->solve(mean_, frame_.cells);
      if (status != Status::Ok) return status;
    } else {
      // Least squares over the rows kept: (M_k^T M_k) C_c = M_k^T C_m,k.
      kept_mean_ = mean_;
      for (int row = 0; row < rows_; ++row)
        if (excluded_[static_cast<std::size_t>(row)]) kept_mean_(row) = 0.0;
      kept_rhs_.noalias() = solver_->measurement_matrix().transpose() * kept_mean_;
      frame_.cells = kept_factor_.solve(kept_rhs_);
    }
    residual_.noalias() = solver_->measurement_matrix() * frame_.cells;
    residual_ -= mean_;
    // A row left out of this solve: no disagreement to count, and its stray reading may repeat or
    // age (near 0 pF, half its readings are negative and rejected) without harm.
    const auto left_out = [&](std::size_t r) { return excluded > 0 && excluded_[r] != 0; };
    for (int row = 0; row < rows_; ++row)
      if (left_out(static_cast<std::size_t>(row))) residual_(row) = 0.0;
    // Finite readings can still be large enough (~1e308 pF) for the solve or its residual to
    // overflow: no frame then, rather than one whose residual is infinite or NaN (a NaN row escapes
    // the outlier count below).
    if (!residual_.allFinite()) return Status::NonFinite;
    ReadoutHealth& health = frame_.health;
    health = ReadoutHealth{};
    health.restarts = restarts_;
    health.excluded_rows = static_cast<std::uint16_t>(excluded);
    health.max_residual = residual_.cwiseAbs().maxCoeff();
    // Rows are read one after another, so their newest readings' ages spread evenly over one cycle.
    std::copy(newest_age_.begin(), newest_age_.end(), age_scratch_.begin());
    const auto middle = age_scratch_.begin() + rows_ / 2;
    std::nth_element(age_scratch_.begin(), middle, age_scratch_.end());
    const double stale_age = config_.stale_cycles * 2.0 * *middle;
    // |residual| > bound / sqrt(n), squared: no square root per row.
    const double bound_squared = config_.max_reading_residual * config_.max_reading_residual;
    for (int row = 0; row < rows_; ++row) {
      const auto r = static_cast<std::size_t>(row);
      health.filling_rows += count_[r] < config_.mean_window ? 1 : 0;
      health.stale_rows += newest_age_[r] > stale_age && !left_out(r) ? 1 : 0;
      health.stuck_rows += repeats_[r] >= config_.stuck_readings && !left_out(r) ? 1 : 0;
      health.disconnected_rows += candidate_[r];  // read below disconnected_below: exclude_disconnected_rows() marked it
      health.outlier_rows += residual_(row) * residual_(row) * count_[r] > bound_squared ? 1 : 0;
    }
    frame_.timestamp = last_timestamp_;
    frame_.oldest_age = last_timestamp_ - oldest;
    frame_.rejected = rejected_since_solve_;
    ++frame_.sequence;
    updates_since_solve_ = 0;  // a whole frame restarts the cadence too
    rejected_since_solve_ = 0;
    return Status::Solved;
  }

  // The disconnected rows left out of this solve (their count), re-factoring the kept rows' normal
  // equations when the set changed: in preallocated storage, at most once per change. None when
  // too many are disconnected or the rest would not determine every cell (then they stay in).
  int exclude_disconnected_rows() noexcept {
    int disconnected = 0;
    bool changed = false;
    for (int row = 0; row < rows_; ++row) {
      const auto r = static_cast<std::size_t>(row);
      candidate_[r] = mean_(row) < config_.disconnected_below ? 1 : 0;
      disconnected += candidate_[r];
      changed = changed || candidate_[r] != excluded_[r];
    }
    if (disconnected > config_.max_excluded_share * rows_) disconnected = 0;  // too many: keep them all in
    if (!changed) return kept_factor_valid_ ? disconnected : 0;
    std::copy(candidate_.begin(), candidate_.end(), excluded_.begin());
    kept_factor_valid_ = false;
    if (disconnected == 0) return 0;
    const Eigen::MatrixXd& m = solver_->measurement_matrix();
    normal_ = full_normal_;
    for (int row = 0; row < rows_; ++row)
      if (excluded_[static_cast<std::size_t>(row)]) normal_.noalias() -= m.row(row).transpose() * m.row(row);
    kept_factor_.compute(normal_);
    // The kept rows determine every cell when the normal matrix stays positive definite: its
    // smallest pivot against its largest (the full M's is 1 / cond^2, about 0.025 for the paper's glove).
    const auto pivots = kept_factor_.vectorD();
    kept_factor_valid_ = kept_factor_.info() == Eigen::Success && pivots.minCoeff() > 1e-8 * pivots.maxCoeff();
    return kept_factor_valid_ ? disconnected : 0;
  }

  std::shared_ptr<const Solver> solver_;
  ReadoutConfig config_;
  int rows_ = 0;
  std::vector<double> values_;       // rows x mean_window ring buffers, row-major
  std::vector<double> times_;        // timestamps of values_
  std::vector<int> count_;           // readings held per row (<= mean_window)
  std::vector<int> head_;            // next slot to write per row
  std::vector<int> repeats_;         // consecutive identical readings per row (the latest included)
  std::vector<double> newest_age_;   // per row, age of its newest reading at the latest solve
  std::vector<double> age_scratch_;  // for the median of newest_age_
  int backwards_run_ = 0;            // consecutive readings timestamped before the last accepted one
  std::uint64_t restarts_ = 0;
  int rows_seen_ = 0;  // rows with at least one reading
  int updates_since_solve_ = 0;
  std::uint32_t rejected_since_solve_ = 0;
  double last_timestamp_ = 0.0;
  Measurements mean_;
  Measurements residual_;
  Frame frame_;
  Eigen::MatrixXd full_normal_;              // M^T M
  Eigen::MatrixXd normal_;                   // M_k^T M_k over the kept rows
  Eigen::LDLT<Eigen::MatrixXd> kept_factor_;  // its factors
  bool kept_factor_valid_ = false;           // the kept rows determine every cell
  Solver::Capacitances kept_rhs_;            // M_k^T C_m,k
  Measurements kept_mean_;                   // mean_ with the excluded rows at 0
  std::vector<unsigned char> excluded_;      // rows left out of the latest solve
  std::vector<unsigned char> candidate_;     // rows reading disconnected in this solve
};

}  // namespace glovepose::sensor
