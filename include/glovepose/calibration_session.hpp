/// @file calibration_session.hpp
/// @brief An on-the-fly calibration as it runs: start, add frames, progress, finish. It owns what a
/// calibration needs while the user moves (the per-sensor median min/max, the sample clock, and with
/// a pose-guided model the frames of its sequence, kept for the angle offsets), apart from the
/// estimator's per-frame path, which only hands it each solved frame while it collects.
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <limits>
#include <algorithm>
#include <string>
#include <vector>

#include "calibration/sequence.hpp"
#include "config.hpp"
#include "pose.hpp"
#include "sensor/calibration.hpp"

namespace glovepose {

class CalibrationSession {
 public:
  /// @brief A session for sensors with these names, taking a frame at most every `sample_period`
  /// seconds into a median window of `median_window` frames. With a `sequence` (a pose-guided model's;
  /// it must outlive the session) it keeps the frames taken during the sequence: room for all of them
  /// is made here, so add() never allocates. Throws glovepose::Error for a bad window or period.
  CalibrationSession(const std::vector<std::string>& names, int median_window, const sensor::CalibrationConfig& config, double sample_period,
                     const calibration::Sequence* sequence = nullptr)
      : calibrator_(names, median_window, config), sample_period_(sample_period), sequence_(sequence) {
    if (!(sample_period_ >= 0.0) || !std::isfinite(sample_period_))
      throw Error("CalibrationSession: sample period " + std::to_string(sample_period_) + " s, expected a finite value >= 0");
    if (sequence_ != nullptr) {
      const double period = std::max(sample_period_, 1e-3);
      const auto capacity = static_cast<Eigen::Index>(std::ceil(sequence_->total_seconds() / period)) + 2;
      sequence_cells_.resize(capacity, static_cast<Eigen::Index>(names.size()));
      sequence_times_.resize(static_cast<std::size_t>(capacity));
    }
  }

  /// @brief Starts (or restarts) collecting: the range and the sequence's clock start over.
  void start() noexcept {
    calibrator_.reset();
    collecting_ = true;
    next_sample_ = -std::numeric_limits<double>::infinity();
    sequence_count_ = 0;
    sequence_start_ = std::numeric_limits<double>::quiet_NaN();
    sequence_now_ = 0.0;
  }
  /// @brief Stops collecting (after finish, or to cancel); what was collected stays readable.
  void stop() noexcept { collecting_ = false; }
  /// @brief Whether frames are being collected.
  bool collecting() const noexcept { return collecting_; }
  /// @brief The stream starts over (a reset of the estimator): the next frame is taken whatever its time.
  void restart_clock() noexcept { next_sample_ = -std::numeric_limits<double>::infinity(); }

  /// @brief One solved frame of cells at `timestamp` (s), taken when collecting and a sample period
  /// has passed since the last frame taken; non-finite frames are not taken.
  GLOVEPOSE_REALTIME void add(const Eigen::VectorXd& cells, double timestamp) noexcept {
    if (!collecting_ || !(timestamp >= next_sample_)) return;
    if (calibrator_.add(cells) == Status::NonFinite) return;
    // A small tolerance keeps frames that arrive on a period's grid from slipping by one.
    next_sample_ = timestamp + sample_period_ * (1.0 - 1e-6);
    if (std::isnan(sequence_start_)) sequence_start_ = timestamp;
    sequence_now_ = timestamp - sequence_start_;
    if (sequence_count_ < sequence_cells_.rows()) {
      sequence_cells_.row(sequence_count_) = cells.transpose();
      sequence_times_[static_cast<std::size_t>(sequence_count_++)] = sequence_now_;
    }
  }

  /// @brief How far the calibration has come (with a sequence: its clock and the step under way).
  CalibrationProgress progress() const noexcept {
    CalibrationProgress p{collecting_, calibrator_.frames(), calibrator_.median_window(), calibrator_.ready()};
    if (collecting_ && sequence_ != nullptr && !std::isnan(sequence_start_)) {
      p.sequence_seconds = sequence_now_;
      p.step = sequence_->step_at(sequence_now_);
    }
    return p;
  }

  /// @brief The range of the frames so far. Throws glovepose::Error when fewer frames than the median
  /// window arrived or no calibration was started; it does not stop collecting (stop() does).
  sensor::CalibrationRange range() const {
    if (!collecting_) throw Error("CalibrationSession: no calibration running, expected start_calibration() first");
    return calibrator_.finish();
  }

  /// @brief The frames taken during the sequence (rows, cells C_c) and their seconds since its first frame.
  Eigen::Index sequence_frames() const noexcept { return sequence_count_; }
  Eigen::MatrixXd::ConstRowXpr sequence_cells(Eigen::Index frame) const noexcept { return sequence_cells_.row(frame); }
  double sequence_time(Eigen::Index frame) const noexcept { return sequence_times_[static_cast<std::size_t>(frame)]; }

 private:
  sensor::OnTheFlyCalibrator calibrator_;
  double sample_period_;
  const calibration::Sequence* sequence_;
  bool collecting_ = false;
  double next_sample_ = -std::numeric_limits<double>::infinity();
  Eigen::MatrixXd sequence_cells_;      // frames taken during the sequence (rows), C_c
  std::vector<double> sequence_times_;  // their seconds since the sequence's first frame
  Eigen::Index sequence_count_ = 0;
  double sequence_start_ = std::numeric_limits<double>::quiet_NaN();
  double sequence_now_ = 0.0;
};

}  // namespace glovepose
