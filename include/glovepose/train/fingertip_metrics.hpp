/// @file fingertip_metrics.hpp
/// @brief What a hand used as an XR input device is judged by: where the fingertips are and whether
/// thumb and finger tips meet when the user's do. From predicted and true joint angles frame by
/// frame, on one hand model per recording (a simulated person's own hand, else the reference hand):
/// - each digit's fingertip position error, mm: forward kinematics (hand/kinematics.hpp) of the true
///   and the predicted angles on the same hand, the tips compared wrist-relative (in the model's
///   root frame: the global pose and the wrist are not estimated, so they are left out of both);
///   mean, median, 95th percentile and maximum per digit and over all five;
/// - for index..pinky, the error of the thumb-tip-to-fingertip distance, |d_pred - d_true|, mm;
/// - pinch detection per pair (thumb-index, -middle, -ring, -pinky) by the rule of hand/pinch.hpp,
///   the one the live pinch state (hand/xr_hand.hpp) uses: a pinch is on when the two tip points (the
///   ends of the distal phalanxes, Kinematics::fingertip) come closer than kPinchThresholdMm and
///   stays on until they part beyond kPinchReleaseMm (the same rule for the truth and the
///   prediction); per-frame precision and recall of the predicted pinch against the
///   true one; and, for each true pinch onset, the predicted onset matched to it within
///   kPinchOnsetWindowS either side (its latency: predicted minus true onset time, negative when the
///   prediction was early), the median latency and the onsets missed;
/// - in the frames a pair pinches in truth: the mean position error of its two tips (thumb and
///   finger pooled) and of their distance, what a contact stage (hand/contact.hpp) is for.
///
/// The threshold and the release, and why 15 and 18 mm: hand/pinch.hpp. docs/results.md,
/// "Fingertips and pinches", has the measurement.
///
/// Evaluation is offline set-up code: it may allocate and throws glovepose::Error on misuse.
/// Percentiles are core::percentile's (nearest rank: the ceil(q n)-th smallest value).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "../config.hpp"
#include "../core/statistics.hpp"
#include "../hand/dofs.hpp"
#include "../hand/kinematics.hpp"
#include "../hand/pinch.hpp"

namespace glovepose::train {

// The pinch rule is hand/pinch.hpp's (it says why 15 and 18 mm): the same entities, not copies.
using hand::kPinchPairCount;
using hand::kPinchReleaseMm;
using hand::kPinchThresholdMm;
/// @brief How far (s) before or after a true pinch onset a predicted onset may be to count as its
/// detection; a true onset without one is missed.
inline constexpr double kPinchOnsetWindowS = 0.25;

/// @brief The rules of the measures. Defaults: kPinchThresholdMm, kPinchReleaseMm, kPinchOnsetWindowS.
struct FingertipConfig {
  double pinch_threshold_mm = kPinchThresholdMm;  ///< A pinch starts below this distance.
  double pinch_release_mm = kPinchReleaseMm;      ///< ... and ends beyond this one (>= the threshold).
  double onset_window_s = kPinchOnsetWindowS;     ///< Largest |predicted - true onset time| of a detection.

  /// @brief Throws glovepose::Error naming the first setting out of range.
  void validate() const {
    if (!(pinch_threshold_mm > 0.0 && std::isfinite(pinch_threshold_mm)))
      throw Error("FingertipConfig: pinch_threshold_mm is " + std::to_string(pinch_threshold_mm) + ", expected a positive distance (mm)");
    if (!(pinch_release_mm >= pinch_threshold_mm && std::isfinite(pinch_release_mm)))
      throw Error("FingertipConfig: pinch_release_mm is " + std::to_string(pinch_release_mm) +
                  ", expected a distance (mm) at least pinch_threshold_mm (" + std::to_string(pinch_threshold_mm) + ")");
    if (!(onset_window_s >= 0.0 && std::isfinite(onset_window_s)))
      throw Error("FingertipConfig: onset_window_s is " + std::to_string(onset_window_s) + ", expected a duration of 0 s or more");
  }

