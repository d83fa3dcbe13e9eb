/// @file metrics.hpp
/// @brief Joint-angle error metrics as the paper reports them: mean absolute angle error in degrees
/// over all 25 DoFs and frames (Glauser et al. 2019, Table 1), per DoF, per finger, and the cumulative
/// error curve (Fig. 14: share of angles with an error below a threshold; the paper quotes 92% below
/// 15 degrees), plus RMS, median, 95th percentile and maximum.
///
/// Evaluation is offline set-up code: it may allocate and throws glovepose::Error on misuse.
///
/// How the figures are resolved:
/// - Means, RMS and maxima are exact up to a fixed-point quantum of 2^-32 degree (about 2e-10
///   degree) per angle error. The sums are kept in 128-bit fixed point, so they do not depend on the
///   order of add() calls or on how frames were split across accumulators before merge(): a merged
///   report is bit-identical to one accumulated sequentially.
/// - The cumulative curve and the share under 15 degrees are exact counts (errors strictly below
///   whole-degree thresholds).
/// - Percentiles (median, 95th) use the nearest-rank definition (the ceil(q n)-th smallest error)
///   and are resolved by a histogram of 1/128-degree bins below 180 degrees: the reported value is
///   the centre of the bin holding that error, clamped to the observed minimum and maximum, so it is
///   within 1/256 degree of the exact value. Errors of 180 degrees or more are kept individually and
///   their percentiles are exact.
/// - No wrap-around: the error of an angle is |predicted - true|, since joint angles are not
///   periodic within their limits.
#pragma once

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "../core/statistics.hpp"
#include "../core/units.hpp"
#include "../config.hpp"
#include "../hand/dofs.hpp"

namespace glovepose::train {

/// @brief Width of a histogram bin used for percentiles, degrees (a power of two, so every whole
/// degree is a bin edge and binning is exact).
inline constexpr double kPercentileResolutionDeg = 1.0 / 128.0;
/// @brief Errors at or above this many degrees are kept individually rather than in the histogram.
inline constexpr double kHistogramLimitDeg = 180.0;
/// @brief Largest threshold of the cumulative error curve, degrees; the curve holds 0, 1, ..., 45.
inline constexpr int kCurveMaxDeg = 45;
/// @brief Number of points of the cumulative error curve (thresholds 0..kCurveMaxDeg).
inline constexpr std::size_t kCurvePoints = static_cast<std::size_t>(kCurveMaxDeg) + 1;
/// @brief The threshold the paper quotes in Fig. 14 (92% of angles below it), degrees.
inline constexpr int kPaperThresholdDeg = 15;

/// @brief Error statistics of one group of angles (one DoF, one finger), degrees.
struct ErrorSummary {
  double mean_deg = 0;  ///< Mean absolute error.
  double rms_deg = 0;   ///< Root of the mean squared error.
  double max_deg = 0;   ///< Largest absolute error.
};

/// @brief One DoF's errors.
struct DofError {
  const char* name = "";  ///< hand::kDofs name, e.g. "index_base_flexion".
  int theta = 0;          ///< Index in the reference model's 34 parameters (9..33).
  bool scored = true;     ///< False for a DoF without reference angles (not labelled): error is then NaN.
  ErrorSummary error;     ///< Over all valid frames.
};

/// @brief One finger's errors, over the frames and the finger's 5 DoFs.
struct FingerError {
  const char* name = "";  ///< hand::to_string(Finger), e.g. "thumb".
  ErrorSummary error;     ///< Over all valid frames and the finger's scored DoFs (NaN when it has none).
};

/// @brief One point of the cumulative error curve (paper Fig. 14).
struct CurvePoint {
  int threshold_deg = 0;  ///< Threshold, whole degrees.
  double share = 0;       ///< Share (0..1) of angles whose error is strictly below the threshold.
};

/// @brief What AngleErrorAccumulator::report() measured. Always from at least one valid frame.
struct AngleErrorReport {
  std::size_t frames = 0;                     ///< Valid frames evaluated.
  std::size_t skipped_frames = 0;             ///< Frames left out because an angle (predicted or true) was not finite.
  std::size_t angles = 0;                     ///< Angle errors evaluated: frames x scored DoFs.
  std::size_t scored_dofs = hand::kDofCount;  ///< DoFs scored (those with reference angles).
  ErrorSummary overall;                       ///< Over all angles; overall.mean_deg is the paper's "mean angle error".
  double median_deg = 0;                      ///< Nearest-rank median of all angle errors (see percentile_resolution_deg).
  double p95_deg = 0;                         ///< Nearest-rank 95th percentile of all angle errors.
  double percentile_resolution_deg = kPercentileResolutionDeg;  ///< Histogram bin width behind the percentiles.
  double share_under_15deg = 0;                                 ///< Share of angles with error below 15 degrees (paper Fig. 14: 92%).
  std::array<FingerError, hand::kFingerCount> fingers{};        ///< By hand::Finger.
  std::array<DofError, hand::kDofCount> dofs{};                 ///< In hand::kDofs order.
  std::array<CurvePoint, kCurvePoints> curve{};                 ///< Thresholds 0, 1, ..., kCurveMaxDeg degrees.
};

namespace detail {

// An unsigned 128-bit sum of 64-bit terms: integer addition is associative, so the total does not
// depend on the order frames arrive in or on how accumulators are merged.
struct FixedSum {
  std::uint64_t low = 0;
  std::uint64_t high = 0;

