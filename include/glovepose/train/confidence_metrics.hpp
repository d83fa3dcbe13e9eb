/// @file confidence_metrics.hpp
/// @brief Whether a per-joint confidence (Pose::confidence, model/pose_error.hpp) means something,
/// scored over joint-frames against the true errors: the mean error of the quarter of joint-frames
/// with the lowest confidence over the quarter with the highest (all DoFs pooled, and the median of
/// that ratio within each DoF), and the mean confidence beside the share actually within the
/// tolerance (a calibrated confidence has the two equal). What `glovepose eval` reports as
/// "confidence" and tools/experiments/confidence.cpp prints for the streamed estimator.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "../hand/dofs.hpp"

namespace glovepose::train {

/// @brief The scores of a confidence (see the file comment).
struct ConfidenceReport {
  double tolerance_deg = 0.0;         ///< The confidence's tolerance.
  long joint_frames = 0;              ///< Joint-frames scored.
  double mean_error_deg = 0.0;        ///< Their mean |error|.
  double mean_confidence = 0.0;       ///< Their mean confidence.
  double share_within = 0.0;          ///< The share whose |error| is within the tolerance.
  double quarter_error_ratio = 0.0;   ///< Mean error of the lowest-confidence quarter over the highest's.
  double within_dof_ratio = 0.0;      ///< The same ratio within each DoF, the median over the DoFs.
};

/// @brief Collects joint-frames (|error|, confidence) and scores them.
class ConfidenceAccumulator {
 public:
  explicit ConfidenceAccumulator(double tolerance_deg) : tolerance_deg_(tolerance_deg) {}

  /// @brief One joint-frame of DoF `dof`: its |error| (degrees) and its confidence.
  void add(std::size_t dof, double error_deg, double confidence) {
    frames_.push_back({static_cast<float>(std::abs(error_deg)), static_cast<float>(confidence), static_cast<std::uint8_t>(dof)});
  }
  bool empty() const noexcept { return frames_.empty(); }

  ConfidenceReport report() const {
    ConfidenceReport r;
    r.tolerance_deg = tolerance_deg_;
    r.joint_frames = static_cast<long>(frames_.size());
    for (const JointFrame& j : frames_) {
      r.mean_error_deg += j.error;
      r.mean_confidence += j.confidence;
      r.share_within += j.error <= tolerance_deg_ ? 1.0 : 0.0;
    }
    const double n = static_cast<double>(std::max<std::size_t>(frames_.size(), 1));
    r.mean_error_deg /= n;
    r.mean_confidence /= n;
    r.share_within /= n;
    r.quarter_error_ratio = quarter_ratio(frames_);
    std::vector<double> per_dof;
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      std::vector<JointFrame> one;
      for (const JointFrame& j : frames_)
        if (j.dof == d) one.push_back(j);
      const double ratio = quarter_ratio(std::move(one));
      if (std::isfinite(ratio)) per_dof.push_back(ratio);
    }
    if (!per_dof.empty()) {
      std::sort(per_dof.begin(), per_dof.end());
      const std::size_t h = per_dof.size() / 2;
      r.within_dof_ratio = per_dof.size() % 2 ? per_dof[h] : 0.5 * (per_dof[h - 1] + per_dof[h]);
    } else {
      r.within_dof_ratio = std::numeric_limits<double>::quiet_NaN();
    }
    return r;
  }

 private:
  struct JointFrame {
    float error;
    float confidence;
    std::uint8_t dof;
  };

  // Mean error of the lowest-confidence quarter over the highest's (ties keep the frames' order);
  // NaN for fewer than 8 joint-frames or an error-free top quarter.
  static double quarter_ratio(std::vector<JointFrame> v) {
    if (v.size() < 8) return std::numeric_limits<double>::quiet_NaN();
    std::stable_sort(v.begin(), v.end(), [](const JointFrame& a, const JointFrame& b) { return a.confidence < b.confidence; });
    const std::size_t q = v.size() / 4;
    double low = 0.0, high = 0.0;
    for (std::size_t i = 0; i < q; ++i) {
      low += v[i].error;
      high += v[v.size() - 1 - i].error;
    }
    return high > 0.0 ? low / high : std::numeric_limits<double>::quiet_NaN();
  }

  double tolerance_deg_;
  std::vector<JointFrame> frames_;
};

/// @brief The report as JSON: "tolerance_deg", "joint_frames", "mean_error_deg", "mean_confidence",
/// "share_within_tolerance", "quarter_error_ratio", "within_dof_ratio" (null when not defined).
inline std::string confidence_json(const ConfidenceReport& r) {
  const auto number = [](double v) {
    if (!std::isfinite(v)) return std::string("null");
    char text[32];
    std::snprintf(text, sizeof text, "%.6g", v);
    return std::string(text);
  };
  return "{\"tolerance_deg\": " + number(r.tolerance_deg) + ", \"joint_frames\": " + std::to_string(r.joint_frames) +
         ", \"mean_error_deg\": " + number(r.mean_error_deg) + ", \"mean_confidence\": " + number(r.mean_confidence) +
         ", \"share_within_tolerance\": " + number(r.share_within) + ", \"quarter_error_ratio\": " + number(r.quarter_error_ratio) +
         ", \"within_dof_ratio\": " + number(r.within_dof_ratio) + "}";
}

}  // namespace glovepose::train
