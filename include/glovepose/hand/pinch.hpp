/// @file pinch.hpp
/// @brief The one definition of a pinch, shared by evaluation (train/fingertip_metrics.hpp) and the
/// live pinch and aim state an engine reads (hand/xr_hand.hpp, XR_FB_hand_tracking_aim):
/// - the distance: between the thumb's tip point and a finger's (the ends of the distal phalanxes,
///   Kinematics::fingertip), mm, for the four pairs thumb-index, -middle, -ring, -pinky;
/// - the flag: a pinch starts when that distance falls below kPinchThresholdMm (15 mm) and ends
///   when it rises to kPinchReleaseMm (18 mm); in between it keeps its state (hysteresis: a
///   distance hovering at 15 mm makes one onset, not a train of them);
/// - the strength: 1 at or below the threshold, 0 at or beyond kPinchFarMm (40 mm), a smoothstep
///   in between (pinch_strength).
///
/// Why 15 mm. Tip points are the ends of the distal phalanx bones, inside the fingertips: two tips
/// touch when their points are the two tip radii apart, 11.2-12.6 mm on the reference hand
/// (kReferenceDistalRadius; thumb with pinky .. middle). The gallery's pinch poses
/// (sim/pose_gallery.hpp: pinch_index, pinch_middle, pinch_ring, pinch_pinky, ok, key_grip, the
/// thumb solved to contact) put them 12.0-14.4 mm apart; the nearest gallery pose that is not a
/// pinch, flat_bent, 20.3 mm (thumb-index). 15 mm is above every gallery contact and 5 mm below
/// the closest non-pinch; the release at 18 mm keeps a distance hovering at the threshold from
/// making a train of onsets. docs/results.md, "Fingertips and pinches", has the measurement.
///
/// Why the strength curve. XR_FB_hand_tracking_aim defines a pinch strength of 1.0 as thumb and
/// finger fully touching; here that is the threshold, where the flag turns on (every gallery
/// contact lies below it), so a strength of 1 and the flag's onset agree. 0 at 40 mm: the
/// shipped model's thumb-index distance is off by 8.1 mm on average and 20.8 mm at the 95th
/// percentile (docs/results.md), so a ramp much shorter than that 20-25 mm would turn the
/// estimate's noise into a strength jumping between 0 and 1; 40 mm = 15 mm + 25 mm spans it, and
/// every gallery pose that is neither a pinch nor flat_bent (20.3 mm) still reads 0 on all four
/// pairs (the nearest: tap_index's thumb and index, 40.1 mm; thumbs_up's, 45.7-49.3 mm; open and
/// flat hands 50-130 mm). A smoothstep, 3u^2 - 2u^3, has no kink at either end, so a cursor
/// or a highlight driven by it starts and stops moving gently; it is monotone, so a closer pinch
/// never reads weaker.
///
/// Per frame everything here is noexcept and allocation-free; PinchRule::validate (set-up) throws
/// glovepose::Error.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <string>

#include <Eigen/Geometry>

#include "../config.hpp"
#include "dofs.hpp"
#include "kinematics.hpp"
#include "pinch_rule.hpp"

namespace glovepose::hand {

/// @brief The five tip points (Kinematics::fingertip, the frame `skeleton` was posed in), thumb to pinky.
GLOVEPOSE_REALTIME inline std::array<Eigen::Vector3d, kFingerCount> fingertip_positions(const Kinematics& kinematics,
                                                                                        const Skeleton& skeleton) noexcept {
  std::array<Eigen::Vector3d, kFingerCount> tips;
  for (std::size_t f = 0; f < kFingerCount; ++f) tips[f] = kinematics.fingertip(skeleton, static_cast<Finger>(f));
  return tips;
}

/// @brief The five tip points (mm, the hand's root frame) of a pose, thumb to pinky.
GLOVEPOSE_REALTIME inline std::array<Eigen::Vector3d, kFingerCount> fingertip_positions(const Kinematics& kinematics,
                                                                                        const Angles& angles) noexcept {
  Skeleton skeleton;
  kinematics.pose(angles, skeleton);
  return fingertip_positions(kinematics, skeleton);
}

/// @brief Thumb-tip-to-fingertip distances (same unit as the tips) of the four pairs.
GLOVEPOSE_REALTIME inline PinchDistances pinch_distances(const std::array<Eigen::Vector3d, kFingerCount>& tips) noexcept {
  PinchDistances d{};
  for (std::size_t k = 0; k < kPinchPairCount; ++k) d[k] = (tips[0] - tips[k + 1]).norm();
  return d;
}

/// @brief Thumb-tip-to-fingertip distances (mm) of a pose (radians) on `kinematics`' hand.
GLOVEPOSE_REALTIME inline PinchDistances pinch_distances(const Kinematics& kinematics, const Angles& angles) noexcept {
  return pinch_distances(fingertip_positions(kinematics, angles));
}

/// @brief One frame's pinch state: per pair, the distance, the strength and the flag.
struct PinchState {
  PinchDistances distance_mm{};                   ///< Thumb tip to fingertip, mm (NaN when not known).
  std::array<float, kPinchPairCount> strength{};  ///< pinch_strength of the distance, [0, 1].
  PinchFlags pinching{};                          ///< The hysteresis flag.
};

/// @brief The pinch flags of one hand over time: the hysteresis state of the four pairs. Per frame
/// noexcept and allocation-free.
class PinchTracker {
 public:
  /// @brief A tracker with the given rule (validated: throws glovepose::Error).
  explicit PinchTracker(const PinchRule& rule = {}) : rule_(rule) { rule_.validate(); }

  /// @brief The rule.
  const PinchRule& rule() const noexcept { return rule_; }

  /// @brief The next frame's state from its distances (mm). A pair whose distance is not finite
  /// reads strength 0, not pinching, and starts over (off) on the next frame.
  GLOVEPOSE_REALTIME PinchState update(const PinchDistances& distance_mm) noexcept {
    PinchState s;
    s.distance_mm = distance_mm;
    for (std::size_t k = 0; k < kPinchPairCount; ++k) {
      on_[k] = pinch_next(on_[k], distance_mm[k], rule_);
      s.pinching[k] = on_[k];
      s.strength[k] = static_cast<float>(pinch_strength(distance_mm[k], rule_));
    }
    return s;
  }

  /// @brief update() from a pose (radians) on `kinematics`' hand.
  GLOVEPOSE_REALTIME PinchState update(const Kinematics& kinematics, const Angles& angles) noexcept {
    return update(pinch_distances(kinematics, angles));
  }

  /// @brief The flags after the last update.
  const PinchFlags& pinching() const noexcept { return on_; }

  /// @brief Forgets the state: every pair off.
  void reset() noexcept { on_ = PinchFlags{}; }

 private:
  PinchRule rule_;
  PinchFlags on_{};
};

}  // namespace glovepose::hand