  /// @brief The pinch rule of these settings (hand/pinch.hpp). Its far distance, which only the
  /// strength uses (not evaluated here), is the default, or twice the threshold when that is beyond it.
  hand::PinchRule pinch_rule() const noexcept {
    hand::PinchRule rule;
    rule.threshold_mm = pinch_threshold_mm;
    rule.release_mm = pinch_release_mm;
    if (!(rule.far_mm > rule.threshold_mm)) rule.far_mm = 2.0 * rule.threshold_mm;
    return rule;
  }
};

/// @brief The five fingertips (mm, root frame of the hand), thumb to pinky, for a pose
/// (hand::fingertip_positions).
using hand::fingertip_positions;

/// @brief Position error statistics of one fingertip (or of all five), mm. NaN when no frame scored it.
struct TipErrorSummary {
  const char* finger = "";  ///< hand::to_string(Finger), or "all".
  std::size_t frames = 0;   ///< Frames in which the tip was scored (its digit's angles finite); "all": summed over the tips.
  double mean_mm = NAN;     ///< Mean Euclidean distance between the true and the predicted tip.
  double median_mm = NAN;   ///< Median of it.
  double p95_mm = NAN;      ///< 95th percentile of it.
  double max_mm = NAN;      ///< Largest.
};

/// @brief One pinch pair's scores (thumb with `finger`), or all four pairs pooled ("all").
struct PinchScore {
  const char* finger = "";              ///< The digit the thumb meets, or "all".
  std::size_t frames = 0;               ///< Frames in which the pair was scored; "all": summed over the pairs.
  double distance_error_mean_mm = NAN;  ///< Mean |d_pred - d_true| of the thumb-to-fingertip distance.
  double distance_error_p95_mm = NAN;   ///< Its 95th percentile.
  std::size_t true_frames = 0;          ///< Frames pinching in truth.
  std::size_t predicted_frames = 0;     ///< Frames pinching in the prediction.
  std::size_t both_frames = 0;          ///< Frames pinching in both.
  double precision = NAN;               ///< both / predicted (NaN when nothing was predicted).
  double recall = NAN;                  ///< both / true (NaN when nothing pinched in truth).
  std::size_t onsets = 0;               ///< True pinch onsets (a frame pinching after one that did not).
  std::size_t detected_onsets = 0;      ///< Those with a predicted onset within the window.
  std::size_t missed_onsets = 0;        ///< Those without.
  std::size_t false_onsets = 0;         ///< Predicted onsets matched to no true onset.
  double latency_median_ms = NAN;       ///< Median (predicted - true onset time) over detected onsets.
  double latency_mean_ms = NAN;         ///< Their mean.
  double pinch_tip_error_mean_mm = NAN;       ///< Over the true pinching frames: mean tip position error, thumb and finger pooled.
  double pinch_distance_error_mean_mm = NAN;  ///< ... and mean |d_pred - d_true| there.
};

/// @brief What FingertipAccumulator::report() measured.
struct FingertipReport {
  std::size_t frames = 0;                                ///< Frames added.
  FingertipConfig config;                                ///< The rules used.
  std::array<TipErrorSummary, hand::kFingerCount> tips;  ///< Thumb to pinky.
  TipErrorSummary all;                                   ///< All five tips pooled.
  std::array<PinchScore, kPinchPairCount> pinches;       ///< Thumb with index, middle, ring, pinky.
  PinchScore all_pinches;                                ///< The four pairs pooled.
};

/// @brief Accumulates fingertip and pinch measures over recordings ("runs"): call begin_run() with
/// the hand of the person who made the next frames, then add() each frame in time order. A digit's
/// measures skip a frame in which one of its DoFs (and, for a pair, the thumb's) is not finite in
/// the prediction or the truth; the pinch state is then unknown, so no onset is counted on the next
/// scored frame. Onsets are matched within a run only; a run's first frame starts no onset.
class FingertipAccumulator {
 public:
  /// @brief An accumulator with the given rules (validated: throws glovepose::Error), on the
  /// reference hand until begin_run() names another.
  explicit FingertipAccumulator(const FingertipConfig& config = {}) : config_(config) {
    config_.validate();
    rule_ = config_.pinch_rule();
  }

  /// @brief The rules.
  const FingertipConfig& config() const noexcept { return config_; }

  /// @brief Starts a new run (recording) whose frames come from `kinematics`' hand.
  void begin_run(const hand::Kinematics& kinematics = hand::Kinematics()) {
    kinematics_ = kinematics;
    ++run_;
    last_time_ = -INFINITY;
    for (PairState& s : state_) s = PairState{};
  }

