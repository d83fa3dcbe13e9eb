/// @file guided_calibration.hpp
/// @brief Pose-guided calibration on datasets: the features of every recorded calibration sequence
/// as a model sees it, the offsets a model's PoseOffsetModel gives them, and fitting that
/// PoseOffsetModel on people the network was not trained on (calibration/pose_offset.hpp).
///
/// A run (subject, glove, session) whose calibration frames (kind 1) followed a guided sequence is
/// read as the estimator reads it live: the sequence's clock starts at the run's first calibration
/// frame, the cells are calibrated by the run's on-the-fly min-max, and each step's holding frames
/// are averaged.
///
/// Set-up code: allocates, throws glovepose::Error naming what is wrong.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Cholesky>

#include "../calibration/pose_offset.hpp"
#include "../calibration/sequence.hpp"
#include "metrics.hpp"
#include "model_file.hpp"
#include "samples.hpp"

namespace glovepose::train {

/// @brief The calibration frames of one run, calibrated by the run's on-the-fly range, with the
/// seconds since the run's first calibration frame.
struct CalibrationRun {
  Samples frames;             ///< Inputs only (targets and angles as recorded, if any).
  std::vector<double> times;  ///< Per frame, seconds since the first calibration frame.
};

/// @brief The calibration frames of every selected run (by subject, session and glove of `filter`)
/// that has a complete on-the-fly range.
inline std::map<std::int64_t, CalibrationRun> calibration_runs(const io::Dataset& data, const FrameFilter& filter,
                                                               const grid::GloveCalibration& calibration = {}) {
  const std::map<std::int64_t, sensor::CalibrationRange> ranges = onthefly_ranges(data, calibration);
  FrameFilter all_kinds = filter;
  all_kinds.keep_outliers = true;
  std::map<std::int64_t, CalibrationRun> runs;
  const auto cells = static_cast<Eigen::Index>(data.cell_count);
  Eigen::VectorXd raw(cells), normalized(cells);
  for (std::size_t i = 0; i < data.frames(); ++i) {
    if (data.kind[i] != io::kKindCalibration || !all_kinds.selects_run(data, i)) continue;
    const std::int64_t key = run_key(data, i);
    const auto range = ranges.find(key);
    if (range == ranges.end()) continue;
    CalibrationRun& run = runs[key];
    if (run.frames.cells == 0) run.frames.cells = static_cast<int>(cells);
    for (Eigen::Index c = 0; c < cells; ++c) raw(c) = data.cells[i * data.cell_count + static_cast<std::size_t>(c)];
    range->second.normalize(raw, normalized);
    for (Eigen::Index c = 0; c < cells; ++c) run.frames.inputs.push_back(static_cast<float>(normalized(c)));
    run.frames.run.push_back(key);
    run.frames.source.push_back(static_cast<std::int64_t>(i));
    run.times.push_back(data.timestamps[i] - data.timestamps[static_cast<std::size_t>(run.frames.source.front())]);
  }
  return runs;
}

/// @brief The sequence a dataset's calibrations followed must be `sequence`: throws glovepose::Error
/// when the dataset's metadata names another one or none.
inline void check_guided(const io::Dataset& data, const calibration::Sequence& sequence) {
  const auto it = data.metadata.find("calibration_sequence");
  if (it == data.metadata.end())
    throw Error(
        "the dataset records no guided calibration (metadata 'calibration_sequence'), expected calibrations that followed sequence '" +
        sequence.id() + "' (glovepose simulate --calibration-sequence FILE)");
  if (it->second != sequence.id())
    throw Error("the dataset's calibrations followed sequence '" + it->second + "', expected '" + sequence.id() + "'");
}

/// @brief The pose-guided features (calibration::StepHoldMeans) of every run of `runs`, as `model`
/// sees them. Runs whose sequence was not performed to the end are left out and listed in `incomplete`.
inline std::map<std::int64_t, Eigen::VectorXd> guided_features(TrainedModel& model, const calibration::Sequence& sequence,
                                                               const std::map<std::int64_t, CalibrationRun>& runs, core::ThreadPool& pool,
                                                               std::vector<std::int64_t>* incomplete = nullptr) {
  const hand::JointLimits limits = model.info.joint_limits();
  std::map<std::int64_t, Eigen::VectorXd> features;
  for (const auto& [key, run] : runs) {
    const std::vector<float> normalized = model.predict(run.frames, pool, nullptr, false);  // as the estimator's offsets see them
    calibration::StepHoldMeans means(sequence, run.frames.cells);
    for (long f = 0; f < run.frames.frames(); ++f) {
      hand::Angles n{};
      for (std::size_t d = 0; d < hand::kDofCount; ++d) n[d] = normalized[static_cast<std::size_t>(f) * hand::kDofCount + d];
      means.add(run.times[static_cast<std::size_t>(f)], limits.denormalize(n), run.frames.inputs.data() + f * run.frames.cells);
    }
    if (!means.missing_step().empty()) {
      if (incomplete) incomplete->push_back(key);
      continue;
    }
    features.emplace(key, means.features());
  }
  return features;
}

/// @brief The pose-guided offsets (radians) of every selected run, from the PoseOffsetModel the
/// model file carries. Throws glovepose::Error when it carries none, when the dataset's calibrations
/// followed another sequence, or naming the first run whose sequence is incomplete.
inline std::map<std::int64_t, hand::Angles> guided_offsets(TrainedModel& model, const io::Dataset& data, const FrameFilter& filter,
                                                           core::ThreadPool& pool) {
  if (!model.info.pose_offset)
    throw Error("the model carries no pose-guided calibration (metadata 'pose_offset'), expected one fitted by glovepose fit-guided");
  const calibration::PoseOffsetModel& offsets = *model.info.pose_offset;
  if (offsets.cells() != model.info.inputs)
    throw Error("the pose-guided calibration reads " + std::to_string(offsets.cells()) + " cells, the model " +
                std::to_string(model.info.inputs));
  check_guided(data, offsets.sequence());
  std::vector<std::int64_t> incomplete;
  const auto features =
      guided_features(model, offsets.sequence(), calibration_runs(data, filter, model.glove.calibration()), pool, &incomplete);
  if (!incomplete.empty())
    throw Error(RunId::of(incomplete.front()).text() + ": the calibration sequence was not performed to the end, expected every step of '" + offsets.sequence().id() + "'");
  std::map<std::int64_t, hand::Angles> out;
  for (const auto& [key, f] : features) {
    if (!offsets.followed(f))
      throw Error(RunId::of(key).text() + ": the calibration does not look like sequence '" + offsets.sequence().id() + "' (RMS z-score " +
                  std::to_string(offsets.rms_z(f)) + " against at most " +
                  std::to_string(calibration::kFollowedMargin * offsets.max_rms_z()) + " among the fitted people)");
    out.emplace(key, offsets.offsets(f));
  }
  return out;
}

/// @brief Ridge least squares y ~ weight x + bias on standardised columns of x (rows are samples):
/// minimises |Z W - (y - mean y)|^2 + ridge * rows * |W|^2 with Z = (x - mean x) / sd x (a constant
/// column keeps sd 1), the intercept unpenalised; returns weight (y.cols() x x.cols()) and bias
/// in the units of x. ridge = 0 is ordinary least squares (x of full column rank).
inline void fit_ridge(const Eigen::MatrixXd& x, const Eigen::MatrixXd& y, double ridge, Eigen::MatrixXd& weight, Eigen::VectorXd& bias) {
  const Eigen::RowVectorXd mean = x.colwise().mean();
  Eigen::RowVectorXd scale = ((x.rowwise() - mean).array().square().colwise().mean()).sqrt();
  for (Eigen::Index j = 0; j < scale.size(); ++j)
    if (!(scale(j) > 1e-12)) scale(j) = 1.0;
  const Eigen::MatrixXd z = (x.rowwise() - mean).array().rowwise() / scale.array();
  const Eigen::RowVectorXd y_mean = y.colwise().mean();
  Eigen::MatrixXd gram = z.transpose() * z;
  gram.diagonal().array() += ridge * static_cast<double>(x.rows());
  const Eigen::MatrixXd wz = gram.ldlt().solve(z.transpose() * (y.rowwise() - y_mean));  // x.cols() x y.cols()
  weight = (wz.array().colwise() / scale.transpose().array()).transpose();
  bias = y_mean.transpose() - weight * mean.transpose();
}

/// @brief What fit_pose_offset made and how well it generalises.
struct PoseOffsetFit {
  calibration::PoseOffsetModel model;  ///< The fitted map.
  double ridge = 0.0;                  ///< Ridge strength chosen by cross-validation (on standardised features).
  long runs = 0;                       ///< Runs (calibrations with session frames) fitted on.
  double cv_error_deg = 0.0;           ///< Cross-validated mean absolute error of the offsets, degrees.
  double baseline_error_deg = 0.0;     ///< The same without any offset (mean |true mean error|), degrees.
};

/// @brief Fits the PoseOffsetModel of `model` for `sequence` on the selected runs of `data` (people
/// the network was not trained on): per run, the features of its calibration and the mean of
/// (true - predicted) angles over its session frames; ridge least squares on standardised features,
/// the ridge strength chosen from `ridges` by `folds`-fold cross-validation over the runs. Throws
/// glovepose::Error when fewer than 2 x folds runs are usable.
inline PoseOffsetFit fit_pose_offset(TrainedModel& model, const calibration::Sequence& sequence, const io::Dataset& recorded,
                                     const FrameFilter& filter, core::ThreadPool& pool,
                                     const std::vector<double>& ridges = {0.003, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0}, int folds = 5) {
  std::optional<io::Dataset> storage;
  const io::Dataset& data = conditioned_for(recorded, model.glove, storage);  // as the estimator conditions its inputs
  check_guided(data, sequence);
  const hand::JointLimits limits = model.info.joint_limits();
  const std::map<std::int64_t, Eigen::VectorXd> features =
      guided_features(model, sequence, calibration_runs(data, filter, model.glove.calibration()), pool);
  const Samples session = make_samples(data, filter, model::CalibrationMode::OnTheFly, nullptr, limits, 1, model.glove.calibration());
  const std::vector<float> predicted = model.predict(session, pool, nullptr, false);  // the offsets are added before the limits
  std::map<std::int64_t, Eigen::VectorXd> residual_sum;
  std::map<std::int64_t, long> residual_count;
  for (long f = 0; f < session.frames(); ++f) {
    const std::int64_t key = session.run[static_cast<std::size_t>(f)];
    hand::Angles n{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) n[d] = predicted[static_cast<std::size_t>(f) * hand::kDofCount + d];
    const hand::Angles radians = limits.denormalize(n);
    Eigen::VectorXd& sum = residual_sum.try_emplace(key, Eigen::VectorXd::Zero(hand::kDofCount)).first->second;
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      sum(static_cast<Eigen::Index>(d)) += session.angles[static_cast<std::size_t>(f) * hand::kDofCount + d] - radians[d];
    ++residual_count[key];
  }
  std::vector<std::int64_t> keys;
  for (const auto& [key, f] : features)
    if (residual_count.count(key)) keys.push_back(key);
  const auto n = static_cast<Eigen::Index>(keys.size());
  if (n < 2 * folds)
    throw Error("fit-guided: " + std::to_string(n) + " runs with a complete guided calibration and session frames, expected at least " +
                std::to_string(2 * folds));
  const Eigen::Index width = features.at(keys.front()).size();
  Eigen::MatrixXd x(n, width), y(n, static_cast<Eigen::Index>(hand::kDofCount));
  for (Eigen::Index r = 0; r < n; ++r) {
    const std::int64_t key = keys[static_cast<std::size_t>(r)];
    x.row(r) = features.at(key).transpose();
    y.row(r) = (residual_sum.at(key) / static_cast<double>(residual_count.at(key))).transpose();
  }
  double best_error = std::numeric_limits<double>::infinity(), best_ridge = ridges.front();
  for (double ridge : ridges) {
    double error = 0.0;
    for (int fold = 0; fold < folds; ++fold) {
      std::vector<Eigen::Index> fit_rows, test_rows;
      for (Eigen::Index r = 0; r < n; ++r) (r % folds == fold ? test_rows : fit_rows).push_back(r);
      Eigen::MatrixXd weight;
      Eigen::VectorXd bias;
      fit_ridge(x(fit_rows, Eigen::all), y(fit_rows, Eigen::all), ridge, weight, bias);
      const Eigen::MatrixXd predicted_offsets = (x(test_rows, Eigen::all) * weight.transpose()).rowwise() + bias.transpose();
      error += (predicted_offsets - y(test_rows, Eigen::all)).cwiseAbs().sum();
    }
    error /= static_cast<double>(n * y.cols());
    if (error < best_error) best_error = error, best_ridge = ridge;
  }
  Eigen::MatrixXd weight;
  Eigen::VectorXd bias;
  fit_ridge(x, y, best_ridge, weight, bias);
  // What the fitted people's calibrations look like, to tell later whether a user followed the sequence.
  const Eigen::VectorXd mean = x.colwise().mean().transpose();
  Eigen::VectorXd scale = ((x.rowwise() - mean.transpose()).array().square().colwise().mean()).sqrt().transpose();
  for (Eigen::Index j = 0; j < scale.size(); ++j)
    if (!(scale(j) > 1e-9)) scale(j) = 1e-9;
  double max_rms_z = 0.0;
  for (Eigen::Index r = 0; r < n; ++r)
    max_rms_z = std::max(max_rms_z, std::sqrt(((x.row(r).transpose() - mean).array() / scale.array()).square().mean()));
  PoseOffsetFit fit{calibration::PoseOffsetModel(sequence, model.info.inputs, std::move(weight), std::move(bias), mean, scale, max_rms_z),
                    best_ridge, static_cast<long>(n), best_error * core::kDegreesPerRadian, y.cwiseAbs().mean() * core::kDegreesPerRadian};
  return fit;
}

}  // namespace glovepose::train
