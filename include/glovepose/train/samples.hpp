/// @file samples.hpp
/// @brief From a Dataset to what a network sees: calibrated cell values and normalised targets,
/// under the paper's three calibration modes (Sec. 4.3 and 5.2, Table 1 columns 3 and 4):
///   - none:      the solved capacitances as they are (pF);
///   - training:  per-cell min-max over the training frames, stored in the model and applied to
///                every frame later ("generic model without calibration");
///   - onthefly:  per session, the min-max of that session's own calibration sequence with a
///                20-frame median ("with calibration"): what a new user does in a minute;
///   - continuous: no calibration step: per run, the range the model's range map keeps from the
///                run's free motion up to each frame (calibration/free_motion.hpp), as the
///                estimator keeps it (evaluation only).
/// Frames used are recording frames whose reference pose is not a collision outlier (the paper
/// drops those, about 2%).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <Eigen/Core>

#include "../calibration/free_motion.hpp"
#include "../config.hpp"
#include "../model/model_info.hpp"
#include "../grid/glove_description.hpp"
#include "../hand/dofs.hpp"
#include "../sensor/calibration.hpp"
#include "../sensor/input_conditioning.hpp"
#include "../sensor/readout_config.hpp"
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
  /// Session seconds (since the run's first recording frame) whose frames make_samples keeps:
  /// [from_seconds, to_seconds).
  double from_seconds = 0.0;
  double to_seconds = std::numeric_limits<double>::infinity();

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
  /// Per frame under CalibrationMode::Continuous: the free motion its run's calibration had taken,
  /// in effective frames (calibration::MotionHistogram::effective_frames); empty otherwise.
  std::vector<float> motion_frames;

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
      if (!motion_frames.empty()) s.motion_frames.push_back(motion_frames[static_cast<std::size_t>(i)]);
    }
    return s;
  }
};

/// @brief (subject, glove, session) of frame `i`, packed in one number (RunId reads it back).
inline std::int64_t run_key(const io::Dataset& data, std::size_t i) noexcept {
  return (static_cast<std::int64_t>(data.subject[i]) << 40) | (static_cast<std::int64_t>(data.glove[i]) << 20) |
         static_cast<std::int64_t>(data.session[i]);
}

