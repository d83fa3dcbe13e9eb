/// @file keypoint_labels.hpp
/// @brief Training labels from a hand tracker recording beside the glove: its 3D keypoints
/// (hand/keypoints.hpp layouts) become the 25 angles at the glove's frames.
///
/// Per take: every tracker frame is fitted by inverse kinematics (hand/keypoint_fit.hpp) on the
/// person's fitted hand; a frame is trusted when every keypoint of the labelled digits is seen and
/// its fit residual is at most max(trusted_rms_mm, 3 x the take's median residual). The angles are
/// smoothed without lag (a Gaussian in time over the trusted frames). The tracker's clock is then
/// placed on the glove's: a given offset, or the lag that best correlates the hand's motion seen by
/// both (the glove's cells' frame-to-frame change against the fitted angles' speed, each normalised
/// per channel). Each glove frame takes the angles interpolated at its time on the tracker's clock;
/// a glove frame outside the tracked span, or between frames not trusted or too far apart, gets no
/// label (not trusted).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "../config.hpp"
#include "../core/statistics.hpp"
#include "../hand/dofs.hpp"
#include "../hand/keypoint_fit.hpp"
#include "../hand/keypoints.hpp"

namespace glovepose::train {

/// @brief One take's keypoints as the tracker reported them.
struct KeypointTrack {
  std::vector<double> times;                ///< The tracker's clock, seconds, increasing.
  std::vector<Eigen::Vector3d> points;      ///< times.size() x the layout's count, mm; NaN: not seen.
};

/// @brief How keypoints become labels.
struct KeypointLabelConfig {
  double smoothing_seconds = 0.08;   ///< SD of the lag-free Gaussian smoothing of the angles (0: none).
  double max_offset_seconds = 5.0;   ///< Clock offsets searched: within +- this.
  std::optional<double> offset;      ///< Known offset (glove time = tracker time + offset): no search.
  /// The glove's own response delay: how long after a motion its cells show it (a readout that
  /// averages readings lags by half its window). The search aligns the motion the cells show, so
  /// this is taken off its lag: the labels then describe the hand at each frame's time stamp.
  double glove_delay_seconds = 0.0;
  double trusted_rms_mm = 10.0;      ///< A frame's fit residual up to which it is always trusted.
  double min_correlation = 0.3;      ///< Clock search: the best lag's correlation at least this.
  hand::KeypointIkConfig ik;         ///< The per-frame fit.
};

/// @brief Where the tracker's clock sits on the glove's.
struct ClockAlignment {
  double offset = 0.0;       ///< Glove time = tracker time + offset, seconds.
  double correlation = NAN;  ///< Correlation of the two motion signals at that offset (NaN: given, not searched).
  double runner_up = NAN;    ///< Best correlation at offsets more than 0.5 s away from it.
};

/// @brief One take's labels at the glove's frames.
struct TakeLabels {
  std::vector<float> angles;          ///< Glove frames x 25, radians; NaN for unlabelled DoFs and untrusted frames.
  std::vector<std::uint8_t> trusted;  ///< Per glove frame: 1 when it has a label.
  std::vector<double> frame_rms_mm;   ///< Per glove frame: the larger fit residual of the two tracker frames it lies between (NaN: none).
  ClockAlignment clock;
  std::vector<double> rms_mm;         ///< Per tracker frame: the fit residual (NaN: too few keypoints).
  std::size_t tracker_trusted = 0;    ///< Tracker frames trusted.
  double rms_threshold_mm = 0.0;      ///< The residual above which a tracker frame was not trusted.
};

/// @brief The DoFs a layout's keypoints label when only the keypoints in `present` are reported: a
/// digit's DoFs when every keypoint its DoFs move is present.
inline hand::DofSet labelled_by(const hand::KeypointModel& model, const std::array<bool, hand::kMaxKeypoints>& present) {
  std::array<bool, hand::kFingerCount> complete{};
  complete.fill(true);
  for (std::size_t k = 0; k < model.count(); ++k)
    if (const int digit = model.digit_of(k); digit >= 0 && !present[k]) complete[static_cast<std::size_t>(digit)] = false;
  hand::DofSet set{};
  for (std::size_t d = 0; d < hand::kDofCount; ++d) set[d] = complete[static_cast<std::size_t>(hand::kDofs[d].finger)];
  return set;
}

namespace detail {

// Each channel's absolute frame-to-frame change over its median (a robust scale), summed: the
// motion a signal shows at the midpoints of its frames. Values rows x channels.
inline std::vector<double> motion_energy(const std::vector<double>& times, const std::vector<double>& values, std::size_t channels,
                                         const std::vector<std::uint8_t>* use, std::vector<double>& at) {
  const std::size_t n = times.size();
  std::vector<double> energy(n > 1 ? n - 1 : 0, 0.0);
  at.assign(energy.size(), 0.0);
  for (std::size_t i = 0; i + 1 < n; ++i) at[i] = 0.5 * (times[i] + times[i + 1]);
  for (std::size_t c = 0; c < channels; ++c) {
    std::vector<double> change(energy.size(), NAN), finite;
    for (std::size_t i = 0; i + 1 < n; ++i) {
      if (use && (!(*use)[i] || !(*use)[i + 1])) continue;
      change[i] = std::abs(values[(i + 1) * channels + c] - values[i * channels + c]) / (times[i + 1] - times[i]);
      if (std::isfinite(change[i])) finite.push_back(change[i]);
    }
    const double scale = core::percentile(finite, 0.5);
    if (!(scale > 0.0)) continue;  // a channel that does not move says nothing about the clock
    for (std::size_t i = 0; i < energy.size(); ++i) energy[i] += std::isfinite(change[i]) ? change[i] / scale : NAN;
  }
  return energy;
}

// Linear interpolation of (t, v) at x; NaN outside the span or next to a NaN.
inline double interpolate(const std::vector<double>& t, const std::vector<double>& v, double x) {
  if (t.empty() || x < t.front() || x > t.back()) return NAN;
  const auto hi = static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), x) - t.begin());
  if (hi == 0) return v[0];
  const double w = (x - t[hi - 1]) / (t[hi] - t[hi - 1]);
  return (1.0 - w) * v[hi - 1] + w * v[hi];
}

}  // namespace detail

