/// @file motion.hpp
/// @brief Natural hand motion for one recording: the subject goes from pose to pose of the gallery
/// (each visit formed in the person's own style and a little differently every time, sometimes a
/// blend of two poses as the paper's participants "explore the space of hand poses"), with
/// minimum-jerk transitions at human speed, dwell times, the couplings of real hands and a little
/// drift and physiological tremor while holding.
///
/// Sources: minimum-jerk point-to-point movements (Flash & Hogan 1985); finger enslaving, the
/// involuntary flexion of neighbouring fingers (Häger-Ross & Schieber 2000; 10-30% of the
/// instructed finger's motion); the distal joint's coupling to the middle joint (kTipCoupling,
/// pose_gallery.hpp); physiological tremor at 8-12 Hz (Elble 1996). Transition times of 0.3-1.6 s and
/// dwell times of a fraction of a second to a few seconds are our choice for the paper's free
/// exploration with a printed gallery.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../hand/collision.hpp"
#include "../hand/dofs.hpp"
#include "../hand/kinematics.hpp"
#include "../calibration/sequence.hpp"
#include "pose_gallery.hpp"
#include "../core/random.hpp"
#include "subject.hpp"

namespace glovepose::sim {

/// @brief Settings of the motion generator.
struct MotionConfig {
  double visit_spread = 0.06;       ///< SD (rad) of a visit's departure from the person's pose (abduction/twist: half).
  double explore = 0.35;            ///< Probability that a target blends two gallery poses.
  double drift_amplitude = 0.025;   ///< Amplitude (rad) of slow wandering (0.1-0.5 Hz) while holding and moving.
  double tremor_amplitude = 0.003;  ///< Amplitude (rad) of physiological tremor (8-12 Hz).
  double tip_spread = 0.05;         ///< SD (rad) of tip flexion around kTipCoupling x middle flexion.
  double pace = 1.0;                ///< Multiplies the subject's speed (calibration sequences move faster).
  double dwell = 1.0;               ///< Multiplies the subject's mean dwell time.
  /// SD of the share of the way to a target the person falls short, toward the gallery's first pose
  /// (half-normal per visit, at most half): extremes a calibration sequence does not fully reach.
  double shortfall = 0.0;
  /// Probability that a target is a free pose: each finger takes its DoFs from a gallery pose of its
  /// own (fingers moving independently, beyond the gallery's whole-hand poses and their blends).
  double independent = 0.0;
};

/// @brief One stretch of the motion: a transition to `to`, then a hold.
struct MotionSegment {
  double start = 0.0;   ///< Seconds since the recording started.
  double move = 0.0;    ///< Transition duration, s.
  double hold = 0.0;    ///< Dwell at `to`, s.
  hand::Angles from{};  ///< Pose at `start`.
  hand::Angles to{};    ///< Pose reached at `start + move`.
  int key = -1;         ///< Gallery index of the target (the first one when blended).
  /// Angles `to` holds exactly (a guided calibration step, e.g. fingers pressed flat on a table):
  /// no drift or tremor there once reached.
  std::array<bool, hand::kDofCount> pinned{};
};

/// @brief The motion of one recording as a function of time. Immutable once made.
class MotionSequence {
 public:
  /// @brief `duration` seconds of motion of `subject` through `gallery`, from `seed`. Starts at the
  /// gallery's first pose ("flat" for the built-in gallery). Throws glovepose::Error for an empty
  /// gallery or a non-positive duration.
  MotionSequence(const Subject& subject, const std::vector<KeyPose>& gallery, double duration, std::uint64_t seed,
                 const MotionConfig& config = {})
      : duration_(duration) {
    if (gallery.empty()) throw Error("MotionSequence: empty gallery, expected at least one key pose");
    if (!(duration > 0.0)) throw Error("MotionSequence: duration " + std::to_string(duration) + " s, expected > 0");
    core::Rng rng(seed);
    const hand::Kinematics fk(subject.hand_model());
    const std::array<double, 16> radius = subject.distal_radius();
    hand::Skeleton skeleton;
    hand::Angles current = shape(gallery.front().angles, subject, config, rng);
    double t = 0.0;
    while (t <= duration) {
      MotionSegment seg;
      seg.start = t;
      seg.from = current;
      seg.key = rng.index(static_cast<int>(gallery.size()));
      hand::Angles target = gallery[static_cast<std::size_t>(seg.key)].angles;
      if (rng.bernoulli(config.explore)) {
        const hand::Angles& other = gallery[static_cast<std::size_t>(rng.index(static_cast<int>(gallery.size())))].angles;
        const double w = rng.uniform(0.25, 0.75);
        for (std::size_t d = 0; d < hand::kDofCount; ++d) target[d] = w * target[d] + (1.0 - w) * other[d];
      }
      if (config.independent > 0.0 && rng.bernoulli(config.independent)) {
        std::array<std::size_t, hand::kFingerCount> source{};
        for (std::size_t& k : source) k = static_cast<std::size_t>(rng.index(static_cast<int>(gallery.size())));
        for (std::size_t d = 0; d < hand::kDofCount; ++d) target[d] = gallery[source[static_cast<std::size_t>(hand::kDofs[d].finger)]].angles[d];
      }
      fall_short(target, gallery.front().angles, config, rng);
      seg.to = shape(target, subject, config, rng);
      // As the paper's tracker would have reported it: interpenetrating fingers give way.
      fk.pose(seg.to, skeleton);
      if (hand::collision_energy(fk, skeleton, radius) > 0.0) seg.to = settle_pose(seg.to, hand::Finger::Thumb, nullptr, fk, radius, 0.1);
      double largest = 0.0;
      for (std::size_t d = 0; d < hand::kDofCount; ++d) largest = std::max(largest, std::abs(seg.to[d] - seg.from[d]));
      seg.move = std::clamp((0.3 + 0.5 * largest) / (subject.speed * config.pace), 0.25, 1.6);
      seg.hold = std::max(0.1, rng.exponential(subject.dwell * config.dwell));
      segments_.push_back(seg);
      current = seg.to;
      t += seg.move + seg.hold;
    }
    make_wobble(config, rng);
  }

