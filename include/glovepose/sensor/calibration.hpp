/// @file calibration.hpp
/// @brief Per-sensor min-max calibration: capacitances -> [-1, 1].
///
/// The paper (Sec. 4.3, 5.2): once the glove is on, each sensor's minimum and maximum reading is
/// fixed by the hand; a short phase in which the user explores extreme poses yields them, with a
/// median filter over 20 frames applied while extracting them ("on-the-fly"). The alternative,
/// without a calibration phase, takes the per-sensor min and max over the training data.
/// A sensor whose range is too small to divide by is reported by name and maps to 0.
#pragma once

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <istream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "../config.hpp"
#include "../status.hpp"

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
};

/// @brief Whether a sensor whose readings spanned [min, max] is "flat" under `config`: its range is
/// not above config.min_relative_range x max(|min|, |max|), or is not positive. A calibration maps a
/// flat sensor to 0; an import refuses a calibration take where one is flat.
inline bool is_flat_range(double min, double max, const CalibrationConfig& config) noexcept {
  const double scale = std::max(std::abs(min), std::abs(max));
  return max - min <= config.min_relative_range * scale || max - min <= 0.0;
}

/// @brief Per-sensor range [min, max] and the normalisation it defines.
///
/// Set-up (building, saving, loading) allocates and throws; normalize() is per-frame.
class CalibrationRange {
 public:
  /// @brief A range from per-sensor minima and maxima with the sensors' names (for reports and
  /// files). Throws glovepose::Error naming the sensor when a value is not finite or min > max, or
  /// when the sizes differ.
  CalibrationRange(Eigen::VectorXd min, Eigen::VectorXd max, std::vector<std::string> names, CalibrationConfig config = {})
      : min_(std::move(min)), max_(std::move(max)), names_(std::move(names)), config_(config) {
    if (min_.size() != max_.size() || static_cast<std::size_t>(min_.size()) != names_.size())
      throw Error("CalibrationRange: " + std::to_string(min_.size()) + " minima, " + std::to_string(max_.size()) + " maxima and " +
                  std::to_string(names_.size()) + " names, expected one of each per sensor");
    if (min_.size() == 0) throw Error("CalibrationRange: no sensors, expected at least one");
    if (!(config_.min_relative_range >= 0.0) || !(config_.clamp_limit > 0.0))
      throw Error("CalibrationRange: min_relative_range must be >= 0 and clamp_limit > 0");
    flat_.assign(static_cast<std::size_t>(min_.size()), false);
    for (Eigen::Index i = 0; i < min_.size(); ++i) {
      const auto& name = names_[static_cast<std::size_t>(i)];
      if (!std::isfinite(min_(i)) || !std::isfinite(max_(i)))
        throw Error("CalibrationRange: " + name + " has a non-finite limit, expected finite min and max");
      if (min_(i) > max_(i))
        throw Error("CalibrationRange: " + name + " has min " + std::to_string(min_(i)) + " above max " + std::to_string(max_(i)) +
                    ", expected min <= max");
      // normalize() divides by the span: one that overflows would turn finite readings into NaN.
      if (!std::isfinite(max_(i) - min_(i)))
        throw Error("CalibrationRange: " + name + " has min " + std::to_string(min_(i)) + " and max " + std::to_string(max_(i)) +
                    ", whose difference overflows, expected a range max - min that is a finite number");
      if (is_flat_range(min_(i), max_(i), config_)) {
        flat_[static_cast<std::size_t>(i)] = true;
        flat_names_.push_back(name);
      }
    }
  }

  /// @brief Min/max over frames of training data (one row per frame, one column per sensor): the
  /// paper's "without calibration" setting. Throws glovepose::Error for an empty or non-finite set.
  static CalibrationRange from_frames(const Eigen::MatrixXd& frames, std::vector<std::string> names, CalibrationConfig config = {}) {
    if (frames.rows() == 0) throw Error("CalibrationRange::from_frames: no frames, expected at least one");
    if (!frames.allFinite()) throw Error("CalibrationRange::from_frames: non-finite values, expected finite frames");
    return CalibrationRange(frames.colwise().minCoeff().transpose(), frames.colwise().maxCoeff().transpose(), std::move(names), config);
  }

  /// @brief Number of sensors.
  int size() const noexcept { return static_cast<int>(min_.size()); }
  /// @brief Per-sensor minima.
  const Eigen::VectorXd& min() const noexcept { return min_; }
  /// @brief Per-sensor maxima.
  const Eigen::VectorXd& max() const noexcept { return max_; }
  /// @brief Sensor names.
  const std::vector<std::string>& names() const noexcept { return names_; }
  /// @brief Names of the sensors whose range is too small to normalise by (they map to 0).
  const std::vector<std::string>& flat_sensors() const noexcept { return flat_names_; }
  /// @brief Whether sensor i is flat.
  bool is_flat(int i) const noexcept { return flat_[static_cast<std::size_t>(i)]; }
  /// @brief The settings in use.
  const CalibrationConfig& config() const noexcept { return config_; }

