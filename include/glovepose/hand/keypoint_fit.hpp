/// @file keypoint_fit.hpp
/// @brief From a hand tracker's keypoints to the hand model: a person's hand shape fitted once
/// (fit_hand_shape), then the 25 angles and the hand's placement per frame by inverse kinematics
/// within the joint limits (KeypointIk).
///
/// Shape: the points fixed to the palm (wrist, knuckles, OpenXR's palm joints) are aligned rigidly
/// to the template palm frame by frame (Kabsch) and averaged, which places each digit's base; each
/// bone's length is the distance between the keypoints at its two ends, its mean square corrected
/// for the keypoints' noise (estimated from the palm points' scatter). The bases' rest orientations
/// are the template's. Per frame: damped least squares (damped_least_squares.hpp) over the hand's
/// rotation and position and the 25 angles, analytic derivatives (Kinematics' DoF axes), each step
/// projected into the joint limits, with weak pulls toward the previous frame's angles and the rest
/// pose that hold the DoFs the keypoints do not see (a straight finger's twist).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include "../config.hpp"
#include "damped_least_squares.hpp"
#include "dofs.hpp"
#include "kinematics.hpp"
#include "keypoints.hpp"

namespace glovepose::hand {

/// @brief Whether a keypoint was reported (all three coordinates finite).
inline bool keypoint_seen(const Eigen::Vector3d& p) noexcept { return p.allFinite(); }

/// @brief The rigid transform taking `from` points onto `to` points (least squares, Kabsch), over
/// the entries where `use` is set; identity when fewer than three are set.
inline Eigen::Affine3d rigid_fit(const KeypointPositions& from, const KeypointPositions& to, const std::array<bool, kMaxKeypoints>& use,
                                 std::size_t count) noexcept {
  Eigen::Vector3d from_mean = Eigen::Vector3d::Zero(), to_mean = Eigen::Vector3d::Zero();
  std::size_t n = 0;
  for (std::size_t k = 0; k < count; ++k)
    if (use[k]) {
      from_mean += from[k];
      to_mean += to[k];
      ++n;
    }
  Eigen::Affine3d out = Eigen::Affine3d::Identity();
  if (n < 3) return out;
  from_mean /= static_cast<double>(n);
  to_mean /= static_cast<double>(n);
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();
  for (std::size_t k = 0; k < count; ++k)
    if (use[k]) cross += (to[k] - to_mean) * (from[k] - from_mean).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  out.linear() = svd.matrixU() * d * svd.matrixV().transpose();
  out.translation() = to_mean - out.linear() * from_mean;
  return out;
}

/// @brief A person's hand fitted to keypoints.
struct HandShapeFit {
  HandModel model;            ///< The template with this person's palm and bone lengths.
  double noise_mm = 0.0;      ///< The keypoints' noise (SD per coordinate) seen on the palm points.
  std::size_t frames = 0;     ///< Frames with enough palm points to be used.
  double hand_length_mm = 0;  ///< Wrist to the middle fingertip along the bones: the hand's size.
};

/// @brief Fits a person's hand model to frames of keypoints (mm, `frames` x layout count, NaN =
/// missing) of the layout, starting from `start` (a right hand's kinematics: mirror a left hand's
/// keypoints first, e.g. negate x, which the free placement absorbs). Throws
/// glovepose::Error when fewer than 10 frames show at least three palm points, or when a bone's
/// length comes out outside 3-150 mm (keypoints in another unit, or of another layout).
inline HandShapeFit fit_hand_shape(KeypointLayout layout, const std::vector<Eigen::Vector3d>& points, const Kinematics& start) {
  const KeypointModel model(layout, start);
  const std::size_t count = model.count();
  const std::size_t frames = points.size() / count;
  std::array<bool, kMaxKeypoints> palm{};
  KeypointPositions palm_mean{};
  std::size_t palm_count = 0;
  for (std::size_t k = 0; k < count; ++k) {
    palm[k] = model.on_palm(k);
    palm_mean[k] = model.anchor(k).local;  // the Hand frame is the root frame at rest
    palm_count += palm[k];
  }
  // Palm points in the palm's frame, frame by frame; three passes so the mean is aligned to itself.
  HandShapeFit out;
  double scatter = 0.0;
  std::size_t scatter_n = 0;
  for (int pass = 0; pass < 3; ++pass) {
    KeypointPositions sum{};
    std::array<std::size_t, kMaxKeypoints> seen{};
    for (auto& s : sum) s.setZero();
    std::vector<KeypointPositions> local;
    std::vector<std::array<bool, kMaxKeypoints>> used;
    std::vector<std::size_t> fitted;  // palm points behind each frame's alignment
    out.frames = 0;
    for (std::size_t f = 0; f < frames; ++f) {
      KeypointPositions observed{};
      std::array<bool, kMaxKeypoints> use{};
      std::size_t n = 0;
      for (std::size_t k = 0; k < count; ++k) {
        observed[k] = points[f * count + k];
        use[k] = palm[k] && keypoint_seen(observed[k]);
        n += use[k];
      }
      if (n < 3) continue;
      ++out.frames;
      const Eigen::Affine3d palm_pose = rigid_fit(palm_mean, observed, use, count);
      const Eigen::Affine3d to_palm = palm_pose.inverse();
      KeypointPositions in_palm{};
      for (std::size_t k = 0; k < count; ++k)
        if (use[k]) {
          in_palm[k] = to_palm * observed[k];
          sum[k] += in_palm[k];
          ++seen[k];
        }
      if (pass == 2) {
        local.push_back(in_palm);
        used.push_back(use);
        fitted.push_back(n);
      }
    }
    if (out.frames < 10)
      throw Error("hand shape: " + std::to_string(out.frames) + " frames show three or more of the " + std::to_string(palm_count) +
                  " palm keypoints of layout " + to_string(layout) + ", expected at least 10");
    for (std::size_t k = 0; k < count; ++k)
      if (palm[k] && seen[k] > 0) palm_mean[k] = sum[k] / static_cast<double>(seen[k]);
    // The alignment took 6 of a frame's 3n coordinates' freedom: the scatter is scaled back up.
    if (pass == 2)
      for (std::size_t f = 0; f < local.size(); ++f) {
        const double kept = (3.0 * static_cast<double>(fitted[f]) - 6.0) / (3.0 * static_cast<double>(fitted[f]));
        for (std::size_t k = 0; k < count; ++k)
          if (used[f][k] && seen[k] > 1 && kept > 0) {
            scatter += (local[f][k] - palm_mean[k]).squaredNorm() / kept;
            ++scatter_n;
          }
      }
  }
  out.noise_mm = scatter_n > 0 ? std::sqrt(scatter / (3.0 * static_cast<double>(scatter_n))) : 0.0;
  if (!std::isfinite(out.noise_mm) || out.noise_mm > 100.0)
    throw Error("hand shape: the palm keypoints scatter by " + std::to_string(out.noise_mm) + " mm about their mean shape, expected a hand "
                "(a few mm; keypoints in millimetres after the unit is applied?)");

  // The palm frame keeps the template's orientation; its origin goes to the wrist keypoint.
  std::size_t wrist = 0;
  while (wrist < count && std::string(keypoint_name(layout, wrist)) != "wrist") ++wrist;
  const Eigen::Vector3d origin = palm_mean[wrist];
  out.model = start.model();
  // Each digit's base: the palm keypoint at its base phalanx's origin; each bone: its two ends.
  const auto distance_ms = [&](std::size_t a, std::size_t b) {
    double sum = 0.0;
    std::size_t n = 0;
    for (std::size_t f = 0; f < frames; ++f) {
      const Eigen::Vector3d& pa = points[f * count + a];
      const Eigen::Vector3d& pb = points[f * count + b];
      if (!keypoint_seen(pa) || !keypoint_seen(pb)) continue;
      sum += (pa - pb).squaredNorm();
      ++n;
    }
    return n > 0 ? std::sqrt(std::max(sum / static_cast<double>(n) - 6.0 * out.noise_mm * out.noise_mm, 0.0)) : NAN;
  };
  for (std::size_t f = 0; f < kFingerCount; ++f) {
    // The digit's four keypoints in layout order (base joint, two joints, tip), as KeypointModel lays them out.
    const std::size_t first = layout == KeypointLayout::MediaPipe ? 1 + 4 * f : XrJointMapper::digit_joint(f);
    const auto base = static_cast<std::size_t>(kFingerBase[f]);
    out.model.rest[base].translation() = palm_mean[first] - origin;
    for (std::size_t k = 0; k < 3; ++k) {
      const double length = distance_ms(first + k, first + k + 1);
      if (!std::isfinite(length)) continue;  // never seen together: the template's length stays
      if (length < 3.0 || length > 150.0)
        throw Error(std::string("hand shape: the ") + to_string(static_cast<Finger>(f)) + " bone from " + keypoint_name(layout, first + k) +
                    " to " + keypoint_name(layout, first + k + 1) + " is " + std::to_string(length) +
                    " mm long, expected 3-150 mm (keypoints in millimetres after the unit is applied?)");
      if (k < 2)
        out.model.rest[base + k + 1].translation() = Eigen::Vector3d(0.0, length, 0.0);
      else
        out.model.tip_length[f] = length;
    }
  }
  const auto middle = static_cast<std::size_t>(kFingerBase[static_cast<std::size_t>(Finger::Middle)]);
  out.hand_length_mm = out.model.rest[middle].translation().norm() + out.model.rest[middle + 1].translation().norm() +
                       out.model.rest[middle + 2].translation().norm() + out.model.tip_length[static_cast<std::size_t>(Finger::Middle)];
  return out;
}

/// @brief Settings of the per-frame fit. Weights are in mm^2 of keypoint residual per rad^2.
struct KeypointIkConfig {
  int max_iterations = 30;        ///< Levenberg-Marquardt iterations at most.
  double previous_weight = 300;   ///< Pull toward the previous frame's angles (holds unseen DoFs steady).
  double rest_weight = 0.1;       ///< Pull toward the rest pose (within the limits).
  double step_tolerance = 1e-6;   ///< Stop when no parameter moves more than this (rad or mm).
};

/// @brief One frame's fit.
struct KeypointIkResult {
  Angles angles{};                                     ///< Radians, within the limits.
  Eigen::Affine3d root = Eigen::Affine3d::Identity();  ///< The model's root frame in the tracker's frame (mm).
  double rms_mm = NAN;                                 ///< Root-mean-square distance of the seen keypoints to the model's.
  std::size_t seen = 0;                                ///< Keypoints used.
};

/// @brief Inverse kinematics of one hand model from keypoints. Immutable; solve() is allocation-free.
class KeypointIk {
 public:
  /// @brief A fit of `model`'s keypoints within `limits`.
  explicit KeypointIk(KeypointModel model, JointLimits limits = {}, KeypointIkConfig config = {})
      : model_(std::move(model)), limits_(limits), config_(config) {}