  void add(std::uint64_t term) noexcept {
    low += term;
    if (low < term) ++high;  // carry
  }
  void add(const FixedSum& other) noexcept {
    add(other.low);
    high += other.high;
  }
  // The sum in units of 2^-32.
  double value() const noexcept { return (static_cast<double>(high) * 0x1p64 + static_cast<double>(low)) * 0x1p-32; }
};

// A value in [0, 2^31) in units of 2^-32, rounded to nearest; scaling by a power of two is exact.
inline std::uint64_t to_fixed(double value) noexcept { return static_cast<std::uint64_t>(std::llround(value * 0x1p32)); }

// Sum of values in ascending order: a deterministic total for a set, whatever order it was built in.
inline double sorted_sum(std::vector<double> values, bool squares) {
  std::sort(values.begin(), values.end());
  double sum = 0.0;
  for (double v : values) sum += squares ? v * v : v;
  return sum;
}

}  // namespace detail

/// @brief Accumulates predicted-against-true joint-angle errors frame by frame or in blocks, and
/// reports them the way the paper does (see the file comment for how each figure is resolved).
///
/// A frame is 25 angles in radians in hand::kDofs order. Only the scored DoFs (all by default; a
/// dataset labelling a subset scores that subset) count: the others are neither read nor reported.
/// A frame with any non-finite scored angle, predicted or true (or whose error overflows a double),
/// is not evaluated but counted in skipped_frames(), so missing ground truth never poisons the mean. For threads, give each its own
/// accumulator and merge() them: the result equals sequential accumulation exactly, whatever the split.
///
/// Memory: a histogram of 23040 counters (about 180 KB), plus 16 bytes per angle error of 180
/// degrees or more (kept individually; only a broken model or angles outside the joint limits make
/// them).
class AngleErrorAccumulator {
 public:
  /// @brief An accumulator with no frames that scores every DoF.
  AngleErrorAccumulator() : histogram_(kHistogramBins, 0) { scored_.fill(true); }

  /// @brief An accumulator with no frames that scores the DoFs of `scored`. Throws glovepose::Error
  /// when the set is empty.
  explicit AngleErrorAccumulator(const hand::DofSet& scored) : scored_(scored), histogram_(kHistogramBins, 0) {
    if (scored_count() == 0) throw Error("AngleErrorAccumulator: no DoF to score, expected at least one");
  }

  /// @brief The DoFs scored.
  const hand::DofSet& scored() const noexcept { return scored_; }

