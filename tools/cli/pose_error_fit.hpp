// The per-DoF errors behind each pose's confidence (include/glovepose/model/pose_error.hpp),
// measured by streaming people the model was not trained on through the estimator as a user runs
// it: after their guided calibration (pose-guided and min-max), with the training set's range, and
// from their first frame with the continuous calibration; plus the cost of standing in for each
// cell. It composes the estimator, so it lives with the tool (`glovepose fit-guided`), above train/.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <glovepose/calibration/free_motion.hpp>
#include <glovepose/calibration/pose_offset.hpp>
#include <glovepose/core/thread_pool.hpp>
#include <glovepose/core/units.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/io/dataset.hpp>
#include <glovepose/model/pose_error.hpp>
#include <glovepose/pose_model.hpp>
#include <glovepose/sensor/calibration.hpp>
#include <glovepose/sensor/floating_cells_config.hpp>
#include <glovepose/train/samples.hpp>

namespace glovepose::cli {

/// The continuous calibration's error is measured per stage of effective frames from here on.
inline const std::vector<double>& pose_error_stages() {
  static const std::vector<double> stages = {0, 25, 50, 100, 200, 400, 800, 1600, 3200};
  return stages;
}

/// What fit_pose_error measured, with the figures it prints.
struct PoseErrorFit {
  model::PoseErrorModel model;
  long runs = 0;                 // runs streamed
  long frames = 0;               // trusted frames scored per condition, summed over the conditions
  double guided_rms_deg = 0.0;   // over the DoFs, the default calibration's still error
  double speed_share = 0.0;      // share of the default calibration's error variance the speed term explains
  double masked_rms_deg = 0.0;   // over cells and DoFs, the stand-in's RMS change
};

namespace detail {

// Per DoF sums of the squared error (deg^2) and squared speed ((deg/s)^2) of scored frames.
struct ErrorSums {
  std::array<double, hand::kDofCount> n{}, x{}, xx{}, y{}, xy{};
  std::map<std::int64_t, bool> runs;
  void add(const hand::Angles& error_deg, const hand::Angles& rate, bool has_rate) {
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const double v = has_rate ? rate[d] * core::kDegreesPerRadian : 0.0;
      const double e2 = error_deg[d] * error_deg[d], v2 = v * v;
      n[d] += 1.0;
      x[d] += v2;
      xx[d] += v2 * v2;
      y[d] += e2;
      xy[d] += e2 * v2;
    }
  }
  void merge(const ErrorSums& o) {
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      n[d] += o.n[d];
      x[d] += o.x[d];
      xx[d] += o.xx[d];
      y[d] += o.y[d];
      xy[d] += o.xy[d];
    }
    for (const auto& [k, v] : o.runs) runs[k] = v;
  }
  bool empty() const { return n[0] == 0.0; }
  // Per DoF, the still error (deg) left when the speed term `b` (deg^2 per (deg/s)^2) is taken out.
  hand::Angles still(const hand::Angles& b) const {
    hand::Angles a{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) a[d] = std::sqrt(std::max(0.0, (y[d] - b[d] * x[d]) / std::max(n[d], 1.0)));
    return a;
  }
  // Per DoF, the least-squares slope of the squared error on the squared speed, at least 0.
  hand::Angles slope() const {
    hand::Angles b{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const double mx = x[d] / n[d], my = y[d] / n[d];
      const double var = xx[d] / n[d] - mx * mx, cov = xy[d] / n[d] - mx * my;
      b[d] = var > 0.0 ? std::max(0.0, cov / var) : 0.0;
    }
    return b;
  }
};

enum Condition { kGuided, kMinMax, kTraining, kConditions };

// The frames of one run, in order: its calibration frames, then its recording frames.
struct RunFrames {
  std::int64_t key = 0;
  std::vector<std::size_t> calibration, recording;
};

inline std::vector<RunFrames> runs_of(const io::Dataset& data, const train::FrameFilter& filter) {
  std::map<std::int64_t, RunFrames> runs;
  for (std::size_t i = 0; i < data.frames(); ++i) {
    if (!filter.selects_run(data, i) || data.kind[i] == io::kKindRemoval) continue;  // a removal has no pose to score
    RunFrames& run = runs[train::run_key(data, i)];
    run.key = train::run_key(data, i);
    (data.kind[i] == io::kKindCalibration ? run.calibration : run.recording).push_back(i);
  }
  std::vector<RunFrames> out;
  for (auto& [key, run] : runs)
    if (!run.recording.empty()) out.push_back(std::move(run));
  return out;
}

