/// @file free_motion.hpp
/// @brief Calibration without a calibration step: each cell's range estimated from how the cells
/// spread while the wearer moves freely (docs/calibration.md, "Without a calibration step").
///
/// Why not the motion's own extremes: free motion rarely reaches the poses of the calibration
/// sequence that the model's min-max was trained on, and its extremes take in transients (a
/// range from the first 60 s of free motion, min-max or P1-P99, is 1.25-1.31x the guided error;
/// tools/experiments/free_calibration.cpp). What does carry the range is the shape of the
/// motion's distribution: each cell's sequence minimum and maximum are, over people, close to a
/// linear function of its percentiles over the motion (kMotionPercentiles: with the 1st, 5th, 20th,
/// 50th, 80th, 95th and 99th, 1.004x the guided error after 60 s on 8 new people, against 1.009x
/// with five and 1.048x with the 5th, 50th and 95th alone). A RangeMap holds those
/// functions, fitted on people the model was not trained on (train::fit_range_map), and the
/// mean range of those people (the prior: the range before any motion was seen).
///
/// MotionHistogram keeps the percentiles as the wearer moves: one histogram per cell, a frame
/// taken only when the cells moved by an RMS `novelty` of their prior ranges since the last one taken (a
/// held pose adds nothing, so it neither fills the percentiles nor ages them), every frame taken
/// weighing 1 / (1 - 1/memory) times the one before (exponential forgetting by frames taken, so a
/// drift or a slip leaves the range within a few memories). ContinuousRange applies the map to
/// them: the prior at first (the map's, or a user's own range when it restarts from a profile
/// after a donning: calibration/donning.hpp), the map of the stage the histogram has reached after
/// that (interpolated between stages in log frames taken), re-derived every update_seconds.
///
/// Set-up (construction, fitting, parsing) allocates and throws glovepose::Error; add(), update()
/// and reset() are per-frame (noexcept, no allocation).
#pragma once

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "../config.hpp"
#include "../io/json.hpp"
#include "../status.hpp"

namespace glovepose::calibration {

/// @brief The percentiles a RangeMap reads, in the order of its features after the constant 1.
inline constexpr double kMotionPercentiles[] = {1.0, 5.0, 20.0, 50.0, 80.0, 95.0, 99.0};
/// @brief Features per cell of a RangeMap: 1 and the kMotionPercentiles.
inline constexpr int kRangeFeatures = 1 + static_cast<int>(std::size(kMotionPercentiles));

/// @brief How the motion's histograms are kept (stored with the RangeMap fitted on them: the map
/// reads the percentiles of histograms kept so).
struct MotionHistogramConfig {
  int bins = 256;                 ///< Per cell, over the prior range widened by `margin` on each side.
  double margin = 1.0;            ///< Prior ranges added below the prior minimum and above the maximum.
  double novelty = 0.03;          ///< A frame is taken when the cells moved by this RMS share of their prior ranges.
  double memory = 4000.0;         ///< Frames taken over which the histogram forgets by a factor e.
};

/// @brief Per-cell histograms of the frames of free motion, forgetting slowly (file comment).
class MotionHistogram {
 public:
  /// @brief Histograms over each cell's prior range [low, high]. Throws glovepose::Error when the
  /// sizes differ, a range is not finite and positive, or the settings are out of range.
  MotionHistogram(const Eigen::VectorXd& low, const Eigen::VectorXd& high, MotionHistogramConfig config) : config_(config) {
    if (low.size() != high.size() || low.size() == 0)
      throw Error("MotionHistogram: " + std::to_string(low.size()) + " minima and " + std::to_string(high.size()) +
                  " maxima, expected one of each per cell");
    if (config.bins < 8 || config.bins > 65536 || !(config.margin >= 0.0) || !std::isfinite(config.margin) || !(config.novelty >= 0.0) ||
        !std::isfinite(config.novelty) || !(config.memory > 1.0) || !std::isfinite(config.memory))
      throw Error("MotionHistogram: bins " + std::to_string(config.bins) + ", margin " + std::to_string(config.margin) + ", novelty " +
                  std::to_string(config.novelty) + ", memory " + std::to_string(config.memory) +
                  ", expected 8..65536 bins, a finite margin and novelty >= 0 and a finite memory > 1");
    span_ = high - low;
    for (Eigen::Index c = 0; c < span_.size(); ++c)
      if (!(span_(c) > 0.0) || !std::isfinite(span_(c)) || !std::isfinite(low(c)))
        throw Error("MotionHistogram: cell " + std::to_string(c) + " has prior range [" + std::to_string(low(c)) + ", " +
                    std::to_string(high(c)) + "], expected finite limits with max > min");
    origin_ = low - config.margin * span_;
    bin_width_ = span_ * (1.0 + 2.0 * config.margin) / static_cast<double>(config.bins);
    counts_ = Eigen::MatrixXd::Zero(config.bins, low.size());
    last_ = Eigen::VectorXd::Zero(low.size());
    growth_ = 1.0 / (1.0 - 1.0 / config.memory);
    novelty_squared_ = config.novelty * config.novelty * static_cast<double>(low.size());
  }

