/// @file one_euro.hpp
/// @brief The 1-euro filter (Casiez, Roussel, Vogel, CHI 2012) for a fixed number of channels,
/// e.g. the 25 joint angles: a low-pass filter whose cutoff rises with speed, so slow motion is
/// smoothed (less jitter) and fast motion is followed (less lag). The paper filters its live poses
/// with it (Sec. 3.1).
///
/// Matches the authors' reference implementation (public repository casiez/OneEuroFilter): the first
/// sample passes unchanged with derivative 0; the derivative is taken against the previous
/// *filtered* value, dx = (x - x_prev_filtered) * freq; alpha = 1 / (1 + tau / Te) with
/// tau = 1 / (2 pi cutoff), Te = 1 / freq; cutoff = min_cutoff + beta * |filtered derivative|; and
/// freq = 1 / (t - t_prev) is updated only when t > t_prev. tests/test_one_euro.cpp checks it
/// against the authors' conformance vectors.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>

#include "../config.hpp"
#include "../core/units.hpp"
#include "../status.hpp"
#include "one_euro_config.hpp"

namespace glovepose::filter {

/// @brief A 1-euro filter over N channels sharing one clock.
template <std::size_t N>
class OneEuroFilter {
 public:
  /// @brief The values of one sample.
  using Values = std::array<double, N>;

  /// @brief A filter with these settings. Throws glovepose::Error when a frequency or cutoff is not
  /// positive or beta is negative.
  explicit OneEuroFilter(OneEuroConfig config = {}) : config_(config) {
    const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
    if (!positive(config_.frequency) || !positive(config_.min_cutoff) || !positive(config_.d_cutoff))
      throw Error("OneEuroFilter: frequency " + std::to_string(config_.frequency) + ", min_cutoff " + std::to_string(config_.min_cutoff) +
                  ", d_cutoff " + std::to_string(config_.d_cutoff) + ", expected all finite and > 0");
    if (!std::isfinite(config_.beta) || config_.beta < 0.0)
      throw Error("OneEuroFilter: beta " + std::to_string(config_.beta) + ", expected finite and >= 0");
    reset();
  }

  /// @brief Forgets the history: the next sample passes unchanged.
  void reset() noexcept {
    frequency_ = config_.frequency;
    last_time_ = -std::numeric_limits<double>::infinity();
    started_.fill(false);
    filtered_.fill(0.0);
    derivative_.fill(0.0);
  }

  /// @brief Filters one sample taken at `timestamp` (seconds) into `out`.
  ///
  /// A non-finite or backwards timestamp rejects the whole sample (Status::NonFinite /
  /// Status::TimestampBackwards); a non-finite value rejects that channel (Status::NonFinite). A
  /// rejected channel is not mixed into the state and `out` holds its last filtered value.
  GLOVEPOSE_REALTIME Status filter(const Values& in, double timestamp, Values& out) noexcept {
    out = filtered_;
    if (!std::isfinite(timestamp)) return Status::NonFinite;
    if (timestamp < last_time_) return Status::TimestampBackwards;
    if (timestamp > last_time_ && std::isfinite(last_time_)) frequency_ = 1.0 / (timestamp - last_time_);
    last_time_ = timestamp;

    Status status = Status::Ok;
    const double alpha_d = alpha(config_.d_cutoff);
    for (std::size_t i = 0; i < N; ++i) {
      const double x = in[i];
      if (!std::isfinite(x)) {
        status = Status::NonFinite;
        continue;
      }
      if (!started_[i]) {
        started_[i] = true;
        filtered_[i] = x;
        derivative_[i] = 0.0;
      } else {
        const double dx = (x - filtered_[i]) * frequency_;
        derivative_[i] = alpha_d * dx + (1.0 - alpha_d) * derivative_[i];
        const double a = alpha(config_.min_cutoff + config_.beta * std::abs(derivative_[i]));
        filtered_[i] = a * x + (1.0 - a) * filtered_[i];
      }
      out[i] = filtered_[i];
    }
    return status;
  }

  /// @brief The settings in use.
  const OneEuroConfig& config() const noexcept { return config_; }

 private:
  double alpha(double cutoff) const noexcept {
    const double tau = 1.0 / (2.0 * core::kPi * cutoff);
    const double te = 1.0 / frequency_;
    return 1.0 / (1.0 + tau / te);
  }

  OneEuroConfig config_;
  double frequency_ = 0.0;
  double last_time_ = 0.0;
  std::array<bool, N> started_{};
  Values filtered_{};
  Values derivative_{};
};

}  // namespace glovepose::filter
