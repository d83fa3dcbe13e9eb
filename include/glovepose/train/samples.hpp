/// @file samples.hpp
/// @brief From a Dataset to what a network sees: calibrated cell values and normalised targets,
/// under the paper's three calibration modes (Sec. 4.3 and 5.2, Table 1 columns 3 and 4):
///   - none:      the solved capacitances as they are (pF);
///   - training:  per-cell min-max over the training frames, stored in the model and applied to
///                every frame later ("generic model without calibration");
///   - onthefly:  per session, the min-max of that session's own calibration sequence with a
///                20-frame median ("with calibration"): what a new user does in a minute.
/// Frames used are recording frames whose reference pose is not a collision outlier (the paper
/// drops those, about 2%).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include <Eigen/Core>

#include "../config.hpp"
#include "../model/model_info.hpp"
#include "../grid/glove_description.hpp"
#include "../hand/dofs.hpp"
#include "../sensor/calibration.hpp"
#include "../io/dataset.hpp"

namespace glovepose::train {

/// @brief Names "cell_0".."cell_{n-1}" for calibration ranges.
inline std::vector<std::string> cell_names(std::size_t n) {
  std::vector<std::string> names;
  for (std::size_t c = 0; c < n; ++c) names.push_back("cell_" + std::to_string(c));
  return names;
}

/// @brief Which frames of a dataset to use.
struct FrameFilter {
  std::vector<int> subjects;   ///< Subject ids to keep; empty: all.
  std::vector<int> sessions;   ///< Session ids to keep; empty: all.
  std::vector<int> gloves;     ///< Glove ids to keep; empty: all.
  bool keep_outliers = false;  ///< Keep frames flagged as collision outliers.

  /// @brief Whether recording frame `i` of `data` is kept (calibration frames never are).
  bool keeps(const io::Dataset& data, std::size_t i) const noexcept {
    return data.kind[i] == io::kKindRecording && (keep_outliers || data.outlier[i] == 0) && selects_run(data, i);
  }
  /// @brief Whether frame `i` of `data`, of any kind, belongs to a selected subject, session and glove.
  bool selects_run(const io::Dataset& data, std::size_t i) const noexcept {
    const auto in = [](const std::vector<int>& list, int v) {
      return list.empty() || std::find(list.begin(), list.end(), v) != list.end();
    };
    return in(subjects, data.subject[i]) && in(sessions, data.session[i]) && in(gloves, data.glove[i]);
  }
};

/// @brief Frames ready for a network: inputs (frames x cells) and targets (frames x 25, normalised
/// by the joint limits), with the true angles and the frame's origin for reports and splits.
struct Samples {
  int cells = 0;               ///< Values per input row.
  std::vector<float> inputs;   ///< frames x cells, calibrated.
  std::vector<float> targets;  ///< frames x 25 in [-1, 1] within the joint limits; a DoF not labelled: its rest pose (JointLimits::rest()).
  std::vector<float> angles;   ///< frames x 25 true angles, radians; NaN for a DoF not labelled.
  hand::DofSet labelled = hand::all_dofs();  ///< The DoFs with reference angles: the only ones trained and scored.
  /// Sensors the calibration maps to 0 because their range was flat (CalibrationRange::flat_sensors()),
  /// per calibrated run (its run key; -1 for the training range), for the runs that have any.
  std::map<std::int64_t, std::vector<std::string>> zeroed;
  std::vector<std::int64_t> run;     ///< Per frame: (subject, glove, session) packed, for splits.
  std::vector<std::int64_t> source;  ///< Per frame: its index in the dataset.

  /// @brief Number of frames.
  long frames() const noexcept { return static_cast<long>(source.size()); }

  /// @brief The frames whose positions `keep` lists, in that order.
  Samples subset(const std::vector<long>& keep) const {
    Samples s;
    s.cells = cells;
    s.labelled = labelled;
    for (long i : keep) {
      s.inputs.insert(s.inputs.end(), inputs.begin() + i * cells, inputs.begin() + (i + 1) * cells);
      s.targets.insert(s.targets.end(), targets.begin() + i * 25, targets.begin() + (i + 1) * 25);
      s.angles.insert(s.angles.end(), angles.begin() + i * 25, angles.begin() + (i + 1) * 25);
      s.run.push_back(run[static_cast<std::size_t>(i)]);
      s.source.push_back(source[static_cast<std::size_t>(i)]);
    }
    return s;
  }
};

/// @brief (subject, glove, session) of frame `i`, packed in one number (RunId reads it back).
inline std::int64_t run_key(const io::Dataset& data, std::size_t i) noexcept {
  return (static_cast<std::int64_t>(data.subject[i]) << 40) | (static_cast<std::int64_t>(data.glove[i]) << 20) |
         static_cast<std::int64_t>(data.session[i]);
}

/// @brief The fields of a run key (run_key): one person's recording session with one glove.
struct RunId {
  int subject = 0;  ///< The person.
  int glove = 0;    ///< The glove.
  int session = 0;  ///< The session.