  /// @brief Adds one frame: `predicted` and `truth` each point to 25 angles (radians, hand::kDofs
  /// order). Returns false, and counts the frame as skipped, when an angle is not finite. Throws
  /// glovepose::Error when a pointer is null.
  bool add(const double* predicted, const double* truth) {
    check_pointers(predicted, truth, 1, "add");
    return add_frame(predicted, truth);
  }

  /// @brief Adds one frame given as hand::Angles; see add(const double*, const double*).
  bool add(const hand::Angles& predicted, const hand::Angles& truth) { return add_frame(predicted.data(), truth.data()); }

  /// @brief Adds `frames` frames stored row-major (frames x 25, radians, hand::kDofs order), e.g. a
  /// network's output block against io::Dataset::angles. Returns the number of frames skipped
  /// because an angle was not finite. Throws glovepose::Error when a pointer is null and frames > 0.
  std::size_t add_batch(const float* predicted, const float* truth, std::size_t frames) { return add_rows(predicted, truth, frames); }

  /// @brief Double-precision form of add_batch(const float*, const float*, std::size_t).
  std::size_t add_batch(const double* predicted, const double* truth, std::size_t frames) { return add_rows(predicted, truth, frames); }

  /// @brief Adds the frames of `other` to this accumulator. The result does not depend on the order
  /// of merges and equals accumulating all frames in one accumulator.
  void merge(const AngleErrorAccumulator& other) {
    if (&other == this) {  // appending a vector to itself would read what it writes
      const AngleErrorAccumulator copy(other);
      merge(copy);
      return;
    }
    if (other.scored_ != scored_)
      throw Error("AngleErrorAccumulator::merge: the other accumulator scores other DoFs (" + hand::dof_set_text(other.scored_) +
                  "), expected the same as this one");
    frames_ += other.frames_;
    skipped_ += other.skipped_;
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      dofs_[d].sum.add(other.dofs_[d].sum);
      dofs_[d].sum_squares.add(other.dofs_[d].sum_squares);
      dofs_[d].max = std::max(dofs_[d].max, other.dofs_[d].max);
    }
    for (std::size_t b = 0; b < kHistogramBins; ++b) histogram_[b] += other.histogram_[b];
    in_histogram_ += other.in_histogram_;
    large_.insert(large_.end(), other.large_.begin(), other.large_.end());
    min_ = std::min(min_, other.min_);
  }

  /// @brief Forgets every frame.
  void clear() {
    const hand::DofSet scored = scored_;
    *this = AngleErrorAccumulator();
    scored_ = scored;
  }

  /// @brief Valid frames added so far.
  std::size_t frames() const noexcept { return frames_; }
  /// @brief Frames left out because an angle was not finite.
  std::size_t skipped_frames() const noexcept { return skipped_; }
  /// @brief Whether no valid frame was added (report() would throw).
  bool empty() const noexcept { return frames_ == 0; }

  /// @brief Share (0..1) of angle errors strictly below `threshold_deg`. Exact for thresholds that
  /// are multiples of kPercentileResolutionDeg (every whole degree) and for any threshold of
  /// kHistogramLimitDeg or more; other thresholds are rounded down to a bin edge. Throws
  /// glovepose::Error when there are no valid frames or the threshold is NaN.
  double share_below(double threshold_deg) const {
    require_frames("share_below");
    if (std::isnan(threshold_deg)) throw Error("AngleErrorAccumulator::share_below: threshold is NaN, expected a number of degrees");
    const double total = static_cast<double>(angles());
    if (threshold_deg <= 0.0) return 0.0;
    if (threshold_deg < kHistogramLimitDeg) {
      const auto edge = static_cast<std::size_t>(std::floor(threshold_deg / kPercentileResolutionDeg));
      std::uint64_t below = 0;
      for (std::size_t b = 0; b < edge; ++b) below += histogram_[b];
      return static_cast<double>(below) / total;
    }
    std::uint64_t below = in_histogram_;
    for (const auto& entry : large_)
      if (entry.second < threshold_deg) ++below;
    return static_cast<double>(below) / total;
  }

