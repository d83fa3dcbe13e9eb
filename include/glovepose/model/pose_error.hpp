/// @file pose_error.hpp
/// @brief What a model knows of its own errors, per DoF, measured on people it was not trained on
/// (fitted by `glovepose fit-guided`, train/pose_error_fit.hpp), and the per-joint confidence the
/// estimator derives from it every frame.
///
/// The error of DoF d on a frame is modelled as zero-mean normal with variance
///   sigma_d^2 = still_d(calibration)^2 + (speed_d * |rate_d|)^2 + sum over stood-in cells c of masked_cd^2
/// - still_d: the RMS error of a hand moving slowly, by the calibration in use (pose-guided, min-max,
///   the training set's range, or continuous after so many effective frames of free motion);
/// - speed_d (seconds): how the error grows with the DoF's own speed (rad/s; the estimator's rate);
/// - masked_cd: the RMS change of DoF d when cell c is stood in for from the others (a torn trace).
/// The confidence is the probability that the error is within a tolerance tau:
/// erf(tau / (sigma_d sqrt 2)). Measured calibration on new people in docs/results.md ("Confidence").
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "../config.hpp"
#include "../core/units.hpp"
#include "../hand/dofs.hpp"
#include "../io/json.hpp"

namespace glovepose::model {

/// @brief The metadata format name of a PoseErrorModel (key "pose_error").
inline constexpr const char* kPoseErrorFormat = "glovepose-pose-error";

/// @brief The calibration a pose was made with, as far as its error depends on it.
enum class ErrorCondition : std::uint8_t {
  Guided,      ///< Min-max plus pose-guided offsets.
  MinMax,      ///< Min-max over the user's calibration (or a range the user set), no offsets.
  Training,    ///< The model's training-set range.
  Continuous,  ///< The continuous calibration, after so many effective frames of free motion.
};

/// @brief Per-DoF errors of a model (file comment). Set-up code constructs and parses it; its
/// confidence() is per-frame (noexcept, allocation-free).
class PoseErrorModel {
 public:
  /// @brief The still error from `frames` effective frames of the continuous calibration on (degrees).
  struct Stage {
    double frames = 0.0;
    hand::Angles still_deg{};
  };

  PoseErrorModel() = default;
  /// @brief From its parts, degrees and seconds. `masked_deg` is cells x 25. Throws glovepose::Error
  /// for a negative or non-finite value, or continuous stages not starting at 0 frames and rising.
  PoseErrorModel(hand::Angles guided_deg, hand::Angles min_max_deg, std::optional<hand::Angles> training_deg, std::vector<Stage> continuous,
                 hand::Angles speed_seconds, Eigen::MatrixXd masked_deg)
      : guided_(guided_deg),
        min_max_(min_max_deg),
        training_(training_deg),
        continuous_(std::move(continuous)),
        speed_(speed_seconds),
        masked_(std::move(masked_deg)) {
    const auto check = [](const hand::Angles& a, const char* what) {
      for (double v : a)
        if (!(v >= 0.0) || !std::isfinite(v)) throw Error(std::string("pose error: '") + what + "' holds " + std::to_string(v) + ", expected finite values >= 0");
    };
    check(guided_, "guided");
    check(min_max_, "min_max");
    if (training_) check(*training_, "training");
    check(speed_, "speed");
    for (std::size_t s = 0; s < continuous_.size(); ++s) {
      check(continuous_[s].still_deg, "continuous");
      const double f = continuous_[s].frames;
      if (!std::isfinite(f) || (s == 0 ? f != 0.0 : !(f > continuous_[s - 1].frames)))
        throw Error("pose error: continuous stage " + std::to_string(s) + " at " + std::to_string(f) +
                    " frames, expected stages from 0 frames on, rising");
    }
    if (masked_.cols() != static_cast<Eigen::Index>(hand::kDofCount) || !masked_.allFinite() || (masked_.size() > 0 && masked_.minCoeff() < 0.0))
      throw Error("pose error: 'masked' is " + std::to_string(masked_.rows()) + " x " + std::to_string(masked_.cols()) +
                  ", expected one row of 25 finite values >= 0 per cell");
  }

  /// @brief Cells the masked table covers.
  Eigen::Index cells() const noexcept { return masked_.rows(); }
  const hand::Angles& guided_deg() const noexcept { return guided_; }
  const hand::Angles& min_max_deg() const noexcept { return min_max_; }
  const std::optional<hand::Angles>& training_deg() const noexcept { return training_; }
  const std::vector<Stage>& continuous() const noexcept { return continuous_; }
  const hand::Angles& speed_seconds() const noexcept { return speed_; }
  const Eigen::MatrixXd& masked_deg() const noexcept { return masked_; }

  /// @brief The still error (degrees) under `condition` (`frames`: the continuous calibration's
  /// effective frames); null when the model was not measured so.
  GLOVEPOSE_REALTIME const hand::Angles* still_deg(ErrorCondition condition, double frames) const noexcept {
    switch (condition) {
      case ErrorCondition::Guided: return &guided_;
      case ErrorCondition::MinMax: return &min_max_;
      case ErrorCondition::Training: return training_ ? &*training_ : nullptr;
      case ErrorCondition::Continuous: {
        if (continuous_.empty()) return nullptr;
        std::size_t s = 0;  // the last stage reached
        while (s + 1 < continuous_.size() && continuous_[s + 1].frames <= frames) ++s;
        return &continuous_[s].still_deg;
      }
    }
    return nullptr;
  }