// Streams `frames` into `estimator`, adding each trusted pose's error against the truth (the labels
// when the data has none; unlabelled DoFs count 0) to sums[stage of its motion frames] (one stage:
// `stages` empty).
inline void score(GlovePoseEstimator& estimator, const io::Dataset& data, const std::vector<std::size_t>& frames, std::int64_t key,
                  const std::vector<double>& stages, std::vector<ErrorSums>& sums) {
  const auto cells = static_cast<int>(data.cell_count);
  const std::vector<float>& truth = data.has_true_angles() ? data.true_angles : data.angles;
  std::vector<double> row(data.cell_count);
  for (std::size_t i : frames) {
    for (std::size_t c = 0; c < data.cell_count; ++c) row[c] = data.cells[i * data.cell_count + c];
    if (estimator.push_cells(row.data(), cells, data.timestamps[i]) != Status::Solved || !estimator.pose().trusted()) continue;
    const Pose& pose = estimator.pose();
    hand::Angles error{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const double t = truth[i * hand::kDofCount + d];
      error[d] = std::isfinite(t) ? (pose.angles[d] - t) * core::kDegreesPerRadian : 0.0;
    }
    const HandState state = estimator.state();
    std::size_t stage = 0;
    while (stage + 1 < stages.size() && stages[stage + 1] <= state.calibration.motion_frames) ++stage;
    sums[stage].add(error, state.rate, state.has_rate);
    sums[stage].runs[key] = true;
  }
}

// Per cell, the mean and covariance of the run's recording cells, and the least-squares weights of
// each cell on the others (the stand-in sensor::FloatingCells computes online).
inline Eigen::MatrixXd standin_weights(const Eigen::MatrixXd& x, Eigen::VectorXd& mean, double ridge) {
  mean = x.colwise().mean().transpose();
  const Eigen::MatrixXd centred = x.rowwise() - mean.transpose();
  const Eigen::MatrixXd cov = centred.transpose() * centred / static_cast<double>(std::max<Eigen::Index>(x.rows() - 1, 1));
  const Eigen::Index n = cov.rows();
  Eigen::MatrixXd weights = Eigen::MatrixXd::Zero(n, n);  // column c: weights of the others for cell c
  for (Eigen::Index c = 0; c < n; ++c) {
    Eigen::MatrixXd system = cov;
    system.row(c).setZero();
    system.col(c).setZero();
    system(c, c) = 1.0;
    const double variance = (cov.diagonal().sum() - cov(c, c)) / static_cast<double>(n - 1);
    system.diagonal().array() += ridge * variance + std::numeric_limits<double>::min();
    Eigen::VectorXd target = cov.col(c);
    target(c) = 0.0;
    weights.col(c) = system.ldlt().solve(target);
    weights(c, c) = 0.0;
  }
  return weights;
}

}  // namespace detail