  /// @brief Forgets every frame.
  void reset() noexcept {
    counts_.setZero();
    weight_ = 1.0;
    total_ = 0.0;
    taken_ = 0;
  }

  /// @brief Offers a frame of finite cells (the caller checks size and finiteness); returns whether
  /// it was taken (the first, then those the cells moved to by an RMS `novelty` of their prior ranges).
  template <typename In>
  GLOVEPOSE_REALTIME bool add(const Eigen::MatrixBase<In>& cells) noexcept {
    // Plain loops: an Eigen reduction over a few cells trips GCC's -Warray-bounds (mingw, AVX-512).
    double moved = 0.0;
    for (Eigen::Index c = 0; c < span_.size(); ++c) {
      const double d = (cells(c) - last_(c)) / span_(c);
      moved += d * d;
    }
    if (taken_ > 0 && moved < novelty_squared_) return false;
    for (Eigen::Index c = 0; c < span_.size(); ++c) last_(c) = cells(c);
    if (weight_ > 1e200) {  // keep the weights finite: only their ratios matter
      counts_ /= weight_;
      total_ /= weight_;
      weight_ = 1.0;
    }
    for (Eigen::Index c = 0; c < counts_.cols(); ++c) {
      const double at = std::floor((cells(c) - origin_(c)) / bin_width_(c));
      const auto bin = static_cast<Eigen::Index>(std::clamp(at, 0.0, static_cast<double>(counts_.rows() - 1)));
      counts_(bin, c) += weight_;
    }
    total_ += weight_;
    weight_ *= growth_;
    ++taken_;
    return true;
  }

  /// @brief Frames taken since the start.
  long taken() const noexcept { return taken_; }
  /// @brief The frames' weight in units of the newest one: how many frames the histograms hold
  /// (the frames taken while fewer than the memory, then levelling off at about the memory).
  double effective_frames() const noexcept { return taken_ == 0 ? 0.0 : total_ / (weight_ / growth_); }

  /// @brief Cell c's q-th percentile (0..100), linear within its bin; the bin's lower edge at 0.
  /// Before any frame, the middle of the prior range.
  GLOVEPOSE_REALTIME double percentile(Eigen::Index c, double q) const noexcept {
    if (total_ <= 0.0) return origin_(c) + 0.5 * bin_width_(c) * static_cast<double>(counts_.rows());
    const double target = std::clamp(q, 0.0, 100.0) / 100.0 * total_;
    double below = 0.0;
    for (Eigen::Index b = 0; b < counts_.rows(); ++b) {
      const double in = counts_(b, c);
      if (below + in >= target && in > 0.0)
        return origin_(c) + bin_width_(c) * (static_cast<double>(b) + std::clamp((target - below) / in, 0.0, 1.0));
      below += in;
    }
    return origin_(c) + bin_width_(c) * static_cast<double>(counts_.rows());
  }

