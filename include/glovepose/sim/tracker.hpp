/// @file tracker.hpp
/// @brief The reference tracker of a simulated capture: the angles a depth-camera hand tracker would
/// have reported beside the glove (the paper's labels came from Tkach et al. 2017 on a RealSense
/// SR300, Sec. 4.1), not the true angles. Its error is what the paper's numbers are measured against
/// and what every real user trains on:
/// - an error that wanders slowly (one Ornstein-Uhlenbeck process per DoF: the tracker's fit
///   settles differently as the hand turns in front of the camera), larger for the thumb and for
///   strongly flexed fingers, whose phalanges the camera sees edge-on or not at all;
/// - a bias per person (the per-user shape calibration's bone lengths, kept for all their sessions,
///   Sec. 4.1) and per session (where the hand lies in front of the camera, the tracker's start);
/// - the tracker's own collision term: outside a failure these errors do not push fingers into one
///   another beyond a small allowance (the error is shortened until they do not);
/// - failures: a finger snapped onto its neighbour's depth points (both models in the same place,
///   a self-colliding pose: what the paper's collision filter removes, Sec. 4.3), or an occluded
///   finger held where it was last seen;
/// - the tracker's latency and temporal smoothing.
/// Every parameter is an assumption unless docs/simulator.md names a source for it.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "../core/units.hpp"
#include "../calibration/sequence.hpp"
#include "../core/random.hpp"
#include "../hand/collision.hpp"
#include "../hand/dofs.hpp"
#include "../hand/kinematics.hpp"
#include "motion.hpp"
#include "recorder.hpp"

namespace glovepose::sim {

/// @brief What the simulated reference tracker gets wrong. All angles in degrees, times in seconds.
/// A default-constructed config is a perfect tracker (labels = truth).
struct TrackerConfig {
  double flexion_sd = 0.0;        ///< SD of the wandering error of a long finger's flexion DoF.
  double abduction_sd = 0.0;      ///< SD of the wandering error of an abduction DoF.
  double twist_sd = 0.0;          ///< SD of the wandering error of a twist DoF.
  double thumb_factor = 1.0;      ///< The thumb's SDs are this many times the fingers'.
  double occlusion_gain = 0.0;    ///< SD x (1 + gain x the finger's flexion / 90 degrees): flexed fingers are seen worse.
  double correlation_time = 0.5;  ///< Time constant of the wandering error (its autocorrelation is exp(-lag / time)).
  double subject_bias_sd = 0.0;   ///< SD of a person's constant per-DoF bias (shape calibration).
  double session_bias_sd = 0.0;   ///< SD of a session's constant per-DoF bias.
  double snap_rate = 0.0;         ///< Per minute: a finger snapped onto its neighbour.
  double freeze_rate = 0.0;       ///< Per minute: an occluded finger held at its last seen pose.
  double failure_seconds = 0.4;   ///< Mean duration of a failure (exponential, at least one frame).
  double snap_abduction = 20.0;   ///< How far a snapped finger's abduction moves toward its neighbour.
  /// Collision energy (mm^2) a label may reach outside a failure (or the truth's, if higher); beyond
  /// it the error is shortened. Infinite: no collision term.
  double collision_allowance = std::numeric_limits<double>::infinity();
  double latency = 0.0;           ///< The labels describe the hand this long before the frame's time.
  double smoothing = 0.0;         ///< Time constant of the tracker's first-order temporal smoothing.
  /// The wandering error's SDs x (the template hand's length / the person's)^size_power: the depth
  /// camera's error is in millimetres, and a millimetre turns a short phalanx further than a long
  /// one (1: that geometry; 0: every hand alike, the worlds fitted before this effect).
  double size_power = 0.0;
  /// Log-SD of a person's own factor on the wandering error's SDs: how well the tracker follows that
  /// person's hand (distance and angle to the camera, the personalised model's fit). 0: none.
  double subject_noise_spread = 0.0;