  /// @brief Nearest-rank percentile of all angle errors, degrees: the ceil(q n)-th smallest of the n
  /// errors (the smallest for q = 0), histogram-resolved below kHistogramLimitDeg (within 1/256
  /// degree, see the file comment). Throws glovepose::Error when there are no valid frames or q is
  /// outside [0, 1].
  double percentile(double q) const {
    require_frames("percentile");
    if (!(q >= 0.0 && q <= 1.0))
      throw Error("AngleErrorAccumulator::percentile: q = " + std::to_string(q) + ", expected a share in [0, 1]");
    const std::uint64_t rank = core::nearest_rank(angles(), q);
    if (rank > in_histogram_) {
      std::vector<double> large;
      large.reserve(large_.size());
      for (const auto& entry : large_) large.push_back(entry.second);
      const auto nth = large.begin() + static_cast<std::ptrdiff_t>(rank - in_histogram_ - 1);
      std::nth_element(large.begin(), nth, large.end());
      return *nth;
    }
    const std::size_t bin = core::bin_of_rank(histogram_, rank);
    const double centre = (static_cast<double>(bin) + 0.5) * kPercentileResolutionDeg;
    return std::clamp(centre, min_, max_error());
  }

  /// @brief The report of every valid frame so far. Throws glovepose::Error when there is none (all
  /// frames skipped, or none added): a mean of nothing is not a figure to print.
  AngleErrorReport report() const {
    require_frames("report");
    AngleErrorReport r;
    r.frames = frames_;
    r.skipped_frames = skipped_;
    r.angles = static_cast<std::size_t>(angles());
    r.scored_dofs = scored_count();

    // Errors of 180 degrees or more, by DoF, summed in ascending order for a deterministic total.
    std::array<std::vector<double>, hand::kDofCount> large_by_dof;
    for (const auto& entry : large_) large_by_dof[entry.first].push_back(entry.second);
    std::array<double, hand::kDofCount> sum{}, sum_squares{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      sum[d] = dofs_[d].sum.value() + detail::sorted_sum(large_by_dof[d], false);
      sum_squares[d] = dofs_[d].sum_squares.value() + detail::sorted_sum(large_by_dof[d], true);
    }

    const double per_dof = static_cast<double>(frames_);
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      r.dofs[d].name = hand::kDofs[d].name;
      r.dofs[d].theta = hand::kDofs[d].theta;
      r.dofs[d].scored = scored_[d];
      r.dofs[d].error = scored_[d] ? summary(sum[d], sum_squares[d], dofs_[d].max, per_dof) : ErrorSummary{NAN, NAN, NAN};
    }

