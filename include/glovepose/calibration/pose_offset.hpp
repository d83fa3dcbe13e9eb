/// @file pose_offset.hpp
/// @brief Pose-guided calibration: a per-user offset of the 25 angles, estimated from how the
/// generic model sees the user's guided calibration sequence (docs/calibration.md).
///
/// Why an offset: min-max calibration maps each user's own extremes to [-1, 1], so it hides how the
/// user's poses sit in absolute terms (one person's fist is more curled than another's, one
/// person's flat hand a little bent). What is left of a new user's error is largely a constant per
/// angle. The calibration sequence tells us what the hand was asked to do at every moment, and some
/// steps pin angles exactly (a hand pressed on a table); how the generic model's output and the
/// calibrated cells sit against those requests carries the offset.
///
/// The estimate is linear in a fixed feature vector of the calibration, fitted on simulated (or
/// recorded) people other than the test users by train::fit_pose_offset (ridge least squares
/// against each person's true mean error). Features, per step of the sequence in order, over the
/// step's holding frames (time since the step's start >= the sequence's settle_seconds):
///   - the mean of the model's predicted angles minus the step's pose (25 values, radians),
///   - the mean of the calibrated cells (`cells` values, in [-clamp, clamp]).
/// offsets = weight x features + bias, radians, added to every pose's angles.
///
/// Whether the user followed the sequence: the model keeps the mean and SD of every feature over
/// the people it was fitted on and the largest RMS z-score of any of them; a calibration whose RMS
/// z-score exceeds kFollowedMargin times that was not the sequence (the user moved freely, or the
/// application did not show the steps), and gets no offsets.
///
/// Set-up code throughout: allocates, throws glovepose::Error naming what is wrong.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "../config.hpp"
#include "../hand/dofs.hpp"
#include "../io/json.hpp"
#include "sequence.hpp"

namespace glovepose::calibration {

/// @brief A pose with a user's offsets applied: the sum, kept within the joint limits (the network's
/// tanh keeps its own angles there). The estimator and the offline evaluation both apply them so.
GLOVEPOSE_REALTIME inline hand::Angles with_offsets(const hand::Angles& angles, const hand::Angles& offsets,
                                                    const hand::JointLimits& limits) noexcept {
  hand::Angles out{};
  for (std::size_t d = 0; d < hand::kDofCount; ++d) out[d] = angles[d] + offsets[d];
  return limits.clamp(out);
}

/// @brief Sums of what the model and the cells showed over each step's holding frames.
class StepHoldMeans {
 public:
  /// @brief Empty sums for `sequence` and `cells` calibrated cells per frame.
  StepHoldMeans(const Sequence& sequence, int cells)
      : sequence_(&sequence),
        cells_(cells),
        sums_(Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(sequence.steps().size()), hand::kDofCount + cells)),
        counts_(sequence.steps().size(), 0) {}

  /// @brief Whether a frame at `t` seconds since the sequence's start is one of a step's holding frames.
  bool holding(double t) const noexcept { return sequence_->holding_at(t); }

  /// @brief Adds a frame at `t` seconds since the sequence's start (ignored outside the holding
  /// frames): the model's angles (radians) and the calibrated cells.
  void add(double t, const hand::Angles& predicted, const float* cells) {
    if (!holding(t)) return;
    const auto k = static_cast<Eigen::Index>(sequence_->step_at(t));
    for (std::size_t d = 0; d < hand::kDofCount; ++d) sums_(k, static_cast<Eigen::Index>(d)) += predicted[d];
    for (int c = 0; c < cells_; ++c) sums_(k, hand::kDofCount + c) += cells[c];
    ++counts_[static_cast<std::size_t>(k)];
  }

  /// @brief Holding frames seen of step `k`.
  long frames(std::size_t k) const { return counts_.at(k); }

  /// @brief The name of the first step without a holding frame, or empty when every step has one.
  std::string missing_step() const {
    for (std::size_t k = 0; k < counts_.size(); ++k)
      if (counts_[k] == 0) return sequence_->steps()[k].name;
    return {};
  }