/// @brief `data` with its cells conditioned as `glove` says (its demean_seconds; sensor::
/// InputConditioner), made in `storage`: a stream starts over at each run (subject, glove,
/// session), where time does not go forward and after a gap of more than `gap_seconds`, as the
/// estimator starts over. `data` itself when the glove conditions nothing or `data` is conditioned
/// so already (metadata "conditioning"); throws glovepose::Error when it was conditioned otherwise.
inline const io::Dataset& conditioned_for(const io::Dataset& data, const grid::GloveDescription& glove, std::optional<io::Dataset>& storage,
                                          double gap_seconds = sensor::ReadoutConfig{}.gap_seconds) {
  const std::vector<int> windows = glove.demean_frames();
  std::string marker;
  for (const int w : windows) marker += (marker.empty() ? "demean frames " : ",") + std::to_string(w);
  const auto done = data.metadata.find("conditioning");
  if (done != data.metadata.end()) {
    if (done->second == marker) return data;
    throw Error("the dataset's cells are conditioned as '" + done->second + "', expected " +
                (marker.empty() ? std::string("none") : "'" + marker + "'") + " (glove '" + glove.id() + "'): give the data as recorded");
  }
  if (windows.empty()) return data;
  if (data.cell_count != windows.size())
    throw Error("the dataset has " + std::to_string(data.cell_count) + " cells per frame, glove '" + glove.id() + "' conditions " +
                std::to_string(windows.size()) + " inputs");
  io::Dataset& out = storage.emplace(data);
  sensor::InputConditioner conditioner(windows);
  std::vector<double> frame(data.cell_count);
  for (std::size_t i = 0; i < data.frames(); ++i) {
    const bool starts = i == 0 || run_key(data, i) != run_key(data, i - 1) || !(data.timestamps[i] > data.timestamps[i - 1]) ||
                        data.timestamps[i] - data.timestamps[i - 1] > gap_seconds;
    if (starts) conditioner.reset();
    float* cells = out.cells.data() + i * data.cell_count;
    for (std::size_t c = 0; c < data.cell_count; ++c) frame[c] = cells[c];
    conditioner.apply(frame.data(), frame.data());
    for (std::size_t c = 0; c < data.cell_count; ++c) cells[c] = static_cast<float>(frame[c]);
  }
  out.metadata["conditioning"] = marker;
  return out;
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
/// on-the-fly mode, or no frame is kept. On the fly, the glove's `glove_calibration` settings apply.
/// CalibrationMode::Continuous follows each run's free motion from its first recording frame with
/// `range_map` (every recording frame of a selected run, kept or not, feeds it).
inline Samples make_samples(const io::Dataset& data, const FrameFilter& filter, model::CalibrationMode mode,
                            const sensor::CalibrationRange* range, const hand::JointLimits& limits, int stride = 1,
                            const grid::GloveCalibration& glove_calibration = {}, const glovepose::calibration::RangeMap* range_map = nullptr) {
  if (!data.has_angles()) throw Error("samples: the dataset has no ground-truth angles, expected a recording with angles");
  if (stride < 1) throw Error("samples: stride " + std::to_string(stride) + ", expected >= 1");
  if (mode == model::CalibrationMode::Training && (range == nullptr || static_cast<std::size_t>(range->size()) != data.cell_count))
    throw Error("samples: training calibration needs a range of " + std::to_string(data.cell_count) + " cells");
  if (mode == model::CalibrationMode::Continuous && (range_map == nullptr || static_cast<std::size_t>(range_map->cells()) != data.cell_count))
    throw Error("samples: continuous calibration needs a range map of " + std::to_string(data.cell_count) +
                " cells, expected a model fitted by glovepose fit-guided");
  // Per run under continuous calibration, the wearer's motion so far and the range it gives.
  struct Following {
    glovepose::calibration::ContinuousRange motion;
    sensor::CalibrationRange range;
  };
  std::map<std::int64_t, Following> following;
  std::map<std::int64_t, double> run_start;  // per run, its first recording frame's time
  const std::map<std::int64_t, sensor::CalibrationRange> runs =
      mode == model::CalibrationMode::OnTheFly ? onthefly_ranges(data, glove_calibration) : std::map<std::int64_t, sensor::CalibrationRange>{};
  Samples s;
  s.cells = static_cast<int>(data.cell_count);
  s.labelled = data.labelled_dofs();
  const hand::Angles rest = limits.rest();
  const Eigen::Index cells = static_cast<Eigen::Index>(data.cell_count);
  Eigen::VectorXd raw(cells), normalized(cells);
  std::map<std::int64_t, long> seen;  // per run, kept frames so far (the stride counts within a run)
  for (std::size_t i = 0; i < data.frames(); ++i) {
    if (data.kind[i] != io::kKindRecording || !filter.selects_run(data, i)) continue;
    const std::int64_t key = run_key(data, i);
    const double since = data.timestamps[i] - run_start.try_emplace(key, data.timestamps[i]).first->second;
    for (Eigen::Index c = 0; c < cells; ++c) raw(c) = data.cells[i * data.cell_count + static_cast<std::size_t>(c)];
    Following* follow = nullptr;
    if (mode == model::CalibrationMode::Continuous) {
      auto it = following.find(key);
      if (it == following.end())
        it = following
                 .emplace(key, Following{glovepose::calibration::ContinuousRange(*range_map),
                                         sensor::CalibrationRange(range_map->prior_min(), range_map->prior_max(), cell_names(data.cell_count),
                                                                  glove_calibration.config())})
                 .first;
      follow = &it->second;
      if (raw.allFinite() && follow->motion.add(raw, data.timestamps[i])) (void)follow->range.move_limits(follow->motion.min(), follow->motion.max());
    }
    if (!filter.keeps(data, i) || !(since >= filter.from_seconds && since < filter.to_seconds)) continue;
    if (seen[key]++ % stride != 0) continue;
    if (mode == model::CalibrationMode::None) {
      normalized = raw;
    } else {
      const sensor::CalibrationRange* r = follow ? &follow->range : range;
      if (mode == model::CalibrationMode::OnTheFly) {
        const auto it = runs.find(key);
        if (it == runs.end())
          throw Error("samples: subject " + std::to_string(data.subject[i]) + ", glove " + std::to_string(data.glove[i]) + ", session " +
                      std::to_string(data.session[i]) +
                      " has no calibration sequence (kind 1 frames), expected one for on-the-fly calibration: import the "
                      "session's calibration take with it (glovepose import --calibration FILE, the same subject and session), or "
                      "choose --calibration-mode training (the training frames' range, stored in the model) or none");
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
    if (follow) s.motion_frames.push_back(static_cast<float>(follow->motion.histogram().effective_frames()));
  }
  if (s.frames() == 0) throw Error("samples: no recording frame of the dataset passes the selection, expected at least one");
  if (mode == model::CalibrationMode::Training && !range->flat_sensors().empty()) s.zeroed[-1] = range->flat_sensors();
  for (const auto& [key, count] : seen)
    if (const auto it = runs.find(key); it != runs.end() && !it->second.flat_sensors().empty()) s.zeroed[key] = it->second.flat_sensors();
  return s;
}

/// @brief How training sets frames aside to score and pick a model.
enum class ValidationSplit {
  Auto,    ///< Runs when the samples hold two runs or more, else Frames.
  Runs,    ///< Whole runs it never trains on: the last runs of the data, about `fraction` of the frames
           ///< (at least one run, never all). What a new session or take will see.
  Frames,  ///< The last `fraction` of every run's frames, so that neighbouring (nearly equal) frames
           ///< do not sit on both sides. Optimistic: the same session validates.
};

/// @brief Training and validation samples, and which frames validate, in words for the user.
struct ValidationParts {
  Samples training, validation;
  std::string description;
};

/// @brief Splits `all` into training and validation samples as `how` says; `fraction` 0 keeps no
/// validation. Throws glovepose::Error for a fraction outside [0, 1) or Runs with one run.
inline ValidationParts split_validation(const Samples& all, double fraction, ValidationSplit how = ValidationSplit::Auto) {
  if (!(fraction >= 0.0 && fraction < 1.0)) throw Error("validation fraction must be in [0, 1)");
  std::vector<std::int64_t> order;  // runs in order of their first frame
  std::map<std::int64_t, long> total, seen;
  for (std::int64_t k : all.run)
    if (total[k]++ == 0) order.push_back(k);
  if (how == ValidationSplit::Runs && order.size() < 2)
    throw Error("validation on held-out runs: the selected frames are one run (" + (order.empty() ? std::string("none") : RunId::of(order[0]).text()) +
                "), expected two or more (each take its own session), or validation on frames (the last part of the run)");
  if (how == ValidationSplit::Auto) how = order.size() >= 2 ? ValidationSplit::Runs : ValidationSplit::Frames;
  std::vector<long> train, validate;
  std::string description;
  if (fraction == 0.0) {
    description = "none (validation fraction 0)";
  } else if (how == ValidationSplit::Runs) {
    std::set<std::int64_t> held;
    long held_frames = 0;
    for (auto k = order.rbegin(); k + 1 != order.rend() && static_cast<double>(held_frames) < fraction * static_cast<double>(all.frames()); ++k) {
      held.insert(*k);
      held_frames += total[*k];
    }
    std::string names;
    std::size_t named = 0;
    for (std::int64_t k : order)
      if (held.count(k) && named++ < 4) names += (names.empty() ? "" : "; ") + RunId::of(k).text();
    if (named > 4) names += "; ...";
    description = std::to_string(held.size()) + " held-out run" + (held.size() == 1 ? "" : "s") + " of " +
                        std::to_string(order.size()) + ", never trained on (" + std::to_string(held_frames) + " frames): " + names;
    for (long i = 0; i < all.frames(); ++i) (held.count(all.run[static_cast<std::size_t>(i)]) ? validate : train).push_back(i);
    return {all.subset(train), all.subset(validate), description};
  } else {
    char share[32];
    std::snprintf(share, sizeof share, "%g%%", 100.0 * fraction);
    description = std::string("the last ") + share + " of the frames of each of " + std::to_string(order.size()) + " run" +
                        (order.size() == 1 ? "" : "s") + " (the same sessions it trains on: optimistic for a new session)";
  }
  for (long i = 0; i < all.frames(); ++i) {
    const std::int64_t k = all.run[static_cast<std::size_t>(i)];
    const long cut = total[k] - static_cast<long>(std::floor(fraction * static_cast<double>(total[k])));
    (seen[k]++ < cut ? train : validate).push_back(i);
  }
  return {all.subset(train), all.subset(validate), description};
}

}  // namespace glovepose::train