  /// @brief The features of cell c (kRangeFeatures values: 1 and the kMotionPercentiles, each as
  /// percentile() gives it), in one pass over the cell's bins.
  GLOVEPOSE_REALTIME void features(Eigen::Index c, double* out) const noexcept {
    out[0] = 1.0;
    constexpr std::size_t count = std::size(kMotionPercentiles);
    if (total_ <= 0.0) {
      for (std::size_t p = 0; p < count; ++p) out[p + 1] = percentile(c, kMotionPercentiles[p]);
      return;
    }
    std::size_t p = 0;
    double below = 0.0;
    for (Eigen::Index b = 0; b < counts_.rows() && p < count; ++b) {
      const double in = counts_(b, c);
      for (; p < count && in > 0.0 && below + in >= kMotionPercentiles[p] / 100.0 * total_; ++p)
        out[p + 1] = origin_(c) + bin_width_(c) * (static_cast<double>(b) + std::clamp((kMotionPercentiles[p] / 100.0 * total_ - below) / in, 0.0, 1.0));
      below += in;
    }
    for (; p < count; ++p) out[p + 1] = origin_(c) + bin_width_(c) * static_cast<double>(counts_.rows());
  }

  /// @brief Cells.
  Eigen::Index cells() const noexcept { return counts_.cols(); }
  /// @brief The settings.
  const MotionHistogramConfig& config() const noexcept { return config_; }

 private:
  MotionHistogramConfig config_;
  Eigen::VectorXd span_;       // the prior ranges
  Eigen::VectorXd origin_;     // each histogram's lower edge
  Eigen::VectorXd bin_width_;  // each histogram's bin width
  Eigen::MatrixXd counts_;     // bins x cells, weighted
  Eigen::VectorXd last_;       // the last frame taken
  double weight_ = 1.0;        // the weight of the next frame taken
  double growth_ = 1.0;        // the next frame's weight over this one's
  double novelty_squared_ = 0.0;  // a frame is taken from this squared distance to the last, in prior ranges
  double total_ = 0.0;         // the weights of the frames taken
  long taken_ = 0;
};

/// @brief The name of the format (the "format" member of the JSON text).
inline constexpr const char* kRangeMapFormat = "glovepose-range-map";

/// @brief The fitted map from the motion's percentiles to each cell's calibration range, per stage
/// of the histogram (frames it holds), with the prior range (file comment).
class RangeMap {
 public:
  /// @brief One stage: from `frames` effective frames on, per cell (rows) the weights of the
  /// kRangeFeatures features for the minimum and for the maximum.
  struct Stage {
    double frames = 0.0;
    Eigen::MatrixXd low;   ///< cells x kRangeFeatures
    Eigen::MatrixXd high;  ///< cells x kRangeFeatures
  };

  /// @brief A map. Throws glovepose::Error when the sizes disagree, a number is not finite, a
  /// prior range is not positive or the stages' frames do not rise from above 0.
  RangeMap(Eigen::VectorXd prior_min, Eigen::VectorXd prior_max, std::vector<Stage> stages, MotionHistogramConfig histogram)
      : prior_min_(std::move(prior_min)), prior_max_(std::move(prior_max)), stages_(std::move(stages)), histogram_(histogram) {
    const Eigen::Index cells = prior_min_.size();
    if (cells == 0 || prior_max_.size() != cells)
      throw Error("range map: " + std::to_string(cells) + " prior minima and " + std::to_string(prior_max_.size()) +
                  " maxima, expected one of each per cell");
    for (Eigen::Index c = 0; c < cells; ++c)
      if (!std::isfinite(prior_min_(c)) || !std::isfinite(prior_max_(c)) || !(prior_max_(c) > prior_min_(c)))
        throw Error("range map: cell " + std::to_string(c) + " has prior range [" + std::to_string(prior_min_(c)) + ", " +
                    std::to_string(prior_max_(c)) + "], expected finite limits with max > min");
    double before = 0.0;
    for (std::size_t s = 0; s < stages_.size(); ++s) {
      const Stage& stage = stages_[s];
      if (!(stage.frames > before) || !std::isfinite(stage.frames))
        throw Error("range map: stage " + std::to_string(s) + " starts at " + std::to_string(stage.frames) +
                    " frames, expected more than the stage before (and than 0)");
      before = stage.frames;
      for (const Eigen::MatrixXd* w : {&stage.low, &stage.high})
        if (w->rows() != cells || w->cols() != kRangeFeatures || !w->allFinite())
          throw Error("range map: stage " + std::to_string(s) + " has " + std::to_string(w->rows()) + " x " + std::to_string(w->cols()) +
                      " weights, expected " + std::to_string(cells) + " x " + std::to_string(kRangeFeatures) + " finite numbers");
    }
    (void)MotionHistogram(prior_min_, prior_max_, histogram_);  // checks the settings
  }

