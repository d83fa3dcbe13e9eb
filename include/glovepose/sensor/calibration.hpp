/// @file calibration.hpp
/// @brief Per-sensor min-max calibration: capacitances -> [-1, 1].
///
/// The paper (Sec. 4.3, 5.2): once the glove is on, each sensor's minimum and maximum reading is
/// fixed by the hand; a short phase in which the user explores extreme poses yields them, with a
/// median filter over 20 frames applied while extracting them ("on-the-fly"). The alternative,
/// without a calibration phase, takes the per-sensor min and max over the training data.
/// A sensor whose range is too small to divide by (flat), or no larger than its own noise would
/// make it (noise only: a dead channel), is reported by name and maps to 0.
#pragma once

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iomanip>
#include <istream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "../config.hpp"
#include "../io/atomic_file.hpp"
#include "../status.hpp"
#include "calibration_config.hpp"

namespace glovepose::sensor {

/// @brief SD of the median of `window` independent Gaussian readings of SD 1: the part of a sensor's
/// white noise that passes the on-the-fly calibration's running median. sqrt(pi / (2 window + pi -
/// 2)): exact for 1, within 1% of a simulation for odd windows, up to 10% above it for even ones
/// (the median of two is their mean), sqrt(pi / (2 window)) for long ones.
inline double median_noise_factor(int window) noexcept {
  return std::sqrt(3.14159265358979323846 / (2.0 * std::max(window, 1) + 3.14159265358979323846 - 2.0));
}

/// @brief Why a calibration maps a sensor to 0 (CalibrationRange::flatness()).
enum class Flatness : std::uint8_t {
  Moving,     ///< Not flat: normalised by its range.
  FlatRange,  ///< Range within CalibrationConfig::min_relative_range of its value (or none).
  NoiseOnly,  ///< Range below CalibrationConfig::min_range_to_noise times its noise SD.
};

/// @brief Per-sensor SD of the high-frequency noise of a stream of frames: the residual of each
/// reading from the median of it and its two neighbours, robust to isolated glitches (the median
/// of three consecutive residuals), averaged over the stream and scaled so that white Gaussian
/// noise of SD s reads s. A still or slowly moving sensor reads its noise's SD (within 5% over
/// 20,000 frames; a one-frame glitch every 50 frames adds 7%); where a sensor moves by more than
/// its noise per frame, three readings are in order and leave no residual, so a movement never
/// counts as noise (the estimate reads low there); only a turn within three frames leaves some.
///
/// Set-up (construction) allocates; reset() and add() are per-frame (noexcept, no allocation).
class NoiseEstimator {
 public:
  /// @brief Mean of the median of three consecutive |x - median3(x)| over white Gaussian noise of
  /// SD 1 (0.46501 over 10^8 frames; tests/test_calibration.cpp checks the scale).
  static constexpr double kGaussianScale = 0.465;

  /// @brief An estimator for `sensors` sensors. Throws glovepose::Error for a negative count.
  explicit NoiseEstimator(Eigen::Index sensors) {
    if (sensors < 0) throw Error("NoiseEstimator: " + std::to_string(sensors) + " sensors, expected at least 0");
    recent_ = Eigen::MatrixXd::Zero(3, sensors);
    residual_ = Eigen::MatrixXd::Zero(3, sensors);
    sum_ = Eigen::VectorXd::Zero(sensors);
  }

  /// @brief Starts over.
  void reset() noexcept {
    frames_ = 0;
    residuals_ = 0;
    terms_ = 0;
    sum_.setZero();
  }