  /// @brief The feature vector (file comment). Throws glovepose::Error naming the first step that
  /// has no holding frame (the calibration ended early or frames were lost).
  Eigen::VectorXd features() const {
    const std::string missing = missing_step();
    if (!missing.empty())
      throw Error("pose-guided calibration: step '" + missing + "' of sequence '" + sequence_->id() +
                  "' has no frame held past its settle time, expected the whole sequence (" + std::to_string(sequence_->total_seconds()) +
                  " s) to be performed");
    const Eigen::Index per_step = sums_.cols();
    Eigen::VectorXd f(sums_.rows() * per_step);
    for (Eigen::Index k = 0; k < sums_.rows(); ++k) {
      const double n = static_cast<double>(counts_[static_cast<std::size_t>(k)]);
      const Step& step = sequence_->steps()[static_cast<std::size_t>(k)];
      for (Eigen::Index j = 0; j < per_step; ++j) {
        double v = sums_(k, j) / n;
        if (j < static_cast<Eigen::Index>(hand::kDofCount)) v -= step.pose[static_cast<std::size_t>(j)];
        f(k * per_step + j) = v;
      }
    }
    return f;
  }

 private:
  const Sequence* sequence_;
  int cells_;
  Eigen::MatrixXd sums_;  // steps x (25 + cells)
  std::vector<long> counts_;
};

/// @brief The name of the format (the "format" member of the JSON text).
inline constexpr const char* kPoseOffsetFormat = "glovepose-pose-offset";
/// @brief A calibration counts as following the sequence up to this many times the largest RMS
/// z-score of the people the model was fitted on.
inline constexpr double kFollowedMargin = 1.5;

/// @brief The fitted linear map from a calibration's features to the 25 angle offsets, with the
/// sequence it was fitted for.
class PoseOffsetModel {
 public:
  /// @brief A model for `sequence` and `cells` cells; `weight` is 25 x feature_count, `bias` 25.
  /// Throws glovepose::Error when the shapes disagree or a number is not finite.
  /// `feature_mean` and `feature_scale` (SD, > 0) describe the features of the people it was fitted
  /// on, `max_rms_z` the largest RMS z-score among them (> 0).
  PoseOffsetModel(Sequence sequence, int cells, Eigen::MatrixXd weight, Eigen::VectorXd bias, Eigen::VectorXd feature_mean,
                  Eigen::VectorXd feature_scale, double max_rms_z)
      : sequence_(std::move(sequence)),
        cells_(cells),
        weight_(std::move(weight)),
        bias_(std::move(bias)),
        mean_(std::move(feature_mean)),
        scale_(std::move(feature_scale)),
        max_rms_z_(max_rms_z) {
    if (cells_ < 1) throw Error("pose offset model: " + std::to_string(cells_) + " cells, expected at least 1");
    const Eigen::Index features = feature_count();
    if (weight_.rows() != static_cast<Eigen::Index>(hand::kDofCount) || weight_.cols() != features ||
        bias_.size() != static_cast<Eigen::Index>(hand::kDofCount))
      throw Error("pose offset model: weight " + std::to_string(weight_.rows()) + " x " + std::to_string(weight_.cols()) + " and bias " +
                  std::to_string(bias_.size()) + ", expected 25 x " + std::to_string(features) + " (steps x (25 + cells)) and 25");
    if (!weight_.allFinite() || !bias_.allFinite()) throw Error("pose offset model: non-finite weights, expected finite numbers");
    if (mean_.size() != features || scale_.size() != features || !mean_.allFinite() || !(scale_.array() > 0.0).all() ||
        !scale_.allFinite() || !(max_rms_z_ > 0.0) || !std::isfinite(max_rms_z_))
      throw Error("pose offset model: feature statistics of " + std::to_string(mean_.size()) + " means and " +
                  std::to_string(scale_.size()) + " scales, expected " + std::to_string(features) +
                  " finite means, positive finite scales and max_rms_z > 0");
  }

  /// @brief RMS over the features of (feature - mean) / scale: how far a calibration lies from the
  /// calibrations of the people the model was fitted on.
  double rms_z(const Eigen::VectorXd& features) const {
    check_size(features);
    return std::sqrt(((features - mean_).array() / scale_.array()).square().mean());
  }
  /// @brief Whether a calibration with these features followed the sequence (file comment).
  bool followed(const Eigen::VectorXd& features) const { return rms_z(features) <= kFollowedMargin * max_rms_z_; }
  /// @brief The largest RMS z-score among the people the model was fitted on.
  double max_rms_z() const noexcept { return max_rms_z_; }

