/// @file input_conditioning.hpp
/// @brief A glove's inputs conditioned before calibration: each input with a window (a glove
/// description's `demean_seconds`, in frames) has the mean of its last readings taken off, a
/// drift-removing high-pass. The same class conditions a dataset's frames for training and
/// evaluation (train/input_conditioning.hpp) and the estimator's frames, so both see the same
/// values, bit for bit, from the same readings.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "../config.hpp"

namespace glovepose::sensor {

/// @brief Per input, the reading less the mean of its last `window` readings (this one included;
/// fewer right after a reset). An input with window 0 passes as it is. Set-up allocates; apply()
/// and reset() do not.
class InputConditioner {
 public:
  /// @brief No input conditioned.
  InputConditioner() = default;
  /// @brief `windows[c]` frames for input c (0: as read; 1 is refused: it would read 0 always).
  explicit InputConditioner(std::vector<int> windows) : windows_(std::move(windows)), sums_(windows_.size(), 0.0) {
    std::size_t at = 0;
    for (std::size_t c = 0; c < windows_.size(); ++c) {
      if (windows_[c] < 0 || windows_[c] == 1)
        throw Error("InputConditioner: input " + std::to_string(c) + " has a window of " + std::to_string(windows_[c]) +
                    " frames, expected 0 (as read) or at least 2");
      starts_.push_back(at);
      at += static_cast<std::size_t>(windows_[c]);
    }
    history_.assign(at, 0.0);
  }

  /// @brief Whether any input is conditioned.
  bool active() const noexcept { return !history_.empty(); }
  /// @brief Inputs it takes per frame (0 when none is conditioned and any count passes).
  std::size_t inputs() const noexcept { return windows_.size(); }

  /// @brief Forgets the readings so far (a new stream: the glove put on again, the clock restarted).
  GLOVEPOSE_REALTIME void reset() noexcept {
    frames_ = 0;
    for (double& s : sums_) s = 0.0;
  }

  /// @brief Conditions one frame of inputs() values from `in` into `out` (they may be the same).
  GLOVEPOSE_REALTIME void apply(const double* in, double* out) noexcept {
    for (std::size_t c = 0; c < windows_.size(); ++c) {
      const double x = in[c];
      const auto window = static_cast<std::size_t>(windows_[c]);
      if (window == 0) {
        out[c] = x;
        continue;
      }
      double& slot = history_[starts_[c] + frames_ % window];
      if (frames_ >= window) sums_[c] -= slot;
      slot = x;
      sums_[c] += x;
      const std::size_t seen = frames_ + 1 < window ? frames_ + 1 : window;
      out[c] = x - sums_[c] / static_cast<double>(seen);
    }
    ++frames_;
  }

 private:
  std::vector<int> windows_;
  std::vector<std::size_t> starts_;  // each input's part of history_
  std::vector<double> history_;      // each input's last readings, a ring per input
  std::vector<double> sums_;         // each input's sum over its ring
  std::size_t frames_ = 0;           // frames since the reset
};

}  // namespace glovepose::sensor