  /// @brief The fields packed in `key` (a run_key of a dataset frame, so >= 0).
  static RunId of(std::int64_t key) noexcept {
    return {static_cast<int>(key >> 40), static_cast<int>((key >> 20) & 0xfffff), static_cast<int>(key & 0xfffff)};
  }
  /// @brief "subject S, glove G, session N", as messages name a run.
  std::string text() const {
    return "subject " + std::to_string(subject) + ", glove " + std::to_string(glove) + ", session " + std::to_string(session);
  }
};

/// @brief Per-cell min and max over the kept frames: the "training" calibration, flat sensors by
/// the glove's rule. Throws glovepose::Error when no frame is kept.
inline sensor::CalibrationRange training_range(const io::Dataset& data, const FrameFilter& filter,
                                               const grid::GloveCalibration& calibration = {}) {
  const std::size_t cells = data.cell_count;
  Eigen::VectorXd lo = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(cells), HUGE_VAL);
  Eigen::VectorXd hi = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(cells), -HUGE_VAL);
  long kept = 0;
  for (std::size_t i = 0; i < data.frames(); ++i) {
    if (!filter.keeps(data, i)) continue;
    ++kept;
    for (std::size_t c = 0; c < cells; ++c) {
      const double v = data.cells[i * cells + c];
      lo(static_cast<Eigen::Index>(c)) = std::min(lo(static_cast<Eigen::Index>(c)), v);
      hi(static_cast<Eigen::Index>(c)) = std::max(hi(static_cast<Eigen::Index>(c)), v);
    }
  }
  if (kept == 0) throw Error("training calibration: no frame of the dataset passes the selection, expected at least one");
  return sensor::CalibrationRange(lo, hi, cell_names(cells), calibration.config());
}

/// @brief The on-the-fly range of every run (subject, glove, session) that has calibration frames:
/// the running-median min-max over the session's calibration sequence, the median spanning the
/// glove's median_seconds at the dataset's frame rate (the paper's 20 frames at 60 Hz by default),
/// flat sensors by the glove's rule.
inline std::map<std::int64_t, sensor::CalibrationRange> onthefly_ranges(const io::Dataset& data,
                                                                        const grid::GloveCalibration& calibration = {}) {
  const int median_window = calibration.median_frames(data.frame_rate());
  std::map<std::int64_t, sensor::OnTheFlyCalibrator> calibrators;
  const std::vector<std::string> names = cell_names(data.cell_count);
  Eigen::VectorXd frame(static_cast<Eigen::Index>(data.cell_count));
  for (std::size_t i = 0; i < data.frames(); ++i) {
    if (data.kind[i] != io::kKindCalibration) continue;
    auto it = calibrators.find(run_key(data, i));
    if (it == calibrators.end())
      it = calibrators.emplace(run_key(data, i), sensor::OnTheFlyCalibrator(names, median_window, calibration.config())).first;
    for (std::size_t c = 0; c < data.cell_count; ++c) frame(static_cast<Eigen::Index>(c)) = data.cells[i * data.cell_count + c];
    it->second.add(frame);
  }
  std::map<std::int64_t, sensor::CalibrationRange> ranges;
  for (const auto& [key, calibrator] : calibrators)
    if (calibrator.ready()) ranges.emplace(key, calibrator.finish());
  return ranges;
}

