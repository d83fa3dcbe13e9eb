/// @file device_clock.hpp
/// @brief A device's clock mapped onto the host's, from the frames' device times and their arrival
/// times: host = device + offset + drift x (device - reference). A frame arrives after it was sent,
/// never before, so within each bin of device time (1 s by default) the arrival with the smallest
/// host - device is the one least delayed; a line fitted by least squares through the last bins'
/// minima (32 by default) gives the offset and the drift, and follows a drift that changes with the
/// device's temperature. The delay every frame has (the link's shortest transfer) cannot be told
/// apart from the offset: it is in it, so mapped times are arrival times of an undelayed frame.
/// Per-frame calls are noexcept and allocation-free.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "../config.hpp"

namespace glovepose::device {

/// @brief Maps device microseconds onto host seconds (of a monotonic host clock).
class DeviceClock {
 public:
  /// @brief `bin_seconds`: the device time over which one least-delayed arrival is kept; `bins`: how
  /// many bins the line is fitted to (at least 2). Throws Error for other values.
  explicit DeviceClock(double bin_seconds = 1.0, std::size_t bins = 32) : bin_seconds_(bin_seconds) {
    if (!(bin_seconds > 0.0) || !std::isfinite(bin_seconds))
      throw Error("DeviceClock: bin of " + std::to_string(bin_seconds) + " s, expected a finite length above 0");
    if (bins < 2) throw Error("DeviceClock: " + std::to_string(bins) + " bins, expected at least 2");
    minima_.resize(bins);
  }

  /// @brief One frame: its device time and the host time it arrived. A device time earlier than the
  /// last one means the device restarted: the mapping starts again from this frame.
  GLOVEPOSE_REALTIME void add(std::uint64_t device_time_us, double host_seconds) noexcept {
    if (!std::isfinite(host_seconds)) return;
    if (count_ == 0 || device_time_us < last_device_us_) {
      reset();
      reference_us_ = device_time_us;
    }
    last_device_us_ = device_time_us;
    ++count_;
    const double x = device_seconds(device_time_us);
    const double y = host_seconds - x;
    const auto bin = static_cast<std::int64_t>(std::floor(x / bin_seconds_));
    if (bin != current_bin_) {
      if (current_bin_ >= 0) {  // the finished bin's least-delayed arrival joins the fit
        minima_[next_] = current_;
        next_ = (next_ + 1) % minima_.size();
        if (kept_ < minima_.size()) ++kept_;
      }
      current_bin_ = bin;
      current_ = Point{x, y};
      fit();
    } else if (y < current_.y) {
      current_ = Point{x, y};
      if (kept_ < 3) fit();
    }
  }

  /// @brief The host time of a device time; NaN before the first frame.
  GLOVEPOSE_REALTIME double to_host(std::uint64_t device_time_us) const noexcept {
    if (count_ == 0) return std::nan("");
    const double x = device_seconds(device_time_us);
    return x + offset_ + drift_ * x;
  }

  /// @brief Host seconds per device second, minus 1 (1e-4: the device's clock runs 100 ppm slow).
  double drift() const noexcept { return drift_; }
  /// @brief host - device at the first frame's device time, seconds (the shortest delay included).
  double offset() const noexcept { return offset_; }
  /// @brief Frames taken since the last restart.
  std::uint64_t frames() const noexcept { return count_; }

  /// @brief Forgets everything (a new device).
  void reset() noexcept {
    count_ = 0;
    kept_ = next_ = 0;
    current_bin_ = -1;
    offset_ = drift_ = 0.0;
  }

 private:
  struct Point {
    double x = 0.0, y = 0.0;
  };

  double device_seconds(std::uint64_t device_time_us) const noexcept {
    return device_time_us >= reference_us_ ? static_cast<double>(device_time_us - reference_us_) * 1e-6
                                           : -static_cast<double>(reference_us_ - device_time_us) * 1e-6;
  }

  // Least squares through the finished bins' minima. The current bin's minimum stays out once three
  // bins are finished: early in a bin it is a poor estimate, and at the end of the line it would tilt
  // it. Before that the drift is 0 and the offset the smallest host - device yet.
  void fit() noexcept {
    if (kept_ < 3) {
      double lowest = current_.y;
      for (std::size_t i = 0; i < kept_; ++i) lowest = std::min(lowest, minima_[i].y);
      drift_ = 0.0;
      offset_ = lowest;
      return;
    }
    double mx = 0.0, my = 0.0;
    for (std::size_t i = 0; i < kept_; ++i) mx += minima_[i].x, my += minima_[i].y;
    mx /= static_cast<double>(kept_);
    my /= static_cast<double>(kept_);
    double sxx = 0.0, sxy = 0.0;
    for (std::size_t i = 0; i < kept_; ++i) {
      sxx += (minima_[i].x - mx) * (minima_[i].x - mx);
      sxy += (minima_[i].x - mx) * (minima_[i].y - my);
    }
    drift_ = sxx > 0.0 ? sxy / sxx : 0.0;
    offset_ = my - drift_ * mx;
  }

  double bin_seconds_;
  std::vector<Point> minima_;
  std::size_t kept_ = 0, next_ = 0;
  std::int64_t current_bin_ = -1;
  Point current_;
  std::uint64_t reference_us_ = 0, last_device_us_ = 0, count_ = 0;
  double offset_ = 0.0, drift_ = 0.0;
};

}  // namespace glovepose::device
