/// @file range_map_fit.hpp
/// @brief Fitting a calibration::RangeMap (calibration/free_motion.hpp) on people the model was
/// not trained on: per run, its guided calibration's min-max range (the target) and the
/// percentiles of its free motion as a MotionHistogram kept them when it held each stage's frames.
///
/// Set-up code: allocates, throws glovepose::Error naming what is missing.
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/QR>

#include "../calibration/free_motion.hpp"
#include "../io/dataset.hpp"
#include "samples.hpp"

namespace glovepose::train {

/// @brief The histograms' frames at which a fit places a stage (those at least `min_runs` runs reach).
inline const std::vector<double>& default_range_stages() {
  static const std::vector<double> stages = {25, 50, 100, 200, 400, 800, 1600, 3200};
  return stages;
}

/// @brief What fit_range_map made, with the fit people's own figures.
struct RangeMapFit {
  calibration::RangeMap map;  ///< The fitted map.
  long runs = 0;              ///< Runs with a guided calibration and free motion.
  /// Per stage: the runs that reached it and the mean |limit - target| over them and the cells in
  /// units of each cell's prior range, by the stage's map (cross-validated over 5 folds) and by the prior.
  struct StageFigures {
    double frames = 0.0;
    long runs = 0;
    double map_error = 0.0;
    double prior_error = 0.0;
  };
  std::vector<StageFigures> stages;
};

namespace detail {

// Per cell, least squares of `y` on `x` (runs x kRangeFeatures), with a ridge of `ridge` x runs on
// the percentiles' weights (the features scaled by the cell's prior range first).
inline Eigen::VectorXd fit_limit(const Eigen::MatrixXd& x, const Eigen::VectorXd& y, double span, double ridge) {
  Eigen::MatrixXd z = x;
  z.rightCols(z.cols() - 1) /= span;
  Eigen::MatrixXd gram = z.transpose() * z;
  gram.diagonal().tail(gram.rows() - 1).array() += ridge * static_cast<double>(x.rows());
  Eigen::VectorXd w = gram.colPivHouseholderQr().solve(z.transpose() * y);
  w.tail(w.size() - 1) /= span;
  return w;
}

}  // namespace detail

/// @brief Fits a RangeMap on the selected runs of `data` (conditioned as the model's estimator
/// conditions its inputs) that have a guided calibration (kind-1 frames; their on-the-fly range
/// with the glove's `calibration` settings is the target) and recording frames (the free motion,
/// in time order). A stage of `stage_frames` is kept when at least `min_runs` runs reach it.
/// Throws glovepose::Error when fewer than `min_runs` runs are usable or none reaches a stage.
inline RangeMapFit fit_range_map(const io::Dataset& data, const FrameFilter& filter, const grid::GloveCalibration& calibration,
                                 const calibration::MotionHistogramConfig& histogram = {},
                                 const std::vector<double>& stage_frames = default_range_stages(), double ridge = 1e-4,
                                 long min_runs = 10) {
  const std::map<std::int64_t, sensor::CalibrationRange> targets = onthefly_ranges(data, calibration);
  const auto cells = static_cast<Eigen::Index>(data.cell_count);
  std::vector<std::int64_t> keys;
  for (const auto& [key, range] : targets) keys.push_back(key);
  // Only runs with free motion too.
  std::map<std::int64_t, bool> moving;
  for (std::size_t i = 0; i < data.frames(); ++i)
    if (data.kind[i] == io::kKindRecording && filter.selects_run(data, i)) moving[run_key(data, i)] = true;
  keys.erase(std::remove_if(keys.begin(), keys.end(), [&](std::int64_t k) { return !moving.count(k); }), keys.end());
  const auto runs = static_cast<long>(keys.size());
  if (runs < min_runs)
    throw Error("fit range map: " + std::to_string(runs) + " runs with a guided calibration and free motion, expected at least " +
                std::to_string(min_runs));
  Eigen::VectorXd prior_min = Eigen::VectorXd::Zero(cells), prior_max = Eigen::VectorXd::Zero(cells);
  for (std::int64_t key : keys) prior_min += targets.at(key).min(), prior_max += targets.at(key).max();
  prior_min /= static_cast<double>(runs);
  prior_max /= static_cast<double>(runs);
  const Eigen::VectorXd span = prior_max - prior_min;

  // Per run, the features when its histograms first held each stage's frames.
  std::map<std::int64_t, std::vector<std::optional<Eigen::MatrixXd>>> features;
  std::map<std::int64_t, calibration::MotionHistogram> histograms;
  Eigen::VectorXd frame(cells);
  for (std::size_t i = 0; i < data.frames(); ++i) {
    if (data.kind[i] != io::kKindRecording || !filter.selects_run(data, i)) continue;
    const std::int64_t key = run_key(data, i);
    if (!targets.count(key)) continue;
    auto h = histograms.find(key);
    if (h == histograms.end()) {
      h = histograms.emplace(key, calibration::MotionHistogram(prior_min, prior_max, histogram)).first;
      features[key].resize(stage_frames.size());
    }
    for (Eigen::Index c = 0; c < cells; ++c) frame(c) = data.cells[i * data.cell_count + static_cast<std::size_t>(c)];
    if (!h->second.add(frame)) continue;
    std::vector<std::optional<Eigen::MatrixXd>>& at = features[key];
    for (std::size_t s = 0; s < stage_frames.size(); ++s) {
      if (at[s] || h->second.effective_frames() < stage_frames[s]) continue;
      Eigen::MatrixXd x(cells, calibration::kRangeFeatures);
      double row[calibration::kRangeFeatures];
      for (Eigen::Index c = 0; c < cells; ++c) {
        h->second.features(c, row);
        for (int k = 0; k < calibration::kRangeFeatures; ++k) x(c, k) = row[k];
      }
      at[s] = std::move(x);
    }
  }

  std::vector<calibration::RangeMap::Stage> stages;
  RangeMapFit fit{calibration::RangeMap(prior_min, prior_max, {}, histogram), runs, {}};
  for (std::size_t s = 0; s < stage_frames.size(); ++s) {
    std::vector<std::int64_t> reached;
    for (std::int64_t key : keys)
      if (features[key][s]) reached.push_back(key);
    const auto n = static_cast<Eigen::Index>(reached.size());
    if (n < min_runs) continue;
    calibration::RangeMap::Stage stage{stage_frames[s], Eigen::MatrixXd(cells, calibration::kRangeFeatures),
                                       Eigen::MatrixXd(cells, calibration::kRangeFeatures)};
    RangeMapFit::StageFigures figures{stage_frames[s], static_cast<long>(n), 0.0, 0.0};
    for (Eigen::Index c = 0; c < cells; ++c) {
      Eigen::MatrixXd x(n, calibration::kRangeFeatures);
      Eigen::VectorXd lo(n), hi(n);
      for (Eigen::Index r = 0; r < n; ++r) {
        const std::int64_t key = reached[static_cast<std::size_t>(r)];
        x.row(r) = features[key][s]->row(c);
        lo(r) = targets.at(key).min()(c);
        hi(r) = targets.at(key).max()(c);
      }
      stage.low.row(c) = detail::fit_limit(x, lo, span(c), ridge).transpose();
      stage.high.row(c) = detail::fit_limit(x, hi, span(c), ridge).transpose();
      // 5-fold cross-validation of the same fit, and the prior's error, in prior ranges.
      for (int fold = 0; fold < 5; ++fold) {
        std::vector<Eigen::Index> train_rows, test_rows;
        for (Eigen::Index r = 0; r < n; ++r) (r % 5 == fold ? test_rows : train_rows).push_back(r);
        if (train_rows.size() < static_cast<std::size_t>(calibration::kRangeFeatures) || test_rows.empty()) continue;
        Eigen::MatrixXd xt(static_cast<Eigen::Index>(train_rows.size()), x.cols());
        Eigen::VectorXd lt(xt.rows()), ht(xt.rows());
        for (Eigen::Index k = 0; k < xt.rows(); ++k) {
          const Eigen::Index r = train_rows[static_cast<std::size_t>(k)];
          xt.row(k) = x.row(r), lt(k) = lo(r), ht(k) = hi(r);
        }
        const Eigen::VectorXd wl = detail::fit_limit(xt, lt, span(c), ridge), wh = detail::fit_limit(xt, ht, span(c), ridge);
        for (Eigen::Index r : test_rows) {
          figures.map_error += (std::abs(x.row(r).dot(wl) - lo(r)) + std::abs(x.row(r).dot(wh) - hi(r))) / span(c);
          figures.prior_error += (std::abs(prior_min(c) - lo(r)) + std::abs(prior_max(c) - hi(r))) / span(c);
        }
      }
    }
    figures.map_error /= 2.0 * static_cast<double>(n * cells);
    figures.prior_error /= 2.0 * static_cast<double>(n * cells);
    fit.stages.push_back(figures);
    stages.push_back(std::move(stage));
  }
  if (stages.empty())
    throw Error("fit range map: no run's free motion filled the first stage's " + std::to_string(stage_frames.front()) +
                " frames, expected longer sessions of free motion");
  fit.map = calibration::RangeMap(prior_min, prior_max, std::move(stages), histogram);
  return fit;
}

}  // namespace glovepose::train