  /// @brief Whether the labels differ from the truth at all.
  bool perfect() const noexcept {
    return flexion_sd == 0.0 && abduction_sd == 0.0 && twist_sd == 0.0 && subject_bias_sd == 0.0 && session_bias_sd == 0.0 &&
           snap_rate == 0.0 && freeze_rate == 0.0 && latency == 0.0 && smoothing == 0.0;
  }
};

/// @brief The random streams of one labelled recording: the person's, the session's and the recording's own.
struct TrackerSeeds {
  std::uint64_t subject = 0;    ///< The person's bias.
  std::uint64_t session = 0;    ///< The session's bias (a session and its calibration sequence share it).
  std::uint64_t recording = 0;  ///< The wandering error and the failures.
};

namespace detail {

// The SD (degrees) of DoF d's wandering error before the occlusion term.
inline double tracker_sd(const TrackerConfig& c, std::size_t d) noexcept {
  const hand::Dof& dof = hand::kDofs[d];
  const double sd = dof.motion == hand::Motion::Abduction ? c.abduction_sd : dof.motion == hand::Motion::Twist ? c.twist_sd : c.flexion_sd;
  return dof.finger == hand::Finger::Thumb ? sd * c.thumb_factor : sd;
}

// A finger's neighbour whose depth points a failing finger is fitted to.
inline hand::Finger snap_target(hand::Finger f, int pick) noexcept {
  switch (f) {
    case hand::Finger::Thumb: return hand::Finger::Index;
    case hand::Finger::Pinky: return hand::Finger::Ring;
    default: return static_cast<hand::Finger>(static_cast<int>(f) + (pick ? 1 : -1));
  }
}

}  // namespace detail

/// @brief The factor on the wandering error's SDs for a person whose hand is `length_scale` times the
/// template's long, drawn from the person's stream `subject_seed` (its own sub-stream: the person's
/// bias draws stay as they were): TrackerConfig::size_power and subject_noise_spread.
inline double tracker_person_factor(const TrackerConfig& config, double length_scale, std::uint64_t subject_seed) {
  double factor = config.size_power == 0.0 ? 1.0 : std::pow(length_scale, -config.size_power);
  if (config.subject_noise_spread > 0.0) {
    core::Rng rng(core::derive_seed(subject_seed, {1}));
    factor *= std::exp(rng.normal(0.0, config.subject_noise_spread));
  }
  return factor;
}

/// @brief Labels `rec` as the reference tracker would: fills rec.labels (frames x 25, radians, within
/// the joint limits) from the true motion and sets rec.outlier from the labels' collision energy, as
/// the paper's filter saw the tracker's poses. A perfect tracker copies the truth. `length_scale`:
/// the person's hand length against the template's (Subject::length_scale()). Deterministic in the seeds.
inline void label_recording(Recording& rec, const MotionSequence& motion, const hand::Kinematics& kinematics,
                            const std::array<double, 16>& radii, const TrackerConfig& config, const TrackerSeeds& seeds,
                            double length_scale = 1.0) {
  const std::size_t n = static_cast<std::size_t>(rec.frames);
  constexpr std::size_t D = hand::kDofCount;
  if (config.perfect()) {
    rec.labels = rec.angles;
    return;
  }
  const hand::JointLimits limits;
  std::array<double, D> bias{};
  core::Rng subject_rng(seeds.subject), session_rng(seeds.session), rng(seeds.recording);
  for (std::size_t d = 0; d < D; ++d)
    bias[d] = (subject_rng.normal(0.0, config.subject_bias_sd) + session_rng.normal(0.0, config.session_bias_sd)) * core::kRadiansPerDegree;
  const double person = tracker_person_factor(config, length_scale, seeds.subject);
  std::array<double, D> wander{};  // unit-variance Ornstein-Uhlenbeck state per DoF
  for (double& z : wander) z = rng.normal(0.0, 1.0);

  struct Failure {
    double end = -1.0;
    hand::Finger finger = hand::Finger::Thumb;
    hand::Finger onto = hand::Finger::Index;
    bool snap = false;
    double direction = 0.0;  // snap: the abduction step toward the neighbour (radians)
    hand::Angles held{};     // freeze: the finger's last seen labels
  } failure;
  const double failure_rate = (config.snap_rate + config.freeze_rate) / 60.0;  // per second
  hand::Skeleton skeleton;
  const auto energy = [&](const hand::Angles& q) {
    kinematics.pose(q, skeleton);
    return hand::collision_energy(kinematics, skeleton, radii);
  };

  rec.labels.resize(n * D);
  hand::Angles smoothed{};
  double previous_time = 0.0;
  for (std::size_t f = 0; f < n; ++f) {
    const double t = rec.timestamps[f];
    const double dt = f == 0 ? 0.0 : t - previous_time;
    previous_time = t;
    const hand::Angles truth = motion.at(t - config.latency);
    const double rho = config.correlation_time > 0.0 ? std::exp(-dt / config.correlation_time) : 0.0;
    const double innovation = std::sqrt(std::max(0.0, 1.0 - rho * rho));
    hand::Angles label{};
    for (std::size_t d = 0; d < D; ++d) {
      if (f > 0) wander[d] = rho * wander[d] + innovation * rng.normal(0.0, 1.0);
      const hand::Finger finger = hand::kDofs[d].finger;
      const double flexion =
          truth[hand::dof_of(finger, hand::Motion::BaseFlexion)] + truth[hand::dof_of(finger, hand::Motion::MiddleFlexion)];
      const double occluded = 1.0 + config.occlusion_gain * std::clamp(flexion / (2.0 * 90.0 * core::kRadiansPerDegree), 0.0, 1.0);
      label[d] = truth[d] + bias[d] + wander[d] * detail::tracker_sd(config, d) * person * occluded * core::kRadiansPerDegree;
    }
    // The tracker's collision term: the error is shortened (bisection on its length) until the
    // fingers overlap no more than allowed.
    if (std::isfinite(config.collision_allowance) && energy(limits.clamp(label)) > config.collision_allowance) {
      const double allowed = std::max(config.collision_allowance, energy(truth));
      const auto along = [&](double k) {
        hand::Angles q{};
        for (std::size_t d = 0; d < D; ++d) q[d] = truth[d] + k * (label[d] - truth[d]);
        return limits.clamp(q);
      };
      double lo = 0.0, hi = 1.0;
      if (energy(along(1.0)) > allowed) {
        for (int i = 0; i < 8; ++i) (energy(along(0.5 * (lo + hi))) > allowed ? hi : lo) = 0.5 * (lo + hi);
        label = along(lo);
      }
    }

    // Failures start as a Poisson process and last an exponential time.
    if (t >= failure.end && failure_rate > 0.0 && rng.bernoulli(1.0 - std::exp(-failure_rate * dt))) {
      failure.snap = rng.uniform() * failure_rate * 60.0 < config.snap_rate;
      failure.finger = static_cast<hand::Finger>(rng.index(static_cast<int>(hand::kFingerCount)));
      failure.onto = detail::snap_target(failure.finger, rng.index(2));
      failure.end = t + std::max(dt, -config.failure_seconds * std::log(1.0 - rng.uniform()));
      failure.held = label;
      // The abduction step that brings the finger onto its neighbour: the sign with the larger overlap.
      const std::size_t abduction = hand::dof_of(failure.finger, hand::Motion::Abduction);
      const double step = config.snap_abduction * core::kRadiansPerDegree;
      hand::Angles plus = truth, minus = truth;
      plus[abduction] += step;
      minus[abduction] -= step;
      failure.direction = energy(limits.clamp(plus)) >= energy(limits.clamp(minus)) ? step : -step;
    }
    if (t < failure.end)
      for (std::size_t d = 0; d < D; ++d) {
        const hand::Dof& dof = hand::kDofs[d];
        if (dof.finger != failure.finger) continue;
        if (!failure.snap) {
          label[d] = failure.held[d];
        } else if (dof.motion == hand::Motion::Abduction) {
          label[d] += failure.direction;
        } else if (dof.motion != hand::Motion::Twist) {  // the flexions follow the neighbour's
          label[d] = label[hand::dof_of(failure.onto, dof.motion)];
        }
      }

    label = limits.clamp(label);
    const double alpha = f == 0 || config.smoothing <= 0.0 ? 1.0 : 1.0 - std::exp(-dt / config.smoothing);
    for (std::size_t d = 0; d < D; ++d) {
      smoothed[d] += alpha * (label[d] - smoothed[d]);
      rec.labels[f * D + d] = static_cast<float>(smoothed[d]);
    }
    rec.outlier[f] = energy(smoothed) > hand::kCollisionOutlierThreshold ? 1 : 0;
  }
}

}  // namespace glovepose::sim