  /// @brief Adds the next frame of the run: predicted and true angles (radians, hand::kDofs order)
  /// at `time_s` seconds. Returns whether every measure scored the frame (false when an angle was
  /// not finite). Throws glovepose::Error when the time is not finite or not after the previous
  /// frame's in this run.
  bool add(const hand::Angles& predicted, const hand::Angles& truth, double time_s) {
    if (run_ == 0) begin_run(kinematics_);
    if (!std::isfinite(time_s) || !(time_s > last_time_))
      throw Error("FingertipAccumulator::add: time " + std::to_string(time_s) + " s after " + std::to_string(last_time_) +
                  " s in the same run, expected finite times increasing within a run (begin_run() for a new recording)");
    last_time_ = time_s;
    ++frames_;
    std::array<bool, hand::kFingerCount> valid{};
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      valid[f] = true;
      for (std::size_t m = 0; m < hand::kFingerCount; ++m) {
        const std::size_t d = hand::kDofIndex[f][m];
        valid[f] = valid[f] && std::isfinite(predicted[d]) && std::isfinite(truth[d]);
      }
    }
    // A digit's tip moves with its own DoFs only (the palm carries none of the 25), so a
    // non-finite angle elsewhere is replaced by 0 for the kinematics and the digit is not scored.
    hand::Angles p = predicted, t = truth;
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      if (!valid[static_cast<std::size_t>(hand::kDofs[d].finger)]) p[d] = t[d] = 0.0;
    const auto pred_tips = fingertip_positions(kinematics_, p), true_tips = fingertip_positions(kinematics_, t);
    const hand::PinchDistances true_distances = hand::pinch_distances(true_tips), pred_distances = hand::pinch_distances(pred_tips);
    bool all = true;
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      if (!valid[f]) {
        all = false;
        continue;
      }
      tip_errors_[f].push_back((pred_tips[f] - true_tips[f]).norm());
    }
    for (std::size_t k = 0; k < kPinchPairCount; ++k) {
      const std::size_t f = k + 1;
      PairState& s = state_[k];
      if (!valid[0] || !valid[f]) {
        s = PairState{};  // unknown: the next scored frame starts no onset
        continue;
      }
      const double d_true = true_distances[k], d_pred = pred_distances[k];
      Pair& pair = pairs_[k];
      pair.distance_errors.push_back(std::abs(d_pred - d_true));
      const bool was_true = s.known && s.true_on, was_pred = s.known && s.pred_on;
      const bool true_on = hand::pinch_next(was_true, d_true, rule_);
      const bool pred_on = hand::pinch_next(was_pred, d_pred, rule_);
      pair.true_frames += true_on;
      pair.predicted_frames += pred_on;
      pair.both_frames += true_on && pred_on;
      if (true_on) {
        pair.pinch_tip_error_sum += (pred_tips[0] - true_tips[0]).norm() + (pred_tips[f] - true_tips[f]).norm();
        pair.pinch_distance_error_sum += std::abs(d_pred - d_true);
      }
      if (s.known && true_on && !s.true_on) pair.true_onsets.push_back({run_, time_s});
      if (s.known && pred_on && !s.pred_on) pair.predicted_onsets.push_back({run_, time_s});
      s = PairState{true, true_on, pred_on};
    }
    return all;
  }

  /// @brief Frames added so far.
  std::size_t frames() const noexcept { return frames_; }
  /// @brief Whether no frame scored any fingertip (report() would throw).
  bool empty() const noexcept {
    return std::all_of(tip_errors_.begin(), tip_errors_.end(), [](const std::vector<double>& e) { return e.empty(); });
  }

  /// @brief The measures over every frame so far. Throws glovepose::Error when no frame scored any
  /// fingertip.
  FingertipReport report() const {
    if (empty())
      throw Error("FingertipAccumulator::report: no fingertip scored in " + std::to_string(frames_) +
                  " frames, expected at least one frame with a digit's predicted and true angles finite");
    FingertipReport r;
    r.frames = frames_;
    r.config = config_;
    std::vector<double> pooled;
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      r.tips[f] = summarize(hand::to_string(static_cast<hand::Finger>(f)), tip_errors_[f]);
      pooled.insert(pooled.end(), tip_errors_[f].begin(), tip_errors_[f].end());
    }
    r.all = summarize("all", pooled);
    // The pairs pooled: their frames and distance errors, and each pair's onsets as matched within it.
    Pair all;
    std::vector<double> latencies_all;
    for (std::size_t k = 0; k < kPinchPairCount; ++k) {
      const Pair& pair = pairs_[k];
      r.pinches[k] = score(hand::to_string(static_cast<hand::Finger>(k + 1)), pair, latencies_all);
      all.distance_errors.insert(all.distance_errors.end(), pair.distance_errors.begin(), pair.distance_errors.end());
      all.true_frames += pair.true_frames;
      all.predicted_frames += pair.predicted_frames;
      all.both_frames += pair.both_frames;
      all.pinch_tip_error_sum += pair.pinch_tip_error_sum;
      all.pinch_distance_error_sum += pair.pinch_distance_error_sum;
    }
    std::vector<double> none;
    r.all_pinches = score("all", all, none);
    for (const PinchScore& s : r.pinches) {
      r.all_pinches.onsets += s.onsets;
      r.all_pinches.detected_onsets += s.detected_onsets;
      r.all_pinches.missed_onsets += s.missed_onsets;
      r.all_pinches.false_onsets += s.false_onsets;
    }
    latency_stats(latencies_all, r.all_pinches);
    return r;
  }

 private:
  struct Onset {
    std::size_t run;
    double time;
  };
  struct Pair {
    std::vector<double> distance_errors;
    std::size_t true_frames = 0, predicted_frames = 0, both_frames = 0;
    double pinch_tip_error_sum = 0.0, pinch_distance_error_sum = 0.0;  // over the true pinching frames (tips: two per frame)
    std::vector<Onset> true_onsets, predicted_onsets;  // in time order within each run, runs in order
  };
  struct PairState {
    bool known = false;  // whether the previous frame of the run scored the pair
    bool true_on = false;
    bool pred_on = false;
  };

  static TipErrorSummary summarize(const char* name, const std::vector<double>& errors) {
    TipErrorSummary s;
    s.finger = name;
    s.frames = errors.size();
    if (errors.empty()) return s;
    double sum = 0.0;
    for (double e : errors) sum += e;
    s.mean_mm = sum / static_cast<double>(errors.size());
    s.median_mm = core::percentile(errors, 0.5);
    s.p95_mm = core::percentile(errors, 0.95);
    s.max_mm = *std::max_element(errors.begin(), errors.end());
    return s;
  }

  static void latency_stats(const std::vector<double>& latencies_s, PinchScore& s) {
    if (latencies_s.empty()) return;
    double sum = 0.0;
    for (double l : latencies_s) sum += l;
    s.latency_mean_ms = 1e3 * sum / static_cast<double>(latencies_s.size());
    s.latency_median_ms = 1e3 * core::percentile(latencies_s, 0.5);
  }

  // Frame counts, distance errors and (for one pair) the onsets matched: each true onset, in time
  // order, takes the earliest unmatched predicted onset of its run within the window either side.
  // Appends the latencies (s) to `all_latencies`.
  PinchScore score(const char* name, const Pair& pair, std::vector<double>& all_latencies) const {
    std::vector<double> latencies;
    PinchScore s;
    s.finger = name;
    s.frames = pair.distance_errors.size();
    if (!pair.distance_errors.empty()) {
      double sum = 0.0;
      for (double e : pair.distance_errors) sum += e;
      s.distance_error_mean_mm = sum / static_cast<double>(pair.distance_errors.size());
      s.distance_error_p95_mm = core::percentile(pair.distance_errors, 0.95);
    }
    s.true_frames = pair.true_frames;
    s.predicted_frames = pair.predicted_frames;
    s.both_frames = pair.both_frames;
    if (pair.predicted_frames > 0) s.precision = static_cast<double>(pair.both_frames) / static_cast<double>(pair.predicted_frames);
    if (pair.true_frames > 0) {
      s.recall = static_cast<double>(pair.both_frames) / static_cast<double>(pair.true_frames);
      s.pinch_tip_error_mean_mm = pair.pinch_tip_error_sum / (2.0 * static_cast<double>(pair.true_frames));
      s.pinch_distance_error_mean_mm = pair.pinch_distance_error_sum / static_cast<double>(pair.true_frames);
    }
    const double window = config_.onset_window_s;
    std::vector<bool> used(pair.predicted_onsets.size(), false);
    std::size_t first = 0;  // predicted onsets before it are of earlier runs or too early for every later true onset
    for (const Onset& t : pair.true_onsets) {
      ++s.onsets;
      while (first < pair.predicted_onsets.size() &&
             (pair.predicted_onsets[first].run < t.run ||
              (pair.predicted_onsets[first].run == t.run && pair.predicted_onsets[first].time < t.time - window)))
        ++first;
      bool found = false;
      for (std::size_t j = first; j < pair.predicted_onsets.size(); ++j) {
        const Onset& p = pair.predicted_onsets[j];
        if (p.run != t.run || p.time > t.time + window) break;
        if (used[j]) continue;
        used[j] = true;
        latencies.push_back(p.time - t.time);
        found = true;
        break;
      }
      ++(found ? s.detected_onsets : s.missed_onsets);
    }
    s.false_onsets = static_cast<std::size_t>(std::count(used.begin(), used.end(), false));
    latency_stats(latencies, s);
    all_latencies.insert(all_latencies.end(), latencies.begin(), latencies.end());
    return s;
  }

  FingertipConfig config_;
  hand::PinchRule rule_;
  hand::Kinematics kinematics_;
  std::size_t run_ = 0;
  double last_time_ = -INFINITY;
  std::size_t frames_ = 0;
  std::array<std::vector<double>, hand::kFingerCount> tip_errors_;
  std::array<Pair, kPinchPairCount> pairs_;
  std::array<PairState, kPinchPairCount> state_{};
};

}  // namespace glovepose::train