  /// @brief Adds one frame of finite readings (the caller checks size and finiteness).
  template <typename In>
  GLOVEPOSE_REALTIME void add(const Eigen::MatrixBase<In>& readings) noexcept {
    recent_.row(static_cast<Eigen::Index>(frames_ % 3)) = readings.transpose();
    if (++frames_ < 3) return;
    // The frame before the newest is the centre of the last three (the ring holds them in some order).
    const Eigen::Index centre = static_cast<Eigen::Index>((frames_ - 2) % 3);
    const Eigen::Index slot = static_cast<Eigen::Index>(residuals_ % 3);
    for (Eigen::Index s = 0; s < recent_.cols(); ++s)
      residual_(slot, s) = std::abs(recent_(centre, s) - median3(recent_(0, s), recent_(1, s), recent_(2, s)));
    if (++residuals_ < 3) return;
    for (Eigen::Index s = 0; s < residual_.cols(); ++s) sum_(s) += median3(residual_(0, s), residual_(1, s), residual_(2, s));
    ++terms_;
  }

  /// @brief Frames added since the start.
  long frames() const noexcept { return frames_; }
  /// @brief The per-sensor noise SD so far; 0 for every sensor before 5 frames (too few to tell).
  Eigen::VectorXd sd() const {
    if (terms_ == 0) return Eigen::VectorXd::Zero(sum_.size());
    return sum_ / (static_cast<double>(terms_) * kGaussianScale);
  }

 private:
  static double median3(double a, double b, double c) noexcept { return std::max(std::min(a, b), std::min(std::max(a, b), c)); }

  Eigen::MatrixXd recent_;    // the last three frames (ring, one row per frame)
  Eigen::MatrixXd residual_;  // the last three residual magnitudes (ring)
  Eigen::VectorXd sum_;       // per sensor, the sum of the medians of three residuals
  long frames_ = 0;
  long residuals_ = 0;
  long terms_ = 0;
};

/// @brief Per-sensor range [min, max] and the normalisation it defines.
///
/// Set-up (building, saving, loading) allocates and throws; normalize() is per-frame.
class CalibrationRange {
 public:
  /// @brief A range from per-sensor minima and maxima with the sensors' names (for reports and
  /// files), its noise unknown (only the range rule applies). Throws glovepose::Error naming the
  /// sensor when a value is not finite or min > max, or when the sizes differ.
  CalibrationRange(Eigen::VectorXd min, Eigen::VectorXd max, std::vector<std::string> names, CalibrationConfig config = {})
      : CalibrationRange(min, std::move(max), Eigen::VectorXd::Zero(min.size()), std::move(names), config) {}

  /// @brief A range with each sensor's noise SD (NoiseEstimator, in the readings' unit; 0: unknown)
  /// measured over the same frames: a sensor whose range is below
  /// config.min_range_to_noise x its noise is noise only, and maps to 0 like a flat one. Throws
  /// glovepose::Error as above, and for a negative or non-finite noise.
  CalibrationRange(Eigen::VectorXd min, Eigen::VectorXd max, Eigen::VectorXd noise, std::vector<std::string> names,
                   CalibrationConfig config = {})
      : min_(std::move(min)), max_(std::move(max)), noise_(std::move(noise)), names_(std::move(names)), config_(config) {
    if (min_.size() != max_.size() || min_.size() != noise_.size() || static_cast<std::size_t>(min_.size()) != names_.size())
      throw Error("CalibrationRange: " + std::to_string(min_.size()) + " minima, " + std::to_string(max_.size()) + " maxima, " +
                  std::to_string(noise_.size()) + " noise SDs and " + std::to_string(names_.size()) +
                  " names, expected one of each per sensor");
    if (min_.size() == 0) throw Error("CalibrationRange: no sensors, expected at least one");
    if (!(config_.min_relative_range >= 0.0) || !(config_.clamp_limit > 0.0) || !(config_.min_range_to_noise >= 0.0) ||
        !std::isfinite(config_.min_range_to_noise))
      throw Error("CalibrationRange: min_relative_range must be >= 0, clamp_limit > 0 and min_range_to_noise finite and >= 0");
    flatness_.assign(static_cast<std::size_t>(min_.size()), Flatness::Moving);
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
      if (!(noise_(i) >= 0.0) || !std::isfinite(noise_(i)))
        throw Error("CalibrationRange: " + name + " has noise SD " + std::to_string(noise_(i)) + ", expected a finite value >= 0");
      flatness_[static_cast<std::size_t>(i)] = flatness_of(i);
      if (flatness_[static_cast<std::size_t>(i)] != Flatness::Moving) flat_names_.push_back(name);
    }
  }