/// Measures `model`'s per-DoF errors on the selected runs of `data` (people it was not trained
/// on; runs need a guided calibration's frames for the guided, min-max and stand-in terms).
/// `masked_runs` runs, `masked_frames` frames each, measure the stand-in. Throws glovepose::Error
/// when no run has both calibration and recording frames.
inline PoseErrorFit fit_pose_error(const std::shared_ptr<const PoseModel>& model, const io::Dataset& data, const train::FrameFilter& filter,
                                   core::ThreadPool& pool, long masked_runs = 100, long masked_frames = 300, long min_runs = 10) {
  const std::vector<detail::RunFrames> runs = detail::runs_of(data, filter);
  const bool guided = model->pose_offset().has_value();
  const bool training = model->training_range().has_value();
  const bool continuous = model->range_map().has_value();
  const std::vector<double>& stages = pose_error_stages();
  std::mutex merge_mutex;
  std::vector<detail::ErrorSums> fixed(detail::kConditions), moving(stages.size());
  std::vector<std::size_t> calibrated;  // runs with a guided calibration's frames
  for (std::size_t r = 0; r < runs.size(); ++r)
    if (!runs[r].calibration.empty()) calibrated.push_back(r);
  if (calibrated.size() < static_cast<std::size_t>(min_runs))
    throw Error("pose error: " + std::to_string(calibrated.size()) + " runs with a calibration and a recording, expected at least " +
                std::to_string(min_runs));
  pool.for_shares(static_cast<long>(runs.size()), [&](core::Range share, int) {
    std::vector<detail::ErrorSums> own_fixed(detail::kConditions), own_moving(stages.size());
    const std::vector<double> one;
    for (long r = share.begin; r < share.end; ++r) {
      const detail::RunFrames& run = runs[static_cast<std::size_t>(r)];
      EstimatorConfig config;
      config.continuous_calibration = false;
      if (!run.calibration.empty()) {
        for (const CalibrationMethod method : {CalibrationMethod::Auto, CalibrationMethod::MinMax}) {
          if (method == CalibrationMethod::Auto && !guided) continue;
          config.calibration_method = method;
          GlovePoseEstimator estimator(model, config);
          estimator.start_calibration();
          std::vector<detail::ErrorSums> ignored(1);
          detail::score(estimator, data, run.calibration, run.key, one, ignored);  // no range yet: no pose
          try {
            (void)estimator.finish_calibration();
          } catch (const Error&) {
            continue;  // too short a calibration: the run has no calibrated condition
          }
          const int condition = estimator.calibration_method() == CalibrationMethod::PoseGuided ? detail::kGuided : detail::kMinMax;
          std::vector<detail::ErrorSums> sums(1);
          detail::score(estimator, data, run.recording, run.key, one, sums);
          own_fixed[static_cast<std::size_t>(condition)].merge(sums[0]);
        }
      }
      if (training) {
        GlovePoseEstimator estimator(model, config);
        estimator.use_training_calibration();
        std::vector<detail::ErrorSums> sums(1);
        detail::score(estimator, data, run.recording, run.key, one, sums);
        own_fixed[detail::kTraining].merge(sums[0]);
      }
      if (continuous) {
        GlovePoseEstimator estimator(model, config);
        estimator.use_continuous_calibration();
        detail::score(estimator, data, run.recording, run.key, stages, own_moving);
      }
    }
    const std::lock_guard<std::mutex> lock(merge_mutex);
    for (std::size_t c = 0; c < fixed.size(); ++c) fixed[c].merge(own_fixed[c]);
    for (std::size_t s = 0; s < moving.size(); ++s) moving[s].merge(own_moving[s]);
  });
  const detail::ErrorSums& base = fixed[guided && !fixed[detail::kGuided].empty() ? detail::kGuided : detail::kMinMax];
  if (base.empty()) throw Error("pose error: no calibrated run gave a trusted pose, expected runs whose calibration frames make a range");
  const hand::Angles slope = base.slope();
  hand::Angles speed_seconds{};
  for (std::size_t d = 0; d < hand::kDofCount; ++d) speed_seconds[d] = std::sqrt(slope[d]);
  const hand::Angles guided_deg = base.still(slope);
  const hand::Angles min_max_deg = fixed[detail::kMinMax].empty() ? guided_deg : fixed[detail::kMinMax].still(slope);
  std::optional<hand::Angles> training_deg;
  if (!fixed[detail::kTraining].empty()) training_deg = fixed[detail::kTraining].still(slope);
  // Continuous stages that enough runs reached; a stage fewer reached joins the one before it.
  std::vector<model::PoseErrorModel::Stage> continuous_stages;
  detail::ErrorSums pending;
  double pending_frames = 0.0;
  for (std::size_t s = 0; s < moving.size(); ++s) {
    if (pending.empty()) pending_frames = stages[s];
    pending.merge(moving[s]);
    if (static_cast<long>(pending.runs.size()) < min_runs) continue;
    continuous_stages.push_back({continuous_stages.empty() ? 0.0 : pending_frames, pending.still(slope)});
    pending = detail::ErrorSums{};
  }
  // The stand-in's cost per cell: each cell replaced by its regression on the others, fitted on the
  // run's own recording; the change of the angles (the network and the joint limits; no offsets:
  // they cancel) over a spread of its frames.
  const auto cells = static_cast<Eigen::Index>(data.cell_count);
  const std::map<std::int64_t, sensor::CalibrationRange> ranges = train::onthefly_ranges(data, model->glove().calibration());
  std::vector<std::size_t> chosen;
  for (std::size_t k = 0; k < calibrated.size() && static_cast<long>(chosen.size()) < masked_runs; ++k)
    chosen.push_back(calibrated[k * calibrated.size() / static_cast<std::size_t>(std::min<long>(masked_runs, static_cast<long>(calibrated.size())))]);
  chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());
  Eigen::MatrixXd masked_sum = Eigen::MatrixXd::Zero(cells, static_cast<Eigen::Index>(hand::kDofCount));
  double masked_count = 0.0;
  const double ridge = sensor::FloatingCellsConfig{}.ridge;
  pool.for_shares(static_cast<long>(chosen.size()), [&](core::Range share, int) {
    Eigen::MatrixXd own = Eigen::MatrixXd::Zero(cells, static_cast<Eigen::Index>(hand::kDofCount));
    double own_count = 0.0;
    for (long k = share.begin; k < share.end; ++k) {
      const detail::RunFrames& run = runs[chosen[static_cast<std::size_t>(k)]];
      const auto range = ranges.find(run.key);
      if (range == ranges.end()) continue;
      const auto n = static_cast<Eigen::Index>(run.recording.size());
      Eigen::MatrixXd x(n, cells);
      for (Eigen::Index f = 0; f < n; ++f)
        for (Eigen::Index c = 0; c < cells; ++c) x(f, c) = data.cells[run.recording[static_cast<std::size_t>(f)] * data.cell_count + static_cast<std::size_t>(c)];
      Eigen::VectorXd mean;
      const Eigen::MatrixXd weights = detail::standin_weights(x, mean, ridge);
      const Eigen::Index picked = std::min<Eigen::Index>(n, masked_frames);
      std::vector<float> intact(static_cast<std::size_t>(picked * cells));
      for (Eigen::Index p = 0; p < picked; ++p)
        for (Eigen::Index c = 0; c < cells; ++c) intact[static_cast<std::size_t>(p * cells + c)] = static_cast<float>(x(p * n / picked, c));
      const std::vector<hand::Angles> reference = model->predict(intact.data(), picked, range->second);
      std::vector<float> stood = intact;
      for (Eigen::Index c = 0; c < cells; ++c) {
        for (Eigen::Index p = 0; p < picked; ++p) {
          const Eigen::VectorXd deviation = x.row(p * n / picked).transpose() - mean;
          stood[static_cast<std::size_t>(p * cells + c)] = static_cast<float>(mean(c) + weights.col(c).dot(deviation));
        }
        const std::vector<hand::Angles> changed = model->predict(stood.data(), picked, range->second);
        for (Eigen::Index p = 0; p < picked; ++p) {
          stood[static_cast<std::size_t>(p * cells + c)] = intact[static_cast<std::size_t>(p * cells + c)];
          for (std::size_t d = 0; d < hand::kDofCount; ++d) {
            const double delta = (changed[static_cast<std::size_t>(p)][d] - reference[static_cast<std::size_t>(p)][d]) * core::kDegreesPerRadian;
            own(c, static_cast<Eigen::Index>(d)) += delta * delta;
          }
        }
      }
      own_count += static_cast<double>(picked);
    }
    const std::lock_guard<std::mutex> lock(merge_mutex);
    masked_sum += own;
    masked_count += own_count;
  });
  if (!(masked_count > 0.0)) throw Error("pose error: no run to measure the stand-in on, expected runs with an on-the-fly range");
  const Eigen::MatrixXd masked_deg = (masked_sum / masked_count).cwiseSqrt();
  PoseErrorFit fit{model::PoseErrorModel(guided_deg, min_max_deg, training_deg, std::move(continuous_stages), speed_seconds, masked_deg)};
  fit.runs = static_cast<long>(runs.size());
  for (const detail::ErrorSums& s : fixed) fit.frames += static_cast<long>(s.n[0]);
  for (const detail::ErrorSums& s : moving) fit.frames += static_cast<long>(s.n[0]);
  double still = 0.0, total = 0.0;
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    still += guided_deg[d] * guided_deg[d];
    total += base.y[d] / base.n[d];
  }
  fit.guided_rms_deg = std::sqrt(still / hand::kDofCount);
  fit.speed_share = total > 0.0 ? 1.0 - still / total : 0.0;
  fit.masked_rms_deg = std::sqrt(masked_deg.squaredNorm() / static_cast<double>(masked_deg.size()));
  return fit;
}

}  // namespace glovepose::cli