  /// @brief Maps readings to 2 (x - min) / (max - min) - 1, clamped to +-clamp_limit; flat sensors
  /// give 0. Returns Status::SizeMismatch or Status::NonFinite (output untouched) for bad input.
  template <typename In, typename Out>
  GLOVEPOSE_REALTIME Status normalize(const Eigen::MatrixBase<In>& readings, Eigen::MatrixBase<Out>& out) const noexcept {
    if (readings.size() != min_.size() || out.size() != min_.size()) return Status::SizeMismatch;
    if (!readings.allFinite()) return Status::NonFinite;
    const double limit = config_.clamp_limit;
    for (Eigen::Index i = 0; i < min_.size(); ++i) {
      if (flat_[static_cast<std::size_t>(i)]) {
        out(i) = 0;
        continue;
      }
      const double v = 2.0 * (readings(i) - min_(i)) / (max_(i) - min_(i)) - 1.0;
      out(i) = static_cast<typename Out::Scalar>(std::clamp(v, -limit, limit));
    }
    return Status::Ok;
  }

  /// @brief Writes the range as text: a header line, the glove id, then "name<TAB>min<TAB>max" per
  /// sensor with 17 significant digits (exact round trip). Throws glovepose::Error if unwritable.
  void save(const std::string& path, const std::string& glove_id) const {
    std::ofstream file(path);
    if (!file) throw Error("CalibrationRange::save: cannot open '" + path + "' for writing");
    file << kFileHeader << "\n"
         << "glove\t" << glove_id << "\n"
         << "sensors\t" << size() << "\n";
    file << std::setprecision(17);
    for (int i = 0; i < size(); ++i) file << names_[static_cast<std::size_t>(i)] << "\t" << min_(i) << "\t" << max_(i) << "\n";
    if (!file) throw Error("CalibrationRange::save: writing '" + path + "' failed");
  }

  /// @brief Reads a file written by save(). The glove id and sensor names must equal the expected
  /// ones; any mismatch or malformed line throws glovepose::Error naming the line and what was expected.
  static CalibrationRange load(const std::string& path, const std::string& glove_id, const std::vector<std::string>& names,
                               CalibrationConfig config = {}) {
    std::ifstream file(path);
    if (!file) throw Error("CalibrationRange::load: cannot open '" + path + "'");
    return load(file, path, glove_id, names, config);
  }

  /// @brief Reads save()'s format from a stream (the parser of load(path, ...)); `source` names the
  /// stream in messages, as the path does.
  static CalibrationRange load(std::istream& file, const std::string& source, const std::string& glove_id,
                               const std::vector<std::string>& names, CalibrationConfig config = {}) {
    std::string line;
    int line_no = 0;
    const auto fail = [&](const std::string& what) -> Error {
      return Error("CalibrationRange::load: '" + source + "' line " + std::to_string(line_no) + ": " + what);
    };
    const auto next = [&]() {
      ++line_no;
      if (!std::getline(file, line)) throw fail("file ends early, expected more lines");
      if (!line.empty() && line.back() == '\r') line.pop_back();
    };
    next();
    if (line != kFileHeader) throw fail("header '" + line + "', expected '" + std::string(kFileHeader) + "'");
    next();
    if (line != "glove\t" + glove_id) throw fail("'" + line + "', expected 'glove\t" + glove_id + "'");
    next();
    if (line != "sensors\t" + std::to_string(names.size()))
      throw fail("'" + line + "', expected 'sensors\t" + std::to_string(names.size()) + "'");
    Eigen::VectorXd min(static_cast<Eigen::Index>(names.size())), max(static_cast<Eigen::Index>(names.size()));
    for (std::size_t i = 0; i < names.size(); ++i) {
      next();
      std::istringstream fields(line);
      std::string name, lo, hi, extra;
      if (!std::getline(fields, name, '\t') || !std::getline(fields, lo, '\t') || !std::getline(fields, hi, '\t') ||
          std::getline(fields, extra, '\t'))
        throw fail("expected 'name<TAB>min<TAB>max'");
      if (name != names[i]) throw fail("sensor '" + name + "', expected '" + names[i] + "'");
      min(static_cast<Eigen::Index>(i)) = parse_number(lo, fail);
      max(static_cast<Eigen::Index>(i)) = parse_number(hi, fail);
    }
    return CalibrationRange(std::move(min), std::move(max), names, config);
  }

