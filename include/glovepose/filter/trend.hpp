/// @file trend.hpp
/// @brief The recent course of N channels (e.g. the 25 angles of the latest poses): values between
/// two samples by linear interpolation, and the rate of change as the least-squares slope over a
/// time window, which a caller extrapolates to predict a little ahead.
///
/// Why a fitted slope: the newest poses differ by the network's frame-to-frame noise as much as by
/// the motion, so the difference of the last two poses is mostly noise at several hundred poses a
/// second; a line through the poses of the last few tens of milliseconds keeps the motion and
/// averages the noise (docs/results.md, "Poses at a requested time", measures the window). The
/// slope is fitted when asked for, so adding a sample costs a copy.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

#include "../config.hpp"
#include "../status.hpp"

namespace glovepose::filter {

/// @brief The last up to Capacity samples of N channels and their fitted slope.
template <std::size_t N, std::size_t Capacity = 128>
class Trend {
  static_assert(Capacity >= 2, "a slope needs two samples");

 public:
  /// @brief The values of one sample.
  using Values = std::array<double, N>;

  /// @brief A trend whose slope is fitted over the samples of the last `window` seconds (at least
  /// the two newest; at most Capacity).
  explicit Trend(double window = 0.15) noexcept : window_(window) {}

  /// @brief Seconds the slope is fitted over.
  double window() const noexcept { return window_; }
  /// @brief Samples held.
  std::size_t size() const noexcept { return count_; }
  /// @brief Timestamp of the newest sample (NaN when empty).
  double newest_time() const noexcept { return count_ ? time_[index(0)] : std::nan(""); }
  /// @brief Timestamp of the oldest sample held (NaN when empty).
  double oldest_time() const noexcept { return count_ ? time_[index(count_ - 1)] : std::nan(""); }
  /// @brief The newest sample's values.
  const Values& newest() const noexcept { return values_[index(0)]; }
  /// @brief Whether slope() comes from at least two samples.
  bool has_slope() const noexcept { return count_ >= 2; }

  /// @brief The rate of change per second: the least-squares slope through the samples within the
  /// window (at least the two newest); zero with fewer than two samples.
  GLOVEPOSE_REALTIME Values slope() const noexcept {
    Values slope{};
    if (!has_slope()) return slope;
    // Closed form n Stv - St Sv over n Stt - St^2 (times and values about the reference sample).
    const double count = static_cast<double>(in_window_);
    const double denominator = count * sum_tt_ - sum_t_ * sum_t_;
    for (std::size_t c = 0; c < N; ++c) {
      slope[c] = (count * sum_tv_[c] - sum_t_ * sum_v_[c]) / denominator;
      // Timestamps near the ends of the double range overflow the sums: no slope rather than NaN.
      if (!std::isfinite(slope[c])) slope[c] = 0.0;
    }
    return slope;
  }

  /// @brief Samples the slope is fitted over: those of the last window() seconds, at least two.
  std::size_t fitted() const noexcept { return in_window_; }

  /// @brief Forgets every sample.
  void reset() noexcept {
    count_ = in_window_ = 0;
    since_rebase_ = 0;
  }

  /// @brief Adds the newest sample. A timestamp not after the newest, or a non-finite one, starts
  /// the trend over from this sample (a clock restart); non-finite values are refused.
  GLOVEPOSE_REALTIME Status add(double t, const Values& values) noexcept {
    for (double v : values)
      if (!std::isfinite(v)) return Status::NonFinite;
    if (!std::isfinite(t)) return Status::NonFinite;
    if (count_ > 0 && !(t > newest_time())) reset();
    if (in_window_ == Capacity) exclude(index(Capacity - 1));  // the ring is about to overwrite it
    head_ = (head_ + 1) % Capacity;
    time_[head_] = t;
    values_[head_] = values;
    count_ = std::min(count_ + 1, Capacity);
    ++in_window_;
    while (in_window_ > 2 && t - time_[index(in_window_ - 1)] > window_) exclude(index(in_window_ - 1));
    // Recomputed when the reference has left the window (differences to it stay within the
    // window's span, against cancellation) or every Capacity additions (rounding).
    if (++since_rebase_ >= Capacity || in_window_ == 1 || !(time_[index(in_window_ - 1)] <= reference_t_))
      rebase();
    else
      include(head_);
    return Status::Ok;
  }

  /// @brief The values at time t: interpolated between the two samples around it, the oldest
  /// sample's before it, and extrapolated along slope() after the newest (the caller bounds how
  /// far). Status::NotReady when empty, NonFinite for a non-finite t.
  GLOVEPOSE_REALTIME Status at(double t, Values& out) const noexcept {
    if (count_ == 0) return Status::NotReady;
    if (!std::isfinite(t)) return Status::NonFinite;
    const double newest_t = newest_time();
    if (t >= newest_t) {
      const Values& last = newest();
      const Values rate = slope();
      for (std::size_t c = 0; c < N; ++c) out[c] = last[c] + rate[c] * (t - newest_t);
      return Status::Ok;
    }
    for (std::size_t k = 1; k < count_; ++k) {
      const std::size_t older = index(k), newer = index(k - 1);
      if (t >= time_[older]) {
        double w = (t - time_[older]) / (time_[newer] - time_[older]);
        if (!(w >= 0.0 && w <= 1.0)) w = 1.0;  // a time difference overflowed: the newer sample
        for (std::size_t c = 0; c < N; ++c) out[c] = values_[older][c] + w * (values_[newer][c] - values_[older][c]);
        return Status::Ok;
      }
    }
    out = values_[index(count_ - 1)];
    return Status::Ok;
  }

 private:
  // Position in the ring of the k-th newest sample.
  std::size_t index(std::size_t k) const noexcept { return (head_ + Capacity - k) % Capacity; }

  // Adds ring sample k to the sums / takes it out of them (and out of the window).
  void include(std::size_t k) noexcept { accumulate(k, 1.0); }
  void exclude(std::size_t k) noexcept {
    accumulate(k, -1.0);
    --in_window_;
  }
  void accumulate(std::size_t k, double sign) noexcept {
    const double dt = time_[k] - reference_t_;
    sum_t_ += sign * dt;
    sum_tt_ += sign * dt * dt;
    for (std::size_t c = 0; c < N; ++c) {
      const double v = values_[k][c] - reference_v_[c];
      sum_v_[c] += sign * v;
      sum_tv_[c] += sign * dt * v;
    }
  }

  // The sums afresh over the window, about the newest sample.
  void rebase() noexcept {
    since_rebase_ = 0;
    reference_t_ = time_[head_];
    reference_v_ = values_[head_];
    sum_t_ = sum_tt_ = 0.0;
    sum_v_ = Values{};
    sum_tv_ = Values{};
    for (std::size_t n = 0; n < in_window_; ++n) accumulate(index(n), 1.0);
  }

  double window_;
  std::array<double, Capacity> time_{};
  std::array<Values, Capacity> values_{};
  std::size_t head_ = Capacity - 1;
  std::size_t count_ = 0;
  std::size_t in_window_ = 0;     // the newest samples the sums cover
  std::size_t since_rebase_ = 0;  // additions since the sums were last recomputed
  double reference_t_ = 0.0;
  Values reference_v_{};
  double sum_t_ = 0.0, sum_tt_ = 0.0;
  Values sum_v_{}, sum_tv_{};
};

}  // namespace glovepose::filter
