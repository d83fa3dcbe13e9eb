/// @file contact.hpp
/// @brief Contact-consistent poses: when the estimated pose says thumb and a finger touch, the
/// few angles of those two chains are adjusted so that the tips meet; every other pose is left as
/// it came.
///
/// Evidence: the estimated pose only (what the stage sees at run time), through the pinch rule of
/// pinch.hpp on its thumb-to-fingertip distances, with that rule's hysteresis: a pair is in contact
/// from when its tips come closer than ContactConfig::detection.threshold_mm until they part beyond
/// its release_mm. Why no wider capture: on the shipped model's poses of unseen people the
/// thumb-index detector's precision and recall are equal (0.50) at 15.75 mm, next to the rule's
/// 15 mm, and a wider threshold buys recall with precision (recall 0.95 at 29.5 mm, precision
/// 0.26): docs/results.md, "Contact-consistent poses"; tools/experiments/contact_floor.py.
///
/// Adjustment: of the pairs in contact the closest one is closed; damped least squares
/// (damped_least_squares.hpp) over the thumb's five DoFs and the finger's five, each step projected
/// into the joint limits, bringing the thumb tip to the contact distance from the finger tip along
/// the line between the estimated tips, with a weak pull toward the estimated angles (of the
/// changes that close the gap, the smallest, shared by the two chains) and, for the other three pairs,
/// a residual keeping their tips at least ContactConfig::apart_mm apart when the thumb's move would
/// bring them closer (a second pinch the evidence did not show). The contact distance is the sum
/// of the two distal phalanxes' radii (collision.hpp's kReferenceDistalRadius: 11.2-12.6 mm), where
/// the tips' surfaces touch. Collision-free: the hand's collision energy (collision.hpp, the
/// squared penetrations of the phalanx capsules) may not end above ContactConfig::max_collision
/// (the paper's outlier threshold, 80 mm^2) unless the estimate's was already higher, and then not
/// above the estimate's; such an adjustment is refused and the estimate kept. Not "no added energy
/// at all": tips meeting at the radii press the neighbouring capsules a little (the gallery's
/// pinches, solved to contact, carry 0.01-63 mm^2), which is contact, not collision.
///
/// Set-up (the constructor) validates and throws glovepose::Error; apply() is noexcept and does not
/// allocate (fixed-size matrices, the stage's own skeleton and axes).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <string>

#include <Eigen/Dense>

#include "../config.hpp"
#include "collision.hpp"
#include "contact_config.hpp"
#include "damped_least_squares.hpp"
#include "dofs.hpp"
#include "kinematics.hpp"
#include "pinch.hpp"

namespace glovepose::hand {

/// @brief What ContactStage::apply() did to one pose.
struct ContactResult {
  PinchFlags contact{};     ///< Per pair (thumb with index .. pinky): in contact by the evidence.
  int closed = -1;          ///< The pair adjusted (0..3), or -1: the pose is unchanged.
  double gap_before_mm = NAN;  ///< That pair's tip distance minus its contact distance, before ...
  double gap_after_mm = NAN;   ///< ... and after (NaN when no pair was adjusted).
  bool refused = false;        ///< An adjustment was found but refused (collision), the pose kept.
};

/// @brief The contact stage of one hand stream (see the file comment).
class ContactStage {
 public:
  /// @brief A stage for poses of `kinematics`' hand within `limits`. Throws glovepose::Error for bad settings.
  ContactStage(const Kinematics& kinematics, const JointLimits& limits, const ContactConfig& config = {})
      : kinematics_(kinematics), limits_(limits), config_(config) {
    config_.validate();
    const std::size_t thumb_tip = static_cast<std::size_t>(kFingerBase[0]) + 2;
    for (std::size_t k = 0; k < kPinchPairCount; ++k)
      contact_mm_[k] = kReferenceDistalRadius[thumb_tip] + kReferenceDistalRadius[static_cast<std::size_t>(kFingerBase[k + 1]) + 2];
  }