  /// @brief Min/max over frames of training data (one row per frame in time order, one column per
  /// sensor): the paper's "without calibration" setting; the noise is measured over the same frames.
  /// Throws glovepose::Error for an empty or non-finite set.
  static CalibrationRange from_frames(const Eigen::MatrixXd& frames, std::vector<std::string> names, CalibrationConfig config = {}) {
    if (frames.rows() == 0) throw Error("CalibrationRange::from_frames: no frames, expected at least one");
    if (!frames.allFinite()) throw Error("CalibrationRange::from_frames: non-finite values, expected finite frames");
    NoiseEstimator noise(frames.cols());
    for (Eigen::Index f = 0; f < frames.rows(); ++f) noise.add(frames.row(f).transpose());
    return CalibrationRange(frames.colwise().minCoeff().transpose(), frames.colwise().maxCoeff().transpose(), noise.sd(), std::move(names),
                            config);
  }

  /// @brief Number of sensors.
  int size() const noexcept { return static_cast<int>(min_.size()); }
  /// @brief Per-sensor minima.
  const Eigen::VectorXd& min() const noexcept { return min_; }
  /// @brief Per-sensor maxima.
  const Eigen::VectorXd& max() const noexcept { return max_; }
  /// @brief Sensor names.
  const std::vector<std::string>& names() const noexcept { return names_; }
  /// @brief Per-sensor noise SD measured with the range (0: unknown, e.g. a range from a file of
  /// version 1 or from min and max alone).
  const Eigen::VectorXd& noise() const noexcept { return noise_; }
  /// @brief Names of the sensors the calibration maps to 0: flat (too small a range to normalise
  /// by) or noise only (a range their noise alone would give).
  const std::vector<std::string>& flat_sensors() const noexcept { return flat_names_; }
  /// @brief Whether sensor i maps to 0 (flat or noise only).
  bool is_flat(int i) const noexcept { return flatness_[static_cast<std::size_t>(i)] != Flatness::Moving; }
  /// @brief Why sensor i maps to 0, or Flatness::Moving.
  Flatness flatness(int i) const noexcept { return flatness_[static_cast<std::size_t>(i)]; }
  /// @brief The settings in use.
  const CalibrationConfig& config() const noexcept { return config_; }

  /// @brief One message naming every sensor that maps to 0 and why, with its range against its
  /// value and its noise, e.g. "2 of 32 sensors read 0: ch_3 (noise only: range 0.92% of its
  /// value, 4.1 x its noise SD), ch_9 (flat: range 0.05% of its value); a sensor reads 0 when its
  /// range is within 1% of its value or below 12 x its noise SD (a dead or unconnected channel, or
  /// a calibration that did not move it)". Empty when every sensor moves.
  std::string flat_report() const {
    if (flat_names_.empty()) return "";
    std::string out = std::to_string(flat_names_.size()) + " of " + std::to_string(size()) + " sensors read 0: ";
    bool first = true;
    for (int i = 0; i < size(); ++i) {
      const Flatness why = flatness(i);
      if (why == Flatness::Moving) continue;
      const double scale = std::max(std::abs(min_(i)), std::abs(max_(i))), span = max_(i) - min_(i);
      out += (first ? "" : ", ") + names_[static_cast<std::size_t>(i)] + (why == Flatness::NoiseOnly ? " (noise only: " : " (flat: ");
      out += scale > 0.0 ? "range " + short_number(100.0 * span / scale) + "% of its value" : "range 0";
      if (noise_(i) > 0.0) out += ", " + short_number(span / noise_(i)) + " x its noise SD";
      out += ")";
      first = false;
    }
    return out + "; a sensor reads 0 when its range is within " + short_number(100.0 * config_.min_relative_range) + "% of its value" +
           (config_.min_range_to_noise > 0.0 ? " or below " + short_number(config_.min_range_to_noise) + " x its noise SD" : "") +
           " (a dead or unconnected channel, or a calibration that did not move it)";
  }