  /// @brief The keypoint model.
  const KeypointModel& model() const noexcept { return model_; }

  /// @brief Fits angles and placement to `observed` (mm, NaN = missing), starting from `start`
  /// angles; `previous` (may be null) is the pose the angles are pulled toward. The placement starts
  /// from the palm keypoints (Kabsch), or all seen keypoints when fewer than three palm ones are seen.
  GLOVEPOSE_REALTIME KeypointIkResult solve(const KeypointPositions& observed, const Angles& start, const Angles* previous) const noexcept {
    constexpr int P = 6 + static_cast<int>(kDofCount);
    const std::size_t count = model_.count();
    std::array<bool, kMaxKeypoints> seen{}, palm{};
    std::size_t seen_n = 0, palm_n = 0;
    for (std::size_t k = 0; k < count; ++k) {
      seen[k] = keypoint_seen(observed[k]);
      palm[k] = seen[k] && model_.on_palm(k);
      seen_n += seen[k];
      palm_n += palm[k];
    }
    KeypointIkResult out;
    out.seen = seen_n;
    out.angles = limits_.clamp(start);
    if (seen_n < 3) return out;
    const Angles rest = limits_.rest();
    const Angles toward = previous ? *previous : out.angles;
    const double previous_weight = previous ? config_.previous_weight : 0.0;

    Skeleton skeleton;
    DofAxes axes;
    KeypointPositions at{};
    model_.kinematics().pose(out.angles, skeleton);
    model_.positions(skeleton, at);
    out.root = rigid_fit(at, observed, palm_n >= 3 ? palm : seen, count);

    const auto cost_of = [&](const Angles& q, const Eigen::Affine3d& root, double& residual) {
      model_.kinematics().pose(q, skeleton, axes, root);
      model_.positions(skeleton, at);
      residual = 0.0;
      for (std::size_t k = 0; k < count; ++k)
        if (seen[k]) residual += (at[k] - observed[k]).squaredNorm();
      double prior = 0.0;
      for (std::size_t d = 0; d < kDofCount; ++d)
        prior += previous_weight * (q[d] - toward[d]) * (q[d] - toward[d]) + config_.rest_weight * (q[d] - rest[d]) * (q[d] - rest[d]);
      return residual + prior;
    };
    double residual = 0.0;
    double cost = cost_of(out.angles, out.root, residual);
    // Normal equations at the current pose (skeleton, axes and `at` are current: the accepted
    // trial's cost_of left them there).
    const auto normal_equations = [&](Eigen::Matrix<double, P, P>& h, Eigen::Matrix<double, P, 1>& g) {
      const Eigen::Vector3d centre = out.root.translation();
      for (std::size_t k = 0; k < count; ++k) {
        if (!seen[k]) continue;
        Eigen::Matrix<double, 3, P> j = Eigen::Matrix<double, 3, P>::Zero();
        const Eigen::Vector3d arm = at[k] - centre;
        for (int a = 0; a < 3; ++a) j.col(a) = Eigen::Vector3d::Unit(a).cross(arm);
        j.block<3, 3>(0, 3).setIdentity();
        for (std::size_t d = 0; d < kDofCount; ++d)
          if (model_.moves(d, k)) j.col(6 + static_cast<int>(d)) = dof_derivative(axes, skeleton, d, at[k]);
        const Eigen::Vector3d r = at[k] - observed[k];
        h.noalias() += j.transpose() * j;
        g.noalias() += j.transpose() * r;
      }
      for (std::size_t d = 0; d < kDofCount; ++d) {
        const int i = 6 + static_cast<int>(d);
        h(i, i) += previous_weight + config_.rest_weight;
        g(i) += previous_weight * (out.angles[d] - toward[d]) + config_.rest_weight * (out.angles[d] - rest[d]);
      }
    };
    Eigen::Affine3d trial_root = out.root;
    Angles trial_angles = out.angles;
    double trial_residual = 0.0;
    const auto trial = [&](const Eigen::Matrix<double, P, 1>& step) {
      trial_root = out.root;
      const Eigen::Vector3d turn = step.template head<3>();
      if (turn.norm() > 0) trial_root.linear() = Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix() * trial_root.linear();
      trial_root.translation() += step.template segment<3>(3);
      for (std::size_t d = 0; d < kDofCount; ++d) trial_angles[d] = out.angles[d] + step(6 + static_cast<int>(d));
      trial_angles = limits_.clamp(trial_angles);
      return cost_of(trial_angles, trial_root, trial_residual);
    };
    const auto accept = [&] {
      out.angles = trial_angles;
      out.root = trial_root;
      residual = trial_residual;
    };
    (void)damped_least_squares<P>(cost, config_.max_iterations, config_.step_tolerance, normal_equations, trial, accept);
    cost_of(out.angles, out.root, residual);
    out.rms_mm = std::sqrt(residual / static_cast<double>(seen_n));
    return out;
  }

 private:
  KeypointModel model_;
  JointLimits limits_;
  KeypointIkConfig config_;
};

}  // namespace glovepose::hand