  /// @brief The settings.
  const ContactConfig& config() const noexcept { return config_; }
  /// @brief The tip distance (mm) at which a pair's tips touch: the two distal radii.
  double contact_distance(std::size_t pair) const noexcept { return contact_mm_[pair]; }

  /// @brief Forgets the contact state (a new stream or a gap).
  void reset() noexcept { on_ = PinchFlags{}; }

  /// @brief Updates the contact state from `angles` (radians) and `skeleton` (posed from them by
  /// the same kinematics) and, when a pair is in contact, adjusts the angles of its two chains so
  /// that its tips meet, re-posing `skeleton`. A pose with a non-finite angle is left as it came and
  /// ends every contact.
  GLOVEPOSE_REALTIME ContactResult apply(Angles& angles, Skeleton& skeleton) noexcept {
    ContactResult result;
    for (double a : angles)
      if (!std::isfinite(a)) {
        reset();
        return result;
      }
    const PinchDistances distance = pinch_distances(fingertip_positions(kinematics_, skeleton));
    int closest = -1;
    for (std::size_t k = 0; k < kPinchPairCount; ++k) {
      on_[k] = pinch_next(on_[k], distance[k], config_.detection);
      if (on_[k] && (closest < 0 || distance[k] < distance[static_cast<std::size_t>(closest)])) closest = static_cast<int>(k);
    }
    result.contact = on_;
    if (closest < 0) return result;
    const auto pair = static_cast<std::size_t>(closest);
    result.closed = closest;
    result.gap_before_mm = distance[pair] - contact_mm_[pair];
    Angles adjusted = angles;
    close(pair, distance, skeleton, adjusted);
    kinematics_.pose(adjusted, work_);
    if (collision_energy(kinematics_, work_) > std::max(config_.max_collision, collision_energy(kinematics_, skeleton))) {
      result.refused = true;
      result.closed = -1;
      return result;
    }
    result.gap_after_mm = pinch_distances(fingertip_positions(kinematics_, work_))[pair] - contact_mm_[pair];
    angles = adjusted;
    skeleton = work_;
    return result;
  }

 private:
  static constexpr int P = 2 * static_cast<int>(kFingerCount);  // the thumb's five DoFs, then the finger's

  // The DoF index of parameter i for the thumb and finger f.
  static std::size_t chain_dof(int i, std::size_t finger) noexcept {
    return i < static_cast<int>(kFingerCount) ? kDofIndex[0][static_cast<std::size_t>(i)]
                                              : kDofIndex[finger][static_cast<std::size_t>(i) - kFingerCount];
  }

