/// @file keypoint_tracker.hpp
/// @brief A hand tracker's keypoints of a simulated hand: what a webcam tracker (MediaPipe), a
/// Leap Motion or a headset's OpenXR hand tracking would report beside the glove, on its own clock.
///
/// The keypoints are the person's own (their hand model: bone lengths and palm), of the true pose at
/// the tracker's frame time, with the hand turning and moving in front of the camera (slow
/// sinusoids: up to 35 degrees about each axis, 60 mm sideways, 400 mm away), plus white Gaussian
/// noise of a stated 3D RMS. The tracker's clock runs `offset` behind the glove's (glove time =
/// tracker time + offset), its frames at their own rate and phase. Every figure here is an
/// assumption of the test set-up, not a fit to a tracker.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>

#include <Eigen/Geometry>

#include "../core/units.hpp"
#include "../core/random.hpp"
#include "../hand/keypoints.hpp"
#include "../train/keypoint_labels.hpp"
#include "motion.hpp"

namespace glovepose::sim {

/// @brief What the simulated keypoint tracker reports.
struct KeypointTrackerConfig {
  hand::KeypointLayout layout = hand::KeypointLayout::MediaPipe;
  double rate_hz = 30.0;         ///< Tracker frames per second.
  double noise_mm = 5.0;         ///< 3D RMS of each keypoint's error (SD noise / sqrt(3) per coordinate).
  double offset_seconds = 0.0;   ///< Glove time = tracker time + offset.
};

/// @brief The keypoints (mm, in the camera's frame) a tracker reports while the hand takes the
/// poses `pose_at(glove time)` between glove times `from` and `to`. Deterministic in `seed`.
inline train::KeypointTrack track_keypoints(const hand::Kinematics& kinematics, const std::function<hand::Angles(double)>& pose_at, double from,
                                            double to, const KeypointTrackerConfig& config, std::uint64_t seed) {
  const hand::KeypointModel model(config.layout, kinematics);
  core::Rng rng(seed);
  const double phase = rng.uniform(0.0, 1.0) / config.rate_hz;
  std::array<double, 6> frequency{}, start{};
  for (std::size_t i = 0; i < 6; ++i) {
    frequency[i] = rng.uniform(0.05, 0.3);
    start[i] = rng.uniform(0.0, 6.283185307179586);
  }
  const double sd = config.noise_mm / std::sqrt(3.0);
  train::KeypointTrack track;
  hand::Skeleton skeleton;
  hand::KeypointPositions points;
  for (double t = from + phase; t <= to; t += 1.0 / config.rate_hz) {
    const auto wave = [&](std::size_t i) { return std::sin(6.283185307179586 * frequency[i] * t + start[i]); };
    const double turn = 35.0 * core::kRadiansPerDegree;
    Eigen::Affine3d root = Eigen::Affine3d::Identity();
    root.linear() = (Eigen::AngleAxisd(turn * wave(0), Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(turn * wave(1), Eigen::Vector3d::UnitY()) *
                     Eigen::AngleAxisd(turn * wave(2), Eigen::Vector3d::UnitZ()))
                        .toRotationMatrix();
    root.translation() = Eigen::Vector3d(60.0 * wave(3), 60.0 * wave(4), 400.0 + 60.0 * wave(5));
    kinematics.pose(pose_at(t), skeleton, root);
    model.positions(skeleton, points);
    track.times.push_back(t - config.offset_seconds);
    for (std::size_t k = 0; k < model.count(); ++k)
      track.points.push_back(points[k] + Eigen::Vector3d(rng.normal(0.0, sd), rng.normal(0.0, sd), rng.normal(0.0, sd)));
  }
  return track;
}

/// @brief The keypoints a tracker reports while the hand makes `motion`.
inline train::KeypointTrack track_keypoints(const hand::Kinematics& kinematics, const MotionSequence& motion, double from, double to,
                                            const KeypointTrackerConfig& config, std::uint64_t seed) {
  return track_keypoints(kinematics, [&](double t) { return motion.at(t); }, from, to, config, seed);
}

}  // namespace glovepose::sim