  /// @brief Moves the limits to `min` and `max` (per sensor, min <= max, finite; the caller checks)
  /// in place, for a range that follows the wearer (calibration::ContinuousRange): each sensor's
  /// flatness is decided again by the same rules, while flat_sensors() and flat_report() keep the
  /// names of those flat when the range was built. Per-frame: no allocation. Returns
  /// Status::SizeMismatch (nothing moved) for another size.
  template <typename Low, typename High>
  GLOVEPOSE_REALTIME Status move_limits(const Eigen::MatrixBase<Low>& min, const Eigen::MatrixBase<High>& max) noexcept {
    if (min.size() != min_.size() || max.size() != max_.size()) return Status::SizeMismatch;
    min_ = min;
    max_ = max;
    for (Eigen::Index i = 0; i < min_.size(); ++i) flatness_[static_cast<std::size_t>(i)] = flatness_of(i);
    return Status::Ok;
  }

  /// @brief Maps readings to 2 (x - min) / (max - min) - 1, clamped to +-clamp_limit; flat sensors
  /// give 0. Returns Status::SizeMismatch or Status::NonFinite (output untouched) for bad input.
  template <typename In, typename Out>
  GLOVEPOSE_REALTIME Status normalize(const Eigen::MatrixBase<In>& readings, Eigen::MatrixBase<Out>& out) const noexcept {
    if (readings.size() != min_.size() || out.size() != min_.size()) return Status::SizeMismatch;
    if (!readings.allFinite()) return Status::NonFinite;
    const double limit = config_.clamp_limit;
    for (Eigen::Index i = 0; i < min_.size(); ++i) {
      if (flatness_[static_cast<std::size_t>(i)] != Flatness::Moving) {
        out(i) = 0;
        continue;
      }
      const double v = 2.0 * (readings(i) - min_(i)) / (max_(i) - min_(i)) - 1.0;
      out(i) = static_cast<typename Out::Scalar>(std::clamp(v, -limit, limit));
    }
    return Status::Ok;
  }

  /// @brief Writes the range as text: a header line ("glovepose-calibration 2"), the glove id, then
  /// "name<TAB>min<TAB>max<TAB>noise" per sensor with 17 significant digits (exact round trip), so
  /// the range read back finds the same flat and noise-only sensors. The file is written whole or
  /// not at all (io::AtomicFile); throws glovepose::Error naming it and the cause if unwritable.
  void save(const std::string& path, const std::string& glove_id) const {
    io::write_file_whole(path, "calibration file", [&](std::ostream& file) { save(file, glove_id); });
  }

  /// @brief Writes save()'s text to a stream.
  void save(std::ostream& file, const std::string& glove_id) const {
    file << kFileHeader << "\n"
         << "glove\t" << glove_id << "\n"
         << "sensors\t" << size() << "\n";
    file << std::setprecision(17);
    for (int i = 0; i < size(); ++i)
      file << names_[static_cast<std::size_t>(i)] << "\t" << min_(i) << "\t" << max_(i) << "\t" << noise_(i) << "\n";
  }