/// @brief The kept frames of `data`, every `stride`-th, calibrated by `mode` (`range` is the
/// training range for CalibrationMode::Training) with targets normalised by `limits`. Throws
/// glovepose::Error when the dataset has no angles, a run lacks its calibration sequence in
/// on-the-fly mode, or no frame is kept. On the fly, the glove's `calibration` settings apply.
inline Samples make_samples(const io::Dataset& data, const FrameFilter& filter, model::CalibrationMode mode,
                            const sensor::CalibrationRange* range, const hand::JointLimits& limits, int stride = 1,
                            const grid::GloveCalibration& calibration = {}) {
  if (!data.has_angles()) throw Error("samples: the dataset has no ground-truth angles, expected a recording with angles");
  if (stride < 1) throw Error("samples: stride " + std::to_string(stride) + ", expected >= 1");
  if (mode == model::CalibrationMode::Training && (range == nullptr || static_cast<std::size_t>(range->size()) != data.cell_count))
    throw Error("samples: training calibration needs a range of " + std::to_string(data.cell_count) + " cells");
  const std::map<std::int64_t, sensor::CalibrationRange> runs =
      mode == model::CalibrationMode::OnTheFly ? onthefly_ranges(data, calibration) : std::map<std::int64_t, sensor::CalibrationRange>{};
  Samples s;
  s.cells = static_cast<int>(data.cell_count);
  s.labelled = data.labelled_dofs();
  const hand::Angles rest = limits.rest();
  const Eigen::Index cells = static_cast<Eigen::Index>(data.cell_count);
  Eigen::VectorXd raw(cells), normalized(cells);
  std::map<std::int64_t, long> seen;  // per run, kept frames so far (the stride counts within a run)
  for (std::size_t i = 0; i < data.frames(); ++i) {
    if (!filter.keeps(data, i)) continue;
    const std::int64_t key = run_key(data, i);
    if (seen[key]++ % stride != 0) continue;
    for (Eigen::Index c = 0; c < cells; ++c) raw(c) = data.cells[i * data.cell_count + static_cast<std::size_t>(c)];
    if (mode == model::CalibrationMode::None) {
      normalized = raw;
    } else {
      const sensor::CalibrationRange* r = range;
      if (mode == model::CalibrationMode::OnTheFly) {
        const auto it = runs.find(key);
        if (it == runs.end())
          throw Error("samples: subject " + std::to_string(data.subject[i]) + ", glove " + std::to_string(data.glove[i]) + ", session " +
                      std::to_string(data.session[i]) +
                      " has no calibration sequence (kind 1 frames), expected one for on-the-fly calibration");
        r = &it->second;
      }
      r->normalize(raw, normalized);
    }
    for (Eigen::Index c = 0; c < cells; ++c) s.inputs.push_back(static_cast<float>(normalized(c)));
    hand::Angles truth{};
    hand::Angles toward{};  // what the network learns: the truth, or the rest pose where there is none
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      truth[d] = data.angles[i * hand::kDofCount + d];
      toward[d] = s.labelled[d] ? truth[d] : rest[d];
    }
    const hand::Angles target = limits.normalize(toward);
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      s.targets.push_back(static_cast<float>(target[d]));
      s.angles.push_back(static_cast<float>(truth[d]));
    }
    s.run.push_back(key);
    s.source.push_back(static_cast<std::int64_t>(i));
  }
  if (s.frames() == 0) throw Error("samples: no recording frame of the dataset passes the selection, expected at least one");
  if (mode == model::CalibrationMode::Training && !range->flat_sensors().empty()) s.zeroed[-1] = range->flat_sensors();
  for (const auto& [key, count] : seen)
    if (const auto it = runs.find(key); it != runs.end() && !it->second.flat_sensors().empty()) s.zeroed[key] = it->second.flat_sensors();
  return s;
}

/// @brief Splits samples into (training, validation): the last `fraction` of every run's frames
/// validate, so neighbouring (nearly equal) frames do not sit on both sides.
inline std::pair<Samples, Samples> split_validation(const Samples& all, double fraction) {
  if (!(fraction >= 0.0 && fraction < 1.0)) throw Error("validation fraction must be in [0, 1)");
  std::map<std::int64_t, long> total, seen;
  for (std::int64_t k : all.run) ++total[k];
  std::vector<long> train, validate;
  for (long i = 0; i < all.frames(); ++i) {
    const std::int64_t k = all.run[static_cast<std::size_t>(i)];
    const long cut = total[k] - static_cast<long>(std::floor(fraction * static_cast<double>(total[k])));
    (seen[k]++ < cut ? train : validate).push_back(i);
  }
  return {all.subset(train), all.subset(validate)};
}

}  // namespace glovepose::train