  /// @brief Per DoF, the probability that the error is within `tolerance` (radians) on a frame
  /// made under `condition` after `frames` (continuous calibration), the angles moving at `rate`
  /// (rad/s; null: unknown, taken as still), cells `masked` (count `n`) stood in for. Returns false
  /// (and leaves `out` alone) when the model was not measured under `condition`.
  GLOVEPOSE_REALTIME bool confidence(ErrorCondition condition, double frames, const hand::Angles* rate, const int* masked, std::size_t n,
                                     double tolerance, hand::Angles& out) const noexcept {
    const hand::Angles* still = still_deg(condition, frames);
    if (still == nullptr) return false;
    const double tau = std::max(tolerance, 0.0) * core::kDegreesPerRadian;
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const double speed = rate != nullptr && std::isfinite((*rate)[d]) ? speed_[d] * std::abs((*rate)[d]) * core::kDegreesPerRadian : 0.0;
      double variance = (*still)[d] * (*still)[d] + speed * speed;
      for (std::size_t i = 0; i < n; ++i)
        if (masked[i] >= 0 && masked[i] < masked_.rows()) variance += masked_(masked[i], static_cast<Eigen::Index>(d)) * masked_(masked[i], static_cast<Eigen::Index>(d));
      out[d] = variance > 0.0 ? std::erf(tau / std::sqrt(2.0 * variance)) : 1.0;
    }
    return true;
  }

  /// @brief The JSON text stored in a model file's metadata (key "pose_error"; docs/calibration.md).
  std::string to_json() const {
    const auto list = [](const hand::Angles& a) { return std::vector<double>(a.begin(), a.end()); };
    io::json::Value stages = io::json::Value::array();
    for (const Stage& s : continuous_) stages.push_back({{"frames", s.frames}, {"still_deg", list(s.still_deg)}});
    io::json::Value masked = io::json::Value::array();
    for (Eigen::Index c = 0; c < masked_.rows(); ++c) {
      const Eigen::VectorXd row = masked_.row(c).transpose();
      masked.push_back(std::vector<double>(row.data(), row.data() + row.size()));
    }
    io::json::Value root = {{"format", kPoseErrorFormat}, {"version", 1},           {"guided_deg", list(guided_)},
                            {"min_max_deg", list(min_max_)}, {"continuous", std::move(stages)}, {"speed_seconds", list(speed_)},
                            {"masked_deg", std::move(masked)}};
    if (training_) root["training_deg"] = list(*training_);
    return io::json::write(root);
  }

  /// @brief Parses to_json()'s text; `source` names it in messages.
  static PoseErrorModel parse(const std::string& text, const std::string& source) {
    using io::json::Value;
    const io::json::Fields f("pose error '" + source + "': ");
    Value root;
    try {
      root = io::json::parse(text);
    } catch (const Error& e) {
      throw f.fail(e.what());
    }
    f.format(root, kPoseErrorFormat, 1);
    const auto angles = [&](const Value& v, const std::string& what) {
      const std::vector<double> numbers = f.numbers(v, what);
      if (numbers.size() != hand::kDofCount)
        throw f.fail(what + " holds " + std::to_string(numbers.size()) + " numbers, expected 25 (one per DoF)");
      hand::Angles a{};
      std::copy(numbers.begin(), numbers.end(), a.begin());
      return a;
    };
    const std::string top = "the top level";
    const hand::Angles guided = angles(f.array(root, "guided_deg", top), "'guided_deg'");
    const hand::Angles min_max = angles(f.array(root, "min_max_deg", top), "'min_max_deg'");
    std::optional<hand::Angles> training;
    if (root.contains("training_deg")) training = angles(f.array(root, "training_deg", top), "'training_deg'");
    const hand::Angles speed = angles(f.array(root, "speed_seconds", top), "'speed_seconds'");
    std::vector<Stage> stages;
    const Value& list = f.array(root, "continuous", top);
    for (std::size_t s = 0; s < list.size(); ++s) {
      const std::string where = "continuous stage " + std::to_string(s);
      if (!list[s].is_object()) throw f.fail(where + " is " + io::json::describe(list[s]) + ", expected an object");
      stages.push_back(Stage{f.number(list[s], "frames", where), angles(f.array(list[s], "still_deg", where), where + " 'still_deg'")});
    }
    const Value& rows = f.array(root, "masked_deg", top);
    Eigen::MatrixXd masked(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(hand::kDofCount));
    for (std::size_t c = 0; c < rows.size(); ++c) {
      const hand::Angles row = angles(rows[c], "'masked_deg' row " + std::to_string(c));
      for (std::size_t d = 0; d < hand::kDofCount; ++d) masked(static_cast<Eigen::Index>(c), static_cast<Eigen::Index>(d)) = row[d];
    }
    try {
      return PoseErrorModel(guided, min_max, training, std::move(stages), speed, std::move(masked));
    } catch (const Error& e) {
      throw f.fail(e.what());
    }
  }

 private:
  hand::Angles guided_{}, min_max_{};
  std::optional<hand::Angles> training_;
  std::vector<Stage> continuous_;
  hand::Angles speed_{};
  Eigen::MatrixXd masked_ = Eigen::MatrixXd(0, static_cast<Eigen::Index>(hand::kDofCount));
};

}  // namespace glovepose::model