  /// @brief Reads a file written by save(), or by a version before the noise column
  /// ("glovepose-calibration 1", "name<TAB>min<TAB>max": the noise unknown). The glove id and sensor
  /// names must equal the expected ones; any mismatch or malformed line throws glovepose::Error
  /// naming the line and what was expected.
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
    const bool with_noise = line == kFileHeader;
    if (!with_noise && line != kFileHeaderWithoutNoise)
      throw fail("header '" + line + "', expected '" + std::string(kFileHeader) + "' (or '" + kFileHeaderWithoutNoise + "')");
    next();
    if (line != "glove\t" + glove_id) throw fail("'" + line + "', expected 'glove\t" + glove_id + "'");
    next();
    if (line != "sensors\t" + std::to_string(names.size()))
      throw fail("'" + line + "', expected 'sensors\t" + std::to_string(names.size()) + "'");
    const auto n = static_cast<Eigen::Index>(names.size());
    Eigen::VectorXd min(n), max(n), noise = Eigen::VectorXd::Zero(n);
    for (std::size_t i = 0; i < names.size(); ++i) {
      next();
      std::istringstream fields(line);
      std::string name, lo, hi, sd, extra;
      if (!std::getline(fields, name, '\t') || !std::getline(fields, lo, '\t') || !std::getline(fields, hi, '\t') ||
          (with_noise && !std::getline(fields, sd, '\t')) || std::getline(fields, extra, '\t'))
        throw fail(with_noise ? "expected 'name<TAB>min<TAB>max<TAB>noise'" : "expected 'name<TAB>min<TAB>max'");
      if (name != names[i]) throw fail("sensor '" + name + "', expected '" + names[i] + "'");
      min(static_cast<Eigen::Index>(i)) = parse_number(lo, fail);
      max(static_cast<Eigen::Index>(i)) = parse_number(hi, fail);
      if (with_noise) noise(static_cast<Eigen::Index>(i)) = parse_number(sd, fail);
    }
    return CalibrationRange(std::move(min), std::move(max), std::move(noise), names, config);
  }

 private:
  static constexpr const char* kFileHeader = "glovepose-calibration 2";

  Flatness flatness_of(Eigen::Index i) const noexcept {
    if (is_flat_range(min_(i), max_(i), config_)) return Flatness::FlatRange;
    if (is_noise_only(min_(i), max_(i), noise_(i), config_)) return Flatness::NoiseOnly;
    return Flatness::Moving;
  }
  static constexpr const char* kFileHeaderWithoutNoise = "glovepose-calibration 1";

  // A figure for a message: 3 significant digits.
  static std::string short_number(double v) {
    std::ostringstream out;
    out << std::setprecision(3) << v;
    return out.str();
  }

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
  Eigen::VectorXd noise_;
  std::vector<std::string> names_;
  CalibrationConfig config_;
  std::vector<Flatness> flatness_;
  std::vector<std::string> flat_names_;
};

/// @brief On-the-fly min-max calibration (paper Sec. 4.3): while the user explores extreme poses,
/// each new frame enters a per-sensor window of the last `median_window` frames; once the window is
/// full, the per-sensor median of the window updates the running min and max. A single spike never
/// reaches the range. Every frame also feeds a NoiseEstimator, so the range names the sensors whose
/// range is their noise alone (CalibrationConfig::min_range_to_noise).
class OnTheFlyCalibrator {
 public:
  /// @brief A calibrator for sensors with these names. Throws glovepose::Error for no sensors or a
  /// median window below 1.
  explicit OnTheFlyCalibrator(std::vector<std::string> names, int median_window = 20, CalibrationConfig config = {})
      : names_(std::move(names)), window_(median_window), config_(config), noise_(static_cast<Eigen::Index>(names_.size())) {
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
    noise_.reset();
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
    noise_.add(readings);
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

  /// @brief The calibrated range so far, with the noise of the same frames. Throws glovepose::Error
  /// if fewer frames than the median window arrived. Flat and noise-only sensors are listed by name
  /// in CalibrationRange::flat_sensors() (CalibrationRange::flat_report(): one message).
  CalibrationRange finish() const {
    if (!ready())
      throw Error("OnTheFlyCalibrator::finish: " + std::to_string(frames_) + " frames, expected at least " + std::to_string(window_) +
                  " (the median window)");
    return CalibrationRange(min_, max_, noise_.sd() * median_noise_factor(window_), names_, config_);
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
  NoiseEstimator noise_;
  Eigen::MatrixXd history_;  // median_window x sensors ring
  std::vector<double> scratch_;
  Eigen::VectorXd min_;
  Eigen::VectorXd max_;
  long frames_ = 0;
};

}  // namespace glovepose::sensor