  /// @brief Features per calibration: steps x (25 + cells).
  Eigen::Index feature_count() const noexcept {
    return static_cast<Eigen::Index>(sequence_.steps().size()) * (static_cast<Eigen::Index>(hand::kDofCount) + cells_);
  }
  /// @brief The sequence the model was fitted for.
  const Sequence& sequence() const noexcept { return sequence_; }
  /// @brief Calibrated cells per frame.
  int cells() const noexcept { return cells_; }
  /// @brief 25 x feature_count().
  const Eigen::MatrixXd& weight() const noexcept { return weight_; }
  /// @brief 25 offsets at zero features.
  const Eigen::VectorXd& bias() const noexcept { return bias_; }

  /// @brief The 25 offsets (radians) of a calibration with these features.
  hand::Angles offsets(const Eigen::VectorXd& features) const {
    check_size(features);
    const Eigen::VectorXd o = weight_ * features + bias_;
    hand::Angles out{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) out[d] = o(static_cast<Eigen::Index>(d));
    return out;
  }

  /// @brief The JSON text stored in a model file's metadata (key "pose_offset"; docs/calibration.md).
  std::string to_json() const {
    const auto numbers = [](const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
    io::json::Value weight = io::json::Value::array();
    for (Eigen::Index d = 0; d < weight_.rows(); ++d) weight.push_back(numbers(weight_.row(d).transpose()));
    const io::json::Value root = {{"format", kPoseOffsetFormat},
                                  {"version", 1},
                                  {"cells", cells_},
                                  {"sequence", io::json::parse(sequence_.to_json())},
                                  {"feature_mean", numbers(mean_)},
                                  {"feature_scale", numbers(scale_)},
                                  {"max_rms_z", max_rms_z_},
                                  {"bias", numbers(bias_)},
                                  {"weight", std::move(weight)}};
    return io::json::write(root);
  }

  /// @brief Parses to_json()'s text; `source` names it in messages.
  static PoseOffsetModel parse(const std::string& text, const std::string& source) {
    using io::json::Value;
    const io::json::Fields f("pose offset model '" + source + "': ");
    Value root;
    try {
      root = io::json::parse(text);
    } catch (const Error& e) {
      throw f.fail(e.what());
    }
    f.format(root, kPoseOffsetFormat, 1);
    const int cells = f.index(root, "cells", kMaxCells + 1, "the top level");
    if (cells < 1) throw f.fail("'cells' is 0, expected a count of cells 1.." + std::to_string(kMaxCells));
    Sequence sequence = Sequence::from_json(f.object(root, "sequence", "the top level"), source);
    const auto vector = [&](const Value& v, const std::string& what) {
      const std::vector<double> numbers = f.numbers(v, what);
      return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(numbers.data(), static_cast<Eigen::Index>(numbers.size())));
    };
    const Eigen::VectorXd bias = vector(f.array(root, "bias", "the top level"), "'bias'");
    const Value& rows = f.array(root, "weight", "the top level");
    if (rows.size() != hand::kDofCount) throw f.fail("'weight' has " + std::to_string(rows.size()) + " rows, expected 25");
    Eigen::MatrixXd weight;
    for (std::size_t d = 0; d < rows.size(); ++d) {
      const Eigen::VectorXd row = vector(rows[d], "'weight' row " + std::to_string(d));
      if (d == 0) weight.resize(static_cast<Eigen::Index>(hand::kDofCount), row.size());
      if (row.size() != weight.cols()) throw f.fail("'weight' rows differ in length");
      weight.row(static_cast<Eigen::Index>(d)) = row.transpose();
    }
    const Eigen::VectorXd mean = vector(f.array(root, "feature_mean", "the top level"), "'feature_mean'");
    const Eigen::VectorXd scale = vector(f.array(root, "feature_scale", "the top level"), "'feature_scale'");
    const double max_rms_z = f.number(root, "max_rms_z", "the top level");
    try {
      return PoseOffsetModel(std::move(sequence), cells, std::move(weight), bias, mean, scale, max_rms_z);
    } catch (const Error& e) {
      throw f.fail(e.what());
    }
  }

 private:
  static constexpr int kMaxCells = 100000;

  void check_size(const Eigen::VectorXd& features) const {
    if (features.size() != feature_count())
      throw Error("pose offset model: " + std::to_string(features.size()) + " features, expected " + std::to_string(feature_count()));
  }

  Sequence sequence_;
  int cells_;
  Eigen::MatrixXd weight_;
  Eigen::VectorXd bias_;
  Eigen::VectorXd mean_;
  Eigen::VectorXd scale_;
  double max_rms_z_;
};

}  // namespace glovepose::calibration