    // Fingers and the whole hand: fixed-point sums added exactly, large errors over the group sorted.
    const auto group = [&](auto member) {
      detail::FixedSum fixed, fixed_squares;
      std::vector<double> large;
      double max = 0.0;
      std::size_t count = 0;
      for (std::size_t d = 0; d < hand::kDofCount; ++d) {
        if (!member(d) || !scored_[d]) continue;
        fixed.add(dofs_[d].sum);
        fixed_squares.add(dofs_[d].sum_squares);
        large.insert(large.end(), large_by_dof[d].begin(), large_by_dof[d].end());
        max = std::max(max, dofs_[d].max);
        ++count;
      }
      if (count == 0) return ErrorSummary{NAN, NAN, NAN};
      return summary(fixed.value() + detail::sorted_sum(large, false), fixed_squares.value() + detail::sorted_sum(large, true), max,
                     per_dof * static_cast<double>(count));
    };
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      r.fingers[f].name = hand::to_string(static_cast<hand::Finger>(f));
      r.fingers[f].error = group([f](std::size_t d) { return static_cast<std::size_t>(hand::kDofs[d].finger) == f; });
    }
    r.overall = group([](std::size_t) { return true; });

    r.median_deg = percentile(0.5);
    r.p95_deg = percentile(0.95);
    r.share_under_15deg = share_below(kPaperThresholdDeg);
    for (int t = 0; t <= kCurveMaxDeg; ++t) r.curve[static_cast<std::size_t>(t)] = CurvePoint{t, share_below(t)};
    return r;
  }

 private:
  static constexpr std::size_t kHistogramBins = static_cast<std::size_t>(kHistogramLimitDeg / kPercentileResolutionDeg);

  struct DofSums {
    detail::FixedSum sum;          // errors below kHistogramLimitDeg, degrees, fixed point
    detail::FixedSum sum_squares;  // their squares, degrees^2, fixed point
    double max = 0.0;              // largest error, any size
  };

  std::uint64_t angles() const noexcept { return static_cast<std::uint64_t>(frames_) * scored_count(); }
  std::size_t scored_count() const noexcept { return static_cast<std::size_t>(std::count(scored_.begin(), scored_.end(), true)); }

  double max_error() const noexcept {
    double max = 0.0;
    for (const DofSums& dof : dofs_) max = std::max(max, dof.max);
    return max;
  }

  static ErrorSummary summary(double sum, double sum_squares, double max, double count) noexcept {
    return ErrorSummary{sum / count, std::sqrt(sum_squares / count), max};
  }

  template <typename T>
  static void check_pointers(const T* predicted, const T* truth, std::size_t frames, const char* what) {
    if (frames > 0 && (predicted == nullptr || truth == nullptr))
      throw Error(std::string("AngleErrorAccumulator::") + what + ": " + (predicted == nullptr ? "predicted" : "truth") +
                  " is null, expected 25 angles per frame");
  }

  void require_frames(const char* what) const {
    if (frames_ == 0)
      throw Error(std::string("AngleErrorAccumulator::") + what + ": no valid frames (" + std::to_string(skipped_) +
                  " skipped for non-finite angles), expected at least one frame with finite predicted and true angles");
  }

  template <typename T>
  std::size_t add_rows(const T* predicted, const T* truth, std::size_t frames) {
    check_pointers(predicted, truth, frames, "add_batch");
    std::size_t skipped = 0;
    for (std::size_t f = 0; f < frames; ++f)
      if (!add_frame(predicted + f * hand::kDofCount, truth + f * hand::kDofCount)) ++skipped;
    return skipped;
  }

  template <typename T>
  bool add_frame(const T* predicted, const T* truth) {
    // Check the whole frame before touching any sum, so a skipped frame leaves no trace.
    std::array<double, hand::kDofCount> error{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      if (!scored_[d]) continue;
      const auto p = static_cast<double>(predicted[d]);
      const auto t = static_cast<double>(truth[d]);
      error[d] = std::abs(p - t) * core::kDegreesPerRadian;
      if (!std::isfinite(p) || !std::isfinite(t) || !std::isfinite(error[d])) {
        ++skipped_;
        return false;
      }
    }
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      if (!scored_[d]) continue;
      const double e = error[d];
      DofSums& dof = dofs_[d];
      dof.max = std::max(dof.max, e);
      min_ = std::min(min_, e);
      if (e < kHistogramLimitDeg) {
        dof.sum.add(detail::to_fixed(e));
        dof.sum_squares.add(detail::to_fixed(e * e));
        // e / 2^-7 is exact, so the bin edges fall exactly on multiples of 1/128 degree.
        ++histogram_[std::min(kHistogramBins - 1, static_cast<std::size_t>(e / kPercentileResolutionDeg))];
        ++in_histogram_;
      } else {
        large_.emplace_back(d, e);
      }
    }
    ++frames_;
    return true;
  }

  std::size_t frames_ = 0;
  std::size_t skipped_ = 0;
  hand::DofSet scored_{};
  std::array<DofSums, hand::kDofCount> dofs_{};
  std::vector<std::uint64_t> histogram_;                  // counts of errors in [b/128, (b+1)/128) degrees
  std::uint64_t in_histogram_ = 0;                        // errors below kHistogramLimitDeg
  std::vector<std::pair<std::size_t, double>> large_;     // (DoF, error) of errors >= kHistogramLimitDeg
  double min_ = std::numeric_limits<double>::infinity();  // smallest error, to clamp percentiles
};

}  // namespace glovepose::train