/// @brief The offset (glove time = tracker time + offset) that best correlates the glove's motion
/// (cells, glove frames x cells) with the tracker's (angles, tracker frames x 25, NaN rows not
/// used), searched on the glove's frame spacing within +- max_offset and refined between frames.
/// Throws glovepose::Error when the best correlation is below `min_correlation` or another offset
/// more than 0.5 s away correlates within 10% as well (the clocks cannot be aligned).
inline ClockAlignment align_clocks(const std::vector<double>& glove_times, const std::vector<double>& cells, std::size_t cell_count,
                                   const std::vector<double>& tracker_times, const std::vector<double>& angles, double max_offset,
                                   double min_correlation) {
  std::vector<double> glove_at, tracker_at;
  const std::vector<double> glove = detail::motion_energy(glove_times, cells, cell_count, nullptr, glove_at);
  const std::vector<double> tracker = detail::motion_energy(tracker_times, angles, hand::kDofCount, nullptr, tracker_at);
  std::vector<double> spacing;
  for (std::size_t i = 0; i + 1 < glove_times.size(); ++i) spacing.push_back(glove_times[i + 1] - glove_times[i]);
  const double step = core::percentile(spacing, 0.5);
  if (glove.size() < 10 || tracker.size() < 10 || !(step > 0.0))
    throw Error("clock alignment: " + std::to_string(glove_times.size()) + " glove and " + std::to_string(tracker_times.size()) +
                " tracker frames, expected at least 11 of each");
  const auto lags = static_cast<int>(std::ceil(max_offset / step));
  std::vector<double> score(static_cast<std::size_t>(2 * lags + 1), NAN);
  for (int l = -lags; l <= lags; ++l) {
    const double lag = l * step;
    double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < glove.size(); ++i) {
      const double y = detail::interpolate(tracker_at, tracker, glove_at[i] - lag);
      const double x = glove[i];
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      sx += x, sy += y, sxx += x * x, syy += y * y, sxy += x * y;
      ++n;
    }
    // Half the shorter signal must overlap, or a short chance overlap could win.
    if (n < std::max<std::size_t>(10, std::min(glove.size(), tracker.size()) / 2)) continue;
    const double nn = static_cast<double>(n);
    const double cov = sxy / nn - sx / nn * sy / nn, vx = sxx / nn - sx / nn * sx / nn, vy = syy / nn - sy / nn * sy / nn;
    if (vx > 0 && vy > 0) score[static_cast<std::size_t>(l + lags)] = cov / std::sqrt(vx * vy);
  }
  std::size_t best = score.size();
  for (std::size_t i = 0; i < score.size(); ++i)
    if (std::isfinite(score[i]) && (best == score.size() || score[i] > score[best])) best = i;
  ClockAlignment out;
  if (best == score.size())
    throw Error("clock alignment: the glove's and the tracker's takes do not overlap by half within +-" + std::to_string(max_offset) +
                " s, expected takes of the same motion (or give the offset)");
  out.correlation = score[best];
  out.offset = (static_cast<double>(best) - lags) * step;
  if (best > 0 && best + 1 < score.size() && std::isfinite(score[best - 1]) && std::isfinite(score[best + 1])) {
    const double a = score[best - 1], b = score[best], c = score[best + 1];
    const double curvature = a - 2 * b + c;
    if (curvature < 0) out.offset += 0.5 * (a - c) / curvature * step;
  }
  for (std::size_t i = 0; i < score.size(); ++i)
    if (std::isfinite(score[i]) && std::abs((static_cast<double>(i) - static_cast<double>(best)) * step) > 0.5)
      out.runner_up = std::isfinite(out.runner_up) ? std::max(out.runner_up, score[i]) : score[i];
  if (out.correlation < min_correlation)
    throw Error("clock alignment: the glove's and the tracker's motion correlate at most " + std::to_string(out.correlation) +
                " (offset " + std::to_string(out.offset) + " s), expected at least " + std::to_string(min_correlation) +
                ": the takes may not record the same motion (or give the offset)");
  if (std::isfinite(out.runner_up) && out.runner_up > 0.9 * out.correlation)
    throw Error("clock alignment: offsets " + std::to_string(out.offset) + " s and another more than 0.5 s away correlate alike (" +
                std::to_string(out.correlation) + " vs " + std::to_string(out.runner_up) +
                "), expected one clear offset: record more varied motion (or give the offset)");
  return out;
}