  // Damped least squares on the two chains of `pair`, from `q` (the estimate) into `q`.
  void close(std::size_t pair, const PinchDistances& before, const Skeleton& skeleton, Angles& q) noexcept {
    const std::size_t finger = pair + 1;
    const Angles estimate = q;
    for (int i = 0; i < P; ++i) {  // the chains start within the limits
      const std::size_t d = chain_dof(i, finger);
      q[d] = q[d] < limits_.min()[d] ? limits_.min()[d] : (q[d] > limits_.max()[d] ? limits_.max()[d] : q[d]);
    }
    // Where the thumb tip is to be relative to the finger tip: the contact distance away along the
    // estimated tips' line (a vector residual: the problem stays nearly linear, and either chain
    // may carry the change when the other is at its limits).
    tips_ = fingertip_positions(kinematics_, skeleton);
    const Eigen::Vector3d between = tips_[0] - tips_[finger];
    const double gap = between.norm();
    if (!(gap > 1e-6)) return;  // no direction to part them along
    const Eigen::Vector3d target = (contact_mm_[pair] / gap) * between;
    // The other pairs' floor: apart_mm, or their estimated distance when already closer.
    PinchDistances floor_mm{};
    for (std::size_t k = 0; k < kPinchPairCount; ++k) floor_mm[k] = std::min(config_.apart_mm, before[k]);
    const auto cost_of = [&](const Angles& angles) {
      kinematics_.pose(angles, work_, axes_);
      tips_ = fingertip_positions(kinematics_, work_);
      double cost = (tips_[0] - tips_[finger] - target).squaredNorm();
      for (std::size_t k = 0; k < kPinchPairCount; ++k) {
        const double d = (tips_[0] - tips_[k + 1]).norm();
        if (k != pair && d < floor_mm[k]) cost += (d - floor_mm[k]) * (d - floor_mm[k]);
      }
      for (int i = 0; i < P; ++i) {
        const std::size_t d = chain_dof(i, finger);
        cost += config_.change_weight * (angles[d] - estimate[d]) * (angles[d] - estimate[d]);
      }
      return cost;
    };
    double cost = cost_of(q);
    // The normal equations at the current pose (cost_of left work_, axes_ and tips_ there).
    const auto normal_equations = [&](Eigen::Matrix<double, P, P>& h, Eigen::Matrix<double, P, 1>& g) {
      constexpr int F = static_cast<int>(kFingerCount);
      // Thumb tip minus finger tip to the target: the thumb's DoFs move the first, the finger's the second.
      Eigen::Matrix<double, 3, P> j;
      for (int i = 0; i < F; ++i) {
        j.col(i) = dof_derivative(axes_, work_, chain_dof(i, finger), tips_[0]);
        j.col(F + i) = -dof_derivative(axes_, work_, chain_dof(F + i, finger), tips_[finger]);
      }
      h.noalias() += j.transpose() * j;
      g.noalias() += j.transpose() * (tips_[0] - tips_[finger] - target);
      const Eigen::Matrix<double, 3, F> jt = j.template leftCols<F>();
      // The other pairs below their floor: the thumb's DoFs part them (their fingers are not parameters).
      for (std::size_t k = 0; k < kPinchPairCount; ++k) {
        if (k == pair) continue;
        const Eigen::Vector3d apart = tips_[0] - tips_[k + 1];
        const double d = apart.norm();
        if (!(d > 1e-9) || d >= floor_mm[k]) continue;
        const Eigen::Matrix<double, 1, F> jk = (apart / d).transpose() * jt;
        h.template topLeftCorner<F, F>().noalias() += jk.transpose() * jk;
        g.template head<F>().noalias() += jk.transpose() * (d - floor_mm[k]);
      }
      for (int i = 0; i < P; ++i) {
        const std::size_t d = chain_dof(i, finger);
        h(i, i) += config_.change_weight;
        g(i) += config_.change_weight * (q[d] - estimate[d]);
      }
      // A DoF at a limit that the descent would push beyond it is held there (active set): the
      // projection would cut its share of the step, and the others must carry it instead.
      for (int i = 0; i < P; ++i) {
        const std::size_t d = chain_dof(i, finger);
        if ((q[d] <= limits_.min()[d] && g(i) > 0.0) || (q[d] >= limits_.max()[d] && g(i) < 0.0)) {
          const double diagonal = h(i, i);
          h.row(i).setZero();
          h.col(i).setZero();
          h(i, i) = diagonal;
          g(i) = 0.0;
        }
      }
    };
    Angles candidate = q;
    const auto trial = [&](const Eigen::Matrix<double, P, 1>& step) {
      candidate = q;
      for (int i = 0; i < P; ++i) {
        const std::size_t d = chain_dof(i, finger);
        const double a = q[d] + step(i);
        candidate[d] = a < limits_.min()[d] ? limits_.min()[d] : (a > limits_.max()[d] ? limits_.max()[d] : a);
      }
      return cost_of(candidate);
    };
    const auto accept = [&] { q = candidate; };
    (void)damped_least_squares<P>(cost, config_.max_iterations, config_.step_tolerance, normal_equations, trial, accept);
  }

  Kinematics kinematics_;
  JointLimits limits_;
  ContactConfig config_;
  std::array<double, kPinchPairCount> contact_mm_{};
  PinchFlags on_{};
  // Workspace of apply(), set up with the stage: the trial pose, its DoF axes and tips.
  Skeleton work_{};
  DofAxes axes_{};
  std::array<Eigen::Vector3d, kFingerCount> tips_{};
};

}  // namespace glovepose::hand