  /// @brief Cells.
  int cells() const noexcept { return static_cast<int>(prior_min_.size()); }
  /// @brief The prior range: the mean range of the people the map was fitted on.
  const Eigen::VectorXd& prior_min() const noexcept { return prior_min_; }
  const Eigen::VectorXd& prior_max() const noexcept { return prior_max_; }
  /// @brief The stages, by rising frames.
  const std::vector<Stage>& stages() const noexcept { return stages_; }
  /// @brief How the histograms the map reads are kept.
  const MotionHistogramConfig& histogram() const noexcept { return histogram_; }

  /// @brief Cell c's range from its features after `frames` effective frames: the prior before
  /// any, moving linearly to the first stage's map by its frames, then between stages linearly in
  /// log frames; min <= max (a crossed pair meets at its middle).
  GLOVEPOSE_REALTIME std::pair<double, double> range(Eigen::Index c, const double* features, double frames) const noexcept {
    return range(c, features, frames, prior_min_(c), prior_max_(c));
  }
  /// @brief The same from another prior range [prior_low, prior_high] (a user's own, say).
  GLOVEPOSE_REALTIME std::pair<double, double> range(Eigen::Index c, const double* features, double frames, double prior_low,
                                                     double prior_high) const noexcept {
    double low = prior_low, high = prior_high;
    if (stages_.empty() || !(frames > 0.0)) return {low, high};
    const auto apply = [&](const Stage& s) {
      double lo = 0.0, hi = 0.0;
      for (int k = 0; k < kRangeFeatures; ++k) lo += s.low(c, k) * features[k], hi += s.high(c, k) * features[k];
      return std::pair<double, double>{lo, hi};
    };
    std::size_t s = 0;
    while (s + 1 < stages_.size() && stages_[s + 1].frames <= frames) ++s;
    const auto [lo_s, hi_s] = apply(stages_[s]);
    double a = 1.0;  // the weight of stage s against its neighbour
    if (frames < stages_[0].frames) {
      a = frames / stages_[0].frames;  // with the prior
    } else if (s + 1 < stages_.size()) {
      a = 1.0 - std::log(frames / stages_[s].frames) / std::log(stages_[s + 1].frames / stages_[s].frames);
      const auto [lo_n, hi_n] = apply(stages_[s + 1]);
      low = lo_n, high = hi_n;
    }
    low = a * lo_s + (1.0 - a) * low;
    high = a * hi_s + (1.0 - a) * high;
    if (low > high) low = high = 0.5 * (low + high);
    return {low, high};
  }