/// @brief Labels one take: `track` fitted by `ik` (the person's hand), smoothed, aligned with the
/// glove's frames (times, cells rows x cell_count) and resampled onto them. `labelled`: the DoFs to
/// label (the others NaN). Throws glovepose::Error when the clocks cannot be aligned.
inline TakeLabels label_take(const hand::KeypointIk& ik, const KeypointTrack& track, const hand::DofSet& labelled,
                             const std::vector<double>& glove_times, const std::vector<double>& cells, std::size_t cell_count,
                             const KeypointLabelConfig& config) {
  constexpr std::size_t D = hand::kDofCount;
  const std::size_t count = ik.model().count();
  const std::size_t frames = track.times.size();
  TakeLabels out;
  // Which keypoints a trusted frame must show: those the labelled DoFs move.
  std::array<bool, hand::kMaxKeypoints> needed{};
  for (std::size_t k = 0; k < count; ++k)
    for (std::size_t d = 0; d < D; ++d) needed[k] = needed[k] || (labelled[d] && ik.model().moves(d, k));

  std::vector<double> angles(frames * D, NAN);
  std::vector<std::uint8_t> seen_all(frames, 0);
  out.rms_mm.assign(frames, NAN);
  hand::Angles previous = hand::JointLimits().rest();
  bool have_previous = false;
  for (std::size_t f = 0; f < frames; ++f) {
    hand::KeypointPositions observed{};
    bool complete = true;
    for (std::size_t k = 0; k < count; ++k) {
      observed[k] = track.points[f * count + k];
      complete = complete && (!needed[k] || hand::keypoint_seen(observed[k]));
    }
    const hand::KeypointIkResult fit = ik.solve(observed, previous, have_previous ? &previous : nullptr);
    if (!std::isfinite(fit.rms_mm)) continue;
    out.rms_mm[f] = fit.rms_mm;
    seen_all[f] = complete;
    for (std::size_t d = 0; d < D; ++d) angles[f * D + d] = fit.angles[d];
    previous = fit.angles;
    have_previous = true;
  }
  std::vector<double> residuals;
  for (std::size_t f = 0; f < frames; ++f)
    if (seen_all[f]) residuals.push_back(out.rms_mm[f]);
  out.rms_threshold_mm = std::max(config.trusted_rms_mm, 3.0 * core::percentile(residuals, 0.5));
  std::vector<std::uint8_t> trusted(frames, 0);
  for (std::size_t f = 0; f < frames; ++f) {
    trusted[f] = seen_all[f] && out.rms_mm[f] <= out.rms_threshold_mm;
    out.tracker_trusted += trusted[f];
  }

  // Lag-free smoothing over the trusted frames.
  std::vector<double> smooth(frames * D, NAN);
  const double sd = config.smoothing_seconds;
  for (std::size_t f = 0; f < frames; ++f) {
    if (!trusted[f]) continue;
    if (!(sd > 0.0)) {
      for (std::size_t d = 0; d < D; ++d) smooth[f * D + d] = angles[f * D + d];
      continue;
    }
    double weight = 0.0;
    std::array<double, D> sum{};
    for (std::size_t g = f; g < frames && track.times[g] - track.times[f] <= 3 * sd; ++g)
      if (trusted[g]) {
        const double w = std::exp(-0.5 * std::pow((track.times[g] - track.times[f]) / sd, 2));
        weight += w;
        for (std::size_t d = 0; d < D; ++d) sum[d] += w * angles[g * D + d];
      }
    for (std::size_t g = f; g-- > 0 && track.times[f] - track.times[g] <= 3 * sd;)
      if (trusted[g]) {
        const double w = std::exp(-0.5 * std::pow((track.times[f] - track.times[g]) / sd, 2));
        weight += w;
        for (std::size_t d = 0; d < D; ++d) sum[d] += w * angles[g * D + d];
      }
    for (std::size_t d = 0; d < D; ++d) smooth[f * D + d] = sum[d] / weight;
  }

  if (config.offset) {
    out.clock.offset = *config.offset;
  } else {
    out.clock = align_clocks(glove_times, cells, cell_count, track.times, smooth, config.max_offset_seconds, config.min_correlation);
    out.clock.offset -= config.glove_delay_seconds;
  }

  // Resample onto the glove's frames: between two trusted tracker frames no further apart than
  // 2.5 of the tracker's usual spacing.
  std::vector<double> spacing;
  for (std::size_t f = 0; f + 1 < frames; ++f) spacing.push_back(track.times[f + 1] - track.times[f]);
  const double gap = 2.5 * core::percentile(spacing, 0.5);
  const std::size_t n = glove_times.size();
  out.angles.assign(n * D, NAN);
  out.trusted.assign(n, 0);
  out.frame_rms_mm.assign(n, NAN);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = glove_times[i] - out.clock.offset;
    if (frames < 2 || t < track.times.front() || t > track.times.back()) continue;
    std::size_t hi = static_cast<std::size_t>(std::lower_bound(track.times.begin(), track.times.end(), t) - track.times.begin());
    if (hi == 0) hi = 1;
    const std::size_t lo = hi - 1;
    out.frame_rms_mm[i] = std::max(out.rms_mm[lo], out.rms_mm[hi]);  // NaN when either has no fit
    if (std::isnan(out.rms_mm[lo]) || std::isnan(out.rms_mm[hi])) out.frame_rms_mm[i] = NAN;
    if (!trusted[lo] || !trusted[hi] || track.times[hi] - track.times[lo] > gap) continue;
    const double w = (t - track.times[lo]) / (track.times[hi] - track.times[lo]);
    for (std::size_t d = 0; d < D; ++d)
      if (labelled[d]) out.angles[i * D + d] = static_cast<float>((1.0 - w) * smooth[lo * D + d] + w * smooth[hi * D + d]);
    out.trusted[i] = 1;
  }
  return out;
}

}  // namespace glovepose::train
