/// @file collision.hpp
/// @brief The collision energy of the reference hand tracker, the paper's outlier filter (Sec. 4.3:
/// frames whose energy exceeds 80 are dropped, about 2% of the data).
///
/// Source: Tkach et al. 2017, public repository anastasia-tkach/honline-cpp-public (its collision
/// term): each finger phalanx (ids 1..15) is the
/// segment from its frame's origin to (0, length, 0) in its frame; parent/child pairs, the palm and
/// the wrist are skipped; for every other pair, with d the distance between the closest points of
/// the two segments and r_i, r_j the phalanxes' distal radii, a penetration e = r_i + r_j - d > 0
/// adds e^2 (mm^2). That the paper's threshold of 80 is in these units is an inference (not stated
/// in the paper).
#pragma once

#include <algorithm>
#include <cmath>
#include <array>
#include <cstddef>

#include <Eigen/Core>

#include "../config.hpp"
#include "collision_threshold.hpp"
#include "kinematics.hpp"

namespace glovepose::hand {

/// @brief Distal sphere radius (mm) of each finger phalanx by phalanx id 1..15 (index 0 unused):
/// thumb 10.31 / 7.31 / 7.03; pinky 6.23 / 4.77 / 4.18; ring 6.97 / 5.01 / 4.85; middle 7.64 /
/// 5.68 / 5.58; index 7.55 / 5.85 / 5.17 (honline-cpp-public's radii file R.txt).
inline constexpr std::array<double, 16> kReferenceDistalRadius{0.0,  10.31, 7.31, 7.03, 6.23, 4.77, 4.18, 6.97,
                                                               5.01, 4.85,  7.64, 5.68, 5.58, 7.55, 5.85, 5.17};

/// @brief Squared distance between the closest points of segments [p0, p1] and [q0, q1]
/// (Ericson, Real-Time Collision Detection, 5.1.9); degenerate segments are handled.
inline double segment_distance_squared(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& q0,
                                       const Eigen::Vector3d& q1) noexcept {
  const Eigen::Vector3d d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  constexpr double kEps = 1e-12;
  double s = 0.0, t = 0.0;
  if (a <= kEps && e <= kEps) return r.squaredNorm();
  if (a <= kEps) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= kEps) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2), denom = a * e - b * b;
      s = denom > kEps ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return ((p0 + s * d1) - (q0 + t * d2)).squaredNorm();
}

/// @brief Collision energy (mm^2) of a posed hand: the sum over non-adjacent finger phalanx pairs of
/// the squared penetration of their capsules. `radius` per phalanx id (default: the reference hand's).
inline double collision_energy(const Kinematics& kinematics, const Skeleton& skeleton,
                               const std::array<double, 16>& radius = kReferenceDistalRadius) noexcept {
  // Segment end points: a phalanx ends at its child's origin, a tip at (0, tip length, 0).
  std::array<Eigen::Vector3d, 16> from{}, to{};
  for (std::size_t f = 0; f < kFingerCount; ++f) {
    const auto base = static_cast<std::size_t>(kFingerBase[f]);
    for (std::size_t j = 0; j < 3; ++j) {
      from[base + j] = skeleton[base + j].translation();
      to[base + j] = j < 2 ? skeleton[base + j + 1].translation() : kinematics.fingertip(skeleton, static_cast<Finger>(f));
    }
  }
  double energy = 0.0;
  for (int i = 1; i <= 15; ++i)
    for (int j = i + 1; j <= 15; ++j) {
      if (kParent[static_cast<std::size_t>(j)] == i || kParent[static_cast<std::size_t>(i)] == j) continue;
      const auto a = static_cast<std::size_t>(i), b = static_cast<std::size_t>(j);
      const double reach = radius[a] + radius[b];
      const double d2 = segment_distance_squared(from[a], to[a], from[b], to[b]);
      if (d2 >= reach * reach) continue;
      const double e = reach - std::sqrt(d2);
      energy += e * e;
    }
  return energy;
}

}  // namespace glovepose::hand