  /// @brief `subject` following a guided calibration sequence, from `seed`: at every step the person
  /// reacts (0.2-0.6 s), moves to the step's pose formed in their own way (style, this visit's
  /// spread, enslaving, as for gallery poses) at their speed and holds it until the next step; the
  /// angles the step pins take the step's pose within its pinned_sd instead, without drift or
  /// tremor once reached. Starts at the first step's pose.
  MotionSequence(const Subject& subject, const calibration::Sequence& sequence, std::uint64_t seed, const MotionConfig& config = {})
      : duration_(sequence.total_seconds()) {
    core::Rng rng(seed);
    const calibration::Step& first = sequence.steps().front();
    const auto visit = [&](const calibration::Step& step) {
      hand::Angles target = step.pose;
      fall_short(target, first.pose, config, rng);  // the pinned angles below still hold
      hand::Angles q = shape(target, subject, config, rng);
      for (std::size_t d = 0; d < hand::kDofCount; ++d)
        if (step.pinned[d]) q[d] = step.pose[d] + rng.normal(0.0, step.pinned_sd);
      return hand::JointLimits().clamp(q);
    };
    hand::Angles current = visit(sequence.steps().front());
    std::array<bool, hand::kDofCount> current_pinned = sequence.steps().front().pinned;
    double t = 0.0;
    for (std::size_t i = 0; i < sequence.steps().size(); ++i) {
      const calibration::Step& step = sequence.steps()[i];
      MotionSegment seg;
      seg.start = t + rng.uniform(0.2, 0.6);
      seg.from = current;
      seg.key = static_cast<int>(i);
      seg.to = i == 0 ? current : visit(step);
      seg.pinned = step.pinned;
      double largest = 0.0;
      for (std::size_t d = 0; d < hand::kDofCount; ++d) largest = std::max(largest, std::abs(seg.to[d] - seg.from[d]));
      seg.move = std::clamp((0.3 + 0.5 * largest) / (subject.speed * config.pace), 0.25, 1.6);
      t += step.seconds;
      seg.hold = std::max(0.0, t - seg.start - seg.move);
      if (i == 0) {  // the sequence starts in the first pose
        seg.start = 0.0;
        seg.hold = step.seconds;
      }
      from_pinned_.push_back(current_pinned);
      segments_.push_back(seg);
      current = seg.to;
      current_pinned = step.pinned;
    }
    make_wobble(config, rng);
  }

  /// @brief Seconds of motion.
  double duration() const noexcept { return duration_; }
  /// @brief The transitions and holds.
  const std::vector<MotionSegment>& segments() const noexcept { return segments_; }

