/// @file donning.hpp
/// @brief Noticing the glove taken off and put on again, from the calibrated cells alone
/// (docs/calibration.md, "Taking the glove off").
///
/// Off the hand the sheet relaxes: no hand stretches it, so most cells read at or below the bottom
/// of their worn range at once. A worn hand rarely does so for long: an open, relaxed hand leaves
/// the cells that sense spread, the web and the back of the hand's width stretched. So the
/// detector watches one number per frame, a high quantile over the cells of their calibrated values
/// (`quantile`: with 0.75, the value three quarters of the cells are at or below): below `off_level`
/// for `off_seconds` the glove is off; above `on_level` for `on_seconds` after that it is on again
/// (a donning). In the fitted world (docs/results.md, "Taking the glove off") a glove lying off
/// the hand sits near -0.9 in the -1..1 units of the calibrated range, a worn hand rarely below
/// -0.7 for long, and the guided sequence's hand pressed flat on a table nearly as low as the
/// glove off the hand (the calibration pauses the detector). It cannot see every removal: on a
/// hand no bigger than the glove's relaxed hand the relaxed sheet reads much like the relaxed hand
/// (3 in 4 removals noticed there; with the continuous calibration none noticed that was not one
/// in 240 worn minutes).
///
/// Per frame: update() is noexcept and allocation-free; the constructor allocates.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../status.hpp"

namespace glovepose::calibration {

/// @brief When the cells say the glove is off the hand, and on again (file comment).
struct DonningConfig {
  double quantile = 0.75;     ///< The quantile over the cells the detector watches (0..1).
  double off_level = -0.8;    ///< Below this (calibrated units, -1..1 the range) the frame looks like a glove off the hand.
  double on_level = -0.7;     ///< Above this it looks worn (between the two levels nothing changes).
  double off_seconds = 3.0;   ///< How long the frames must look off before the glove counts as off.
  double on_seconds = 2.5;    ///< How long they must look worn after that before the glove counts as put on.
  /// A continuous calibration (calibration/free_motion.hpp) is watched only from this many
  /// effective frames of motion on: a younger range cannot tell a glove off the hand from a hand
  /// at the edge of its range.
  double min_motion_frames = 800.0;

  /// @brief Throws glovepose::Error naming the first setting out of range.
  void validate() const {
    if (!(quantile >= 0.0 && quantile <= 1.0) || !std::isfinite(off_level) || !std::isfinite(on_level) || !(on_level >= off_level) ||
        !(off_seconds >= 0.0) || !std::isfinite(off_seconds) || !(on_seconds >= 0.0) || !std::isfinite(on_seconds) ||
        !(min_motion_frames >= 0.0) || !std::isfinite(min_motion_frames))
      throw Error("DonningConfig: quantile " + std::to_string(quantile) + ", off level " + std::to_string(off_level) + ", on level " +
                  std::to_string(on_level) + ", off " + std::to_string(off_seconds) + " s, on " + std::to_string(on_seconds) +
                  " s, min motion frames " + std::to_string(min_motion_frames) +
                  ", expected a quantile in [0, 1], finite levels with on >= off, finite times >= 0 and frames >= 0");
  }
};

/// @brief What a frame changed.
enum class DonningEvent { None, Removed, Donned };

/// @brief The detector's state machine over the frames' quantile (file comment).
class DonningDetector {
 public:
  /// @brief A detector of `cells` cells. Throws glovepose::Error for a bad config or no cells.
  DonningDetector(int cells, DonningConfig config) : config_(config) {
    config_.validate();
    if (cells < 1) throw Error("DonningDetector: " + std::to_string(cells) + " cells, expected at least 1");
    scratch_.resize(static_cast<std::size_t>(cells));
  }

  /// @brief Takes one frame's calibrated cells at `timestamp` (s); returns the event it completes.
  /// Non-finite cells or a clock gone back leave the state as it was and start the timing over.
  GLOVEPOSE_REALTIME DonningEvent update(const double* cells, double timestamp) noexcept {
    if (!std::isfinite(timestamp)) return DonningEvent::None;
    for (std::size_t c = 0; c < scratch_.size(); ++c) {
      if (!std::isfinite(cells[c])) return DonningEvent::None;
      scratch_[c] = cells[c];
    }
    const auto k = static_cast<std::ptrdiff_t>(std::lround(config_.quantile * static_cast<double>(scratch_.size() - 1)));
    std::nth_element(scratch_.begin(), scratch_.begin() + k, scratch_.end());
    level_ = scratch_[static_cast<std::size_t>(k)];
    // The frames must look the other way for the whole time; one that does not starts it over.
    const bool other_way = off_ ? level_ > config_.on_level : level_ < config_.off_level;
    if (!other_way || timestamp < since_) {
      since_ = other_way ? timestamp : std::numeric_limits<double>::infinity();
      return DonningEvent::None;
    }
    if (timestamp - since_ < (off_ ? config_.on_seconds : config_.off_seconds)) return DonningEvent::None;
    off_ = !off_;
    since_ = std::numeric_limits<double>::infinity();
    return off_ ? DonningEvent::Removed : DonningEvent::Donned;
  }

  /// @brief Forgets the state: the glove counts as worn.
  void reset() noexcept {
    off_ = false;
    since_ = std::numeric_limits<double>::infinity();
  }

  /// @brief Whether the glove counts as off the hand now.
  bool off() const noexcept { return off_; }
  /// @brief The watched quantile of the last frame taken.
  double level() const noexcept { return level_; }
  /// @brief The settings.
  const DonningConfig& config() const noexcept { return config_; }

 private:
  DonningConfig config_;
  std::vector<double> scratch_;
  bool off_ = false;
  double since_ = std::numeric_limits<double>::infinity();  // when the frames began to look the other way
  double level_ = 0.0;
};

}  // namespace glovepose::calibration