  /// @brief The JSON text stored in a model file's metadata (key "range_map"; docs/calibration.md).
  std::string to_json() const {
    const auto numbers = [](const auto& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
    io::json::Value stages = io::json::Value::array();
    for (const Stage& s : stages_) {
      io::json::Value low = io::json::Value::array(), high = io::json::Value::array();
      for (Eigen::Index c = 0; c < s.low.rows(); ++c) {
        low.push_back(numbers(Eigen::VectorXd(s.low.row(c).transpose())));
        high.push_back(numbers(Eigen::VectorXd(s.high.row(c).transpose())));
      }
      stages.push_back({{"frames", s.frames}, {"low", std::move(low)}, {"high", std::move(high)}});
    }
    const io::json::Value root = {{"format", kRangeMapFormat},
                                  {"version", 1},
                                  {"percentiles", numbers(std::vector<double>(std::begin(kMotionPercentiles), std::end(kMotionPercentiles)))},
                                  {"bins", histogram_.bins},
                                  {"margin", histogram_.margin},
                                  {"novelty", histogram_.novelty},
                                  {"memory", histogram_.memory},
                                  {"prior_min", numbers(prior_min_)},
                                  {"prior_max", numbers(prior_max_)},
                                  {"stages", std::move(stages)}};
    return io::json::write(root);
  }

  /// @brief Parses to_json()'s text; `source` names it in messages.
  static RangeMap parse(const std::string& text, const std::string& source) {
    using io::json::Value;
    const io::json::Fields f("range map '" + source + "': ");
    Value root;
    try {
      root = io::json::parse(text);
    } catch (const Error& e) {
      throw f.fail(e.what());
    }
    f.format(root, kRangeMapFormat, 1);
    const auto vector = [&](const Value& v, const std::string& what) {
      const std::vector<double> numbers = f.numbers(v, what);
      return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(numbers.data(), static_cast<Eigen::Index>(numbers.size())));
    };
    const Eigen::VectorXd percentiles = vector(f.array(root, "percentiles", "the top level"), "'percentiles'");
    bool same = percentiles.size() == static_cast<Eigen::Index>(std::size(kMotionPercentiles));
    for (Eigen::Index p = 0; same && p < percentiles.size(); ++p) same = percentiles(p) == kMotionPercentiles[p];
    if (!same)
      throw f.fail("'percentiles' differ from this reader's kMotionPercentiles (1, 5, 20, 50, 80, 95, 99), expected a map of those");
    MotionHistogramConfig histogram;
    histogram.bins = f.index(root, "bins", 65537, "the top level");
    histogram.margin = f.number(root, "margin", "the top level");
    histogram.novelty = f.number(root, "novelty", "the top level");
    histogram.memory = f.number(root, "memory", "the top level");
    Eigen::VectorXd prior_min = vector(f.array(root, "prior_min", "the top level"), "'prior_min'");
    Eigen::VectorXd prior_max = vector(f.array(root, "prior_max", "the top level"), "'prior_max'");
    std::vector<Stage> stages;
    const Value& list = f.array(root, "stages", "the top level");
    for (std::size_t s = 0; s < list.size(); ++s) {
      const std::string where = "stage " + std::to_string(s);
      if (!list[s].is_object()) throw f.fail(where + " is " + io::json::describe(list[s]) + ", expected an object");
      Stage stage;
      stage.frames = f.number(list[s], "frames", where);
      for (auto [key, out] : {std::pair<const char*, Eigen::MatrixXd*>{"low", &stage.low}, {"high", &stage.high}}) {
        const Value& rows = f.array(list[s], key, where);
        out->resize(static_cast<Eigen::Index>(rows.size()), kRangeFeatures);
        for (std::size_t c = 0; c < rows.size(); ++c) {
          const Eigen::VectorXd row = vector(rows[c], where + " '" + key + "' row " + std::to_string(c));
          if (row.size() != kRangeFeatures)
            throw f.fail(where + " '" + key + "' row " + std::to_string(c) + " has " + std::to_string(row.size()) + " weights, expected " +
                         std::to_string(kRangeFeatures));
          out->row(static_cast<Eigen::Index>(c)) = row.transpose();
        }
      }
      stages.push_back(std::move(stage));
    }
    try {
      return RangeMap(std::move(prior_min), std::move(prior_max), std::move(stages), histogram);
    } catch (const Error& e) {
      throw f.fail(e.what());
    }
  }