  /// @brief The pose at time t (seconds; clamped to the recording), inside the joint limits, tip
  /// flexion following middle flexion.
  GLOVEPOSE_REALTIME hand::Angles at(double t) const noexcept {
    t = std::clamp(t, 0.0, duration_);
    // The last segment starting at or before t.
    const auto it = std::upper_bound(segments_.begin(), segments_.end(), t, [](double v, const MotionSegment& s) { return v < s.start; });
    const std::size_t index = static_cast<std::size_t>((it == segments_.begin() ? it : it - 1) - segments_.begin());
    const MotionSegment& seg = segments_[index];
    const double s = std::clamp((t - seg.start) / seg.move, 0.0, 1.0);
    const double w = s * s * s * (10.0 + s * (-15.0 + 6.0 * s));  // minimum jerk
    hand::Angles a{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      double wobble = 0.0;
      for (const Wave& v : drift_[d]) wobble += v.amplitude * std::sin(v.omega * t + v.phase);
      for (const Wave& v : tremor_[d]) wobble += v.amplitude * std::sin(v.omega * t + v.phase);
      // A pinned angle does not wobble; the wobble fades in and out over the transitions.
      if (!from_pinned_.empty() && from_pinned_[index][d]) wobble *= w;
      if (seg.pinned[d]) wobble *= 1.0 - w;
      a[d] = seg.from[d] + (seg.to[d] - seg.from[d]) * w + wobble;
    }
    for (std::size_t f = 1; f < hand::kFingerCount; ++f) {  // the tip keeps following the middle joint
      const auto finger = static_cast<hand::Finger>(f);
      const std::size_t middle = hand::dof_of(finger, hand::Motion::MiddleFlexion), tip = hand::dof_of(finger, hand::Motion::TipFlexion);
      const double target_offset =
          (seg.from[tip] - kTipCoupling * seg.from[middle]) * (1.0 - w) + (seg.to[tip] - kTipCoupling * seg.to[middle]) * w;
      a[tip] = kTipCoupling * a[middle] + target_offset;
    }
    return limits_.clamp(a);
  }

 private:
  struct Wave {
    double amplitude, omega, phase;
  };

  // Slow wandering and tremor: two sinusoids per band and DoF, random frequencies and phases.
  void make_wobble(const MotionConfig& config, core::Rng& rng) {
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const bool small = hand::kDofs[d].motion == hand::Motion::Abduction || hand::kDofs[d].motion == hand::Motion::Twist;
      for (int k = 0; k < 2; ++k) {
        drift_[d][static_cast<std::size_t>(k)] = {config.drift_amplitude * (small ? 0.5 : 1.0) * rng.uniform(0.5, 1.0),
                                                  6.283185307179586 * rng.uniform(0.1, 0.5), 6.283185307179586 * rng.uniform()};
        tremor_[d][static_cast<std::size_t>(k)] = {config.tremor_amplitude * rng.uniform(0.5, 1.0),
                                                   6.283185307179586 * rng.uniform(8.0, 12.0), 6.283185307179586 * rng.uniform()};
      }
    }
  }

  // A visit that stops short of `target`, toward `start`, by a half-normal share (at most half).
  static void fall_short(hand::Angles& target, const hand::Angles& start, const MotionConfig& config, core::Rng& rng) {
    if (config.shortfall <= 0.0) return;
    const double r = std::min(0.5, std::abs(rng.normal(0.0, config.shortfall)));
    for (std::size_t d = 0; d < hand::kDofCount; ++d) target[d] += r * (start[d] - target[d]);
  }

  // A visit of a key pose: the person's style, this visit's variation, finger enslaving, the tip
  // coupling, the joint limits.
  static hand::Angles shape(const hand::Angles& key, const Subject& subject, const MotionConfig& config, core::Rng& rng) {
    hand::Angles q = key;
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const bool small = hand::kDofs[d].motion == hand::Motion::Abduction || hand::kDofs[d].motion == hand::Motion::Twist;
      q[d] += subject.style[d] + rng.normal(0.0, small ? config.visit_spread / 2 : config.visit_spread);
    }
    // Enslaving: base and middle flexion of each long finger move towards their neighbours' mean.
    const hand::Angles designed = q;
    for (int column = 1; column <= 2; ++column)
      for (int f = 1; f <= 4; ++f) {
        const auto dof = [&](int finger) { return hand::dof_of(static_cast<hand::Finger>(finger), static_cast<hand::Motion>(column)); };
        double neighbours = 0.0;
        int count = 0;
        for (int n = f - 1; n <= f + 1; n += 2)
          if (n >= 1 && n <= 4) {
            neighbours += designed[dof(n)];
            ++count;
          }
        q[dof(f)] += subject.coupling * (neighbours / count - designed[dof(f)]);
      }
    for (int f = 1; f <= 4; ++f) {
      const auto finger = static_cast<hand::Finger>(f);
      q[hand::dof_of(finger, hand::Motion::TipFlexion)] =
          kTipCoupling * q[hand::dof_of(finger, hand::Motion::MiddleFlexion)] + rng.normal(0.0, config.tip_spread);
    }
    return hand::JointLimits().clamp(q);
  }

  double duration_;
  std::vector<MotionSegment> segments_;
  std::vector<std::array<bool, hand::kDofCount>> from_pinned_;  // per segment of a guided sequence: what `from` pins
  std::array<std::array<Wave, 2>, hand::kDofCount> drift_{};
  std::array<std::array<Wave, 2>, hand::kDofCount> tremor_{};
  hand::JointLimits limits_;
};

}  // namespace glovepose::sim