 private:
  static constexpr const char* kFileHeader = "glovepose-calibration 1";

  template <typename Fail>
  static double parse_number(const std::string& text, const Fail& fail) {
    double value = 0.0;  // from_chars: independent of the host process's locale
    const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
    if (result.ec != std::errc() || result.ptr != text.data() + text.size())
      throw fail("'" + text + "' is not a number, expected a decimal number");
    return value;
  }

  Eigen::VectorXd min_;
  Eigen::VectorXd max_;
  std::vector<std::string> names_;
  CalibrationConfig config_;
  std::vector<bool> flat_;
  std::vector<std::string> flat_names_;
};

/// @brief On-the-fly min-max calibration (paper Sec. 4.3): while the user explores extreme poses,
/// each new frame enters a per-sensor window of the last `median_window` frames; once the window is
/// full, the per-sensor median of the window updates the running min and max. A single spike never
/// reaches the range.
class OnTheFlyCalibrator {
 public:
  /// @brief A calibrator for sensors with these names. Throws glovepose::Error for no sensors or a
  /// median window below 1.
  explicit OnTheFlyCalibrator(std::vector<std::string> names, int median_window = 20, CalibrationConfig config = {})
      : names_(std::move(names)), window_(median_window), config_(config) {
    if (names_.empty()) throw Error("OnTheFlyCalibrator: no sensors, expected at least one");
    if (window_ < 1) throw Error("OnTheFlyCalibrator: median window " + std::to_string(window_) + ", expected at least 1");
    const auto n = static_cast<Eigen::Index>(names_.size());
    history_ = Eigen::MatrixXd::Zero(window_, n);
    scratch_.resize(static_cast<std::size_t>(window_));
    min_ = Eigen::VectorXd(n);
    max_ = Eigen::VectorXd(n);
    reset();
  }

  /// @brief Starts over (e.g. when the glove was put on again).
  void reset() noexcept {
    frames_ = 0;
    min_.setConstant(std::numeric_limits<double>::infinity());
    max_.setConstant(-std::numeric_limits<double>::infinity());
  }

  /// @brief Adds one frame of readings. Rejects (state unchanged) frames of the wrong size
  /// (Status::SizeMismatch) or with a non-finite value (Status::NonFinite). Returns Status::NotReady
  /// until the median window is full, Status::Ok after.
  template <typename In>
  GLOVEPOSE_REALTIME Status add(const Eigen::MatrixBase<In>& readings) noexcept {
    if (readings.size() != history_.cols()) return Status::SizeMismatch;
    if (!readings.allFinite()) return Status::NonFinite;
    history_.row(static_cast<Eigen::Index>(frames_ % window_)) = readings.transpose();
    ++frames_;
    if (frames_ < window_) return Status::NotReady;
    for (Eigen::Index s = 0; s < history_.cols(); ++s) {
      for (int k = 0; k < window_; ++k) scratch_[static_cast<std::size_t>(k)] = history_(k, s);
      const double median = median_of_scratch();
      min_(s) = std::min(min_(s), median);
      max_(s) = std::max(max_(s), median);
    }
    return Status::Ok;
  }

  /// @brief Frames added since the start.
  long frames() const noexcept { return frames_; }
  /// @brief Whether enough frames arrived for a range (the median window is full).
  bool ready() const noexcept { return frames_ >= window_; }
  /// @brief The median window length.
  int median_window() const noexcept { return window_; }

  /// @brief The calibrated range so far. Throws glovepose::Error if fewer frames than the median
  /// window arrived. Flat sensors are listed by name in CalibrationRange::flat_sensors().
  CalibrationRange finish() const {
    if (!ready())
      throw Error("OnTheFlyCalibrator::finish: " + std::to_string(frames_) + " frames, expected at least " + std::to_string(window_) +
                  " (the median window)");
    return CalibrationRange(min_, max_, names_, config_);
  }

 private:
  double median_of_scratch() noexcept {
    const auto mid = scratch_.begin() + window_ / 2;
    std::nth_element(scratch_.begin(), mid, scratch_.end());
    if (window_ % 2 == 1) return *mid;
    const double upper = *mid;
    const double lower = *std::max_element(scratch_.begin(), mid);
    return 0.5 * (lower + upper);
  }

  std::vector<std::string> names_;
  int window_;
  CalibrationConfig config_;
  Eigen::MatrixXd history_;  // median_window x sensors ring
  std::vector<double> scratch_;
  Eigen::VectorXd min_;
  Eigen::VectorXd max_;
  long frames_ = 0;
};

}  // namespace glovepose::sensor