 private:
  Eigen::VectorXd prior_min_;
  Eigen::VectorXd prior_max_;
  std::vector<Stage> stages_;
  MotionHistogramConfig histogram_;
};

/// @brief A range kept from the wearer's free motion by a RangeMap (file comment).
class ContinuousRange {
 public:
  /// @brief Over `map` (kept by reference: it outlives this), re-derived every `update_seconds` of
  /// stream time. Throws glovepose::Error for a non-positive or non-finite period.
  ContinuousRange(const RangeMap& map, double update_seconds = 0.25)
      : map_(&map), histogram_(map.prior_min(), map.prior_max(), map.histogram()), update_seconds_(update_seconds) {
    if (!(update_seconds > 0.0) || !std::isfinite(update_seconds))
      throw Error("ContinuousRange: update period " + std::to_string(update_seconds) + " s, expected a finite time > 0");
    min_ = start_min_ = map.prior_min();
    max_ = start_max_ = map.prior_max();
  }

  /// @brief Starts over from the map's prior range.
  void reset() noexcept { reset(map_->prior_min(), map_->prior_max()); }
  /// @brief Starts over from the range [min, max] (a user's profile: their range on an earlier
  /// donning), which takes the prior's place while the motion is young. Sizes must match cells();
  /// a cell whose limits are not finite with max > min starts from the map's prior.
  void reset(const Eigen::VectorXd& min, const Eigen::VectorXd& max) noexcept {
    histogram_.reset();
    for (Eigen::Index c = 0; c < start_min_.size(); ++c) {
      const bool usable = c < min.size() && c < max.size() && std::isfinite(min(c)) && std::isfinite(max(c)) && max(c) > min(c);
      start_min_(c) = usable ? min(c) : map_->prior_min()(c);
      start_max_(c) = usable ? max(c) : map_->prior_max()(c);
    }
    min_ = start_min_;
    max_ = start_max_;
    next_update_ = -std::numeric_limits<double>::infinity();
  }

  /// @brief Offers a frame of finite cells at `timestamp` (s); returns whether the range changed.
  template <typename In>
  GLOVEPOSE_REALTIME bool add(const Eigen::MatrixBase<In>& cells, double timestamp) noexcept {
    const bool taken = histogram_.add(cells);
    // Within the period since the last update: wait. A clock that went back before the last update
    // (a restart) starts the period over rather than stopping the updates until it catches up.
    if (!taken || (timestamp < next_update_ && timestamp >= next_update_ - update_seconds_)) return false;
    next_update_ = timestamp + update_seconds_;
    update();
    return true;
  }

  /// @brief Re-derives the range from the histograms now. A cell whose map gives a limit that is
  /// not finite (weights beyond any glove's) keeps its range.
  GLOVEPOSE_REALTIME void update() noexcept {
    double features[kRangeFeatures];
    const double frames = histogram_.effective_frames();
    for (Eigen::Index c = 0; c < histogram_.cells(); ++c) {
      histogram_.features(c, features);
      const auto [low, high] = map_->range(c, features, frames, start_min_(c), start_max_(c));
      if (!std::isfinite(low) || !std::isfinite(high) || !std::isfinite(high - low)) continue;
      min_(c) = low;
      max_(c) = high;
    }
  }

  /// @brief The range's minima and maxima now.
  const Eigen::VectorXd& min() const noexcept { return min_; }
  const Eigen::VectorXd& max() const noexcept { return max_; }
  /// @brief The motion's histograms.
  const MotionHistogram& histogram() const noexcept { return histogram_; }

 private:
  const RangeMap* map_;
  MotionHistogram histogram_;
  double update_seconds_;
  double next_update_ = -std::numeric_limits<double>::infinity();
  Eigen::VectorXd min_;
  Eigen::VectorXd max_;
  Eigen::VectorXd start_min_;  // the range before any motion: the map's prior or a profile (reset)
  Eigen::VectorXd start_max_;
};

}  // namespace glovepose::calibration
