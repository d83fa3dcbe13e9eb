/// @file evaluate.hpp
/// @brief A trained model scored on a dataset (what `glovepose eval` prints, callable from C++ and,
/// through the C ABI, Python): the angle errors against the labels (and the true angles behind them
/// on simulated data), the motion lag, fingertip and pinch measures on each person's hand, the
/// contact stage's counts, and the sensors each run's calibration zeroed. The result as JSON
/// (to_json) or text (format_text) is produced here, once.
#pragma once

#include <algorithm>
#include <array>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "../config.hpp"
#include "../core/thread_pool.hpp"
#include "../core/units.hpp"
#include "../filter/trend.hpp"
#include "../hand/contact.hpp"
#include "../hand/pinch.hpp"
#include "../io/atomic_file.hpp"
#include "../model/pose_error.hpp"
#include "../model/pose_network.hpp"
#include "../nn/weight_storage.hpp"
#include "confidence_metrics.hpp"
#include "fingertip_metrics.hpp"
#include "guided_calibration.hpp"
#include "lag.hpp"
#include "metrics.hpp"
#include "metrics_report.hpp"
#include "model_file.hpp"
#include "replay.hpp"
#include "samples.hpp"

namespace glovepose::train {

/// @brief The hand of each person in a dataset, for the fingertip measures (sim::subject_hands
/// knows a simulated corpus' people); `description` says whose hands they are.
struct SubjectHands {
  std::vector<hand::Kinematics> people;  ///< By subject id; empty: the reference hand for everyone.
  std::string description = "the reference hand";
  /// @brief The hand of `subject` (the reference hand when it is not listed).
  hand::Kinematics of(int subject) const {
    const auto i = static_cast<std::size_t>(subject);
    return subject >= 0 && i < people.size() ? people[i] : hand::Kinematics();
  }
};

/// @brief The sensors one calibration zeroed because their range was flat (a glove maker's lost
/// channel), named as the glove names them.
struct ZeroedSensors {
  std::optional<RunId> run;          ///< The calibrated run; nullopt: the model's training range.
  std::vector<std::string> sensors;  ///< The glove's cell names.
  /// @brief "calibration of subject 1, glove 0, session 2: 1 flat sensor read 0: b2".
  std::string text() const {
    std::string list;
    for (const std::string& s : sensors) list += (list.empty() ? "" : ", ") + s;
    return "calibration of " + (run ? run->text() : std::string("the training range")) + ": " + std::to_string(sensors.size()) +
           " flat sensor" + (sensors.size() == 1 ? "" : "s") + " read 0: " + list;
  }
};

/// @brief The zeroed sensors of `samples` per calibration, named by `glove` (the samples' ranges
/// name cells by position, cell_names()).
inline std::vector<ZeroedSensors> zeroed_sensors(const Samples& samples, const grid::GloveDescription& glove) {
  const std::vector<std::string> by_position = cell_names(glove.cell_names().size());
  std::vector<ZeroedSensors> out;
  for (const auto& [key, names] : samples.zeroed) {
    ZeroedSensors z;
    if (key >= 0) z.run = RunId::of(key);
    for (const std::string& n : names) {
      const auto at = std::find(by_position.begin(), by_position.end(), n);
      z.sensors.push_back(at == by_position.end() ? n : glove.cell_names()[static_cast<std::size_t>(at - by_position.begin())]);
    }
    out.push_back(std::move(z));
  }
  return out;
}

/// @brief What to evaluate and how.
struct EvaluationOptions {
  FrameFilter filter;  ///< The frames scored.
  int stride = 1;      ///< Every stride-th selected frame of a run.
  /// How the inputs are calibrated: "" (the model's mode; guided when the model carries a
  /// pose-guided calibration and the data followed its sequence), "none", "training", "onthefly"
  /// or "guided".
  std::string calibration;
  /// Replay the raw rows through a readout with these settings first (replay.hpp); nullopt: the
  /// dataset's cells as they are.
  std::optional<sensor::ReadoutConfig> replay;
  bool contact = false;          ///< Adjust the predicted poses with the contact stage (hand/contact.hpp) before scoring.
  bool pinch_distances = false;  ///< Keep every frame's true and predicted thumb-to-fingertip distances.
  SubjectHands hands;            ///< Whose hands the fingertips are measured on.
  int threads = 0;               ///< Threads (0: all cores).
  /// How the network holds its weights: F32 scores the file's values in float (the trainer's
  /// network); F16, BF16 and Fixed16 score the real-time network (nn::UNet, nn::Fcn, as
  /// PoseModel loads it) holding them so. A linear map has only F32.
  nn::WeightStorage weights = nn::WeightStorage::F32;
  /// The confidence scored (model/pose_error.hpp, when the model carries its errors): the
  /// probability of an error within this tolerance (radians; the estimator's default, 10 degrees),
  /// from the calibration scored, the continuous calibration's stage and the angles' rate of change
  /// over `rate_window` seconds (the estimator's default prediction_window). No cell is stood in for.
  double confidence_tolerance = 10.0 * core::kRadiansPerDegree;
  double rate_window = 0.15;
};

/// @brief One frame's thumb-to-fingertip distances (mm), true and predicted, and the true pinches.
struct PinchDistanceRow {
  hand::PinchDistances truth{}, predicted{};
  hand::PinchFlags pinching{};
  bool run_start = false;  ///< The first frame of a run (recording).
};

/// @brief The scores of a model on a dataset.
struct EvaluationResult {
  std::string calibration;                 ///< "guided", or the calibration mode used.
  std::optional<std::string> mean_window;  ///< The dataset's readout mean window (metadata "mean_window"), if it says.
  bool rows_replayed = false;              ///< The raw rows were replayed through a readout.
  nn::WeightStorage weights = nn::WeightStorage::F32;  ///< How the network held its weights.
  AngleErrorReport vs_labels;              ///< Against the labels.
  double lag_ms = 0.0;                     ///< Motion lag against the labels.
  std::optional<AngleErrorReport> vs_truth;  ///< Against the true angles (simulated data).
  double truth_lag_ms = 0.0;                 ///< Motion lag against the true angles.
  std::optional<FingertipReport> fingertips;  ///< Fingertips and pinches (against the truth when there is one).
  bool fingertips_vs_truth = false;           ///< Whether the fingertips were scored against the true angles.
  std::string hands;                          ///< Whose hands the fingertips were measured on.
  bool contact = false;                       ///< The contact stage ran.
  std::size_t contact_adjusted = 0, contact_refused = 0;  ///< Poses it adjusted; adjustments refused (collision).
  std::size_t outside_limits = 0;             ///< Predicted angles outside the joint limits (held at them).
  std::vector<ZeroedSensors> zeroed;          ///< Sensors the calibrations zeroed.
  std::vector<std::int64_t> source;  ///< Per scored frame: its index in the dataset.
  std::vector<float> labels;         ///< Per scored frame, 25 label angles (radians; NaN: not labelled).
  std::vector<float> predicted;      ///< Per scored frame, 25 predicted angles (radians).
  std::vector<PinchDistanceRow> pinch_distances;  ///< Per scored frame, when asked for.
  /// The per-joint confidence scored against the errors (against the truth when the data has it),
  /// when the model carries its own errors and the inputs were calibrated.
  std::optional<ConfidenceReport> confidence;

  /// @brief Frames scored.
  long frames() const noexcept { return static_cast<long>(source.size()); }
};

/// @brief The selected frames of `data` as `model` sees them: its glove and joint limits, and its
/// calibration mode unless `calibration` ("none", "training", "onthefly", "continuous"; "guided"
/// calibrates on the fly) overrides it. Throws glovepose::Error when the data's glove is not the model's.
inline std::pair<Samples, model::CalibrationMode> samples_for_model(const TrainedModel& trained, const io::Dataset& recorded,
                                                                    const FrameFilter& filter, int stride, const std::string& calibration) {
  std::optional<io::Dataset> storage;
  const io::Dataset& data = conditioned_for(recorded, trained.glove, storage);  // as the estimator conditions its inputs
  if (data.glove_layout() != trained.glove.id())
    throw Error("the dataset was recorded with glove '" + data.glove_layout() + "', the model is for '" + trained.glove.id() + "'");
  const std::string requested = calibration == "guided" ? "onthefly" : calibration;
  const model::CalibrationMode mode = requested.empty() ? trained.info.calibration : model::evaluation_calibration_mode(requested);
  std::optional<sensor::CalibrationRange> range;
  if (mode == model::CalibrationMode::Training) range = trained.training_range();
  if (mode == model::CalibrationMode::Continuous && !trained.info.range_map)
    throw Error("calibration continuous: the model carries no range map, expected a model fitted by glovepose fit-guided");
  return {make_samples(data, filter, mode, range ? &*range : nullptr, trained.info.joint_limits(), stride, trained.glove.calibration(),
                       trained.info.range_map ? &*trained.info.range_map : nullptr),
          mode};
}

namespace detail {

// Normalised predictions (frames x 25) of the model's network with its weights held as `storage`,
// as the real-time path holds them, within the joint limits unless `hold` is false (`outside` adds
// how many were not); DoFs the model was not trained on read the rest pose, as in TrainedModel::predict.
inline std::vector<float> predict_stored(const TrainedModel& model, const Samples& samples, nn::WeightStorage storage, int threads,
                                         std::size_t& outside, bool hold) {
  const model::ModelInfo& info = model.info;
  if (!model.network)
    throw Error("weights " + std::string(nn::storage_name(storage)) + ": the model is " + info.architecture_name() +
                ", which has no real-time network, expected F32 weights (the default)");
  if (samples.cells != info.inputs)
    throw Error("the samples have " + std::to_string(samples.cells) + " cells per frame, the model takes " + std::to_string(info.inputs));
  const model::PoseNetwork network = model::PoseNetwork::from_tensors(info, model.network->parameters().to_tensors(), storage);
  const long frames = samples.frames();
  const std::vector<hand::Angles> rows = network.normalized_dofs_batch(model.glove.map(), samples.inputs.data(), samples.cells, frames, threads);
  std::vector<float> out(static_cast<std::size_t>(frames) * kTargets);
  for (long f = 0; f < frames; ++f) {
    const hand::Angles& a = rows[static_cast<std::size_t>(f)];
    std::copy(a.begin(), a.end(), out.begin() + f * kTargets);
  }
  outside += outside_limits(out.data(), out.size(), hold);  // held as TrainedModel::predict holds F32's
  model.rest_unlabelled(out);
  return out;
}

// Whether to calibrate guided: asked for, or by default when the model carries a pose-guided
// calibration and the dataset's calibrations followed its sequence.
inline bool evaluate_guided(const std::string& calibration, const TrainedModel& model, const io::Dataset& data) {
  if (calibration == "guided") return true;
  if (!calibration.empty() || !model.info.pose_offset) return false;
  const auto it = data.metadata.find("calibration_sequence");
  return it != data.metadata.end() && it->second == model.info.pose_offset->sequence().id();
}

}  // namespace detail

/// @brief Scores `model` on the frames of `data` that `options` selects. Throws glovepose::Error
/// when the data cannot be scored (another glove, no DoF both labelled and trained, a calibration
/// the data lacks).
inline EvaluationResult evaluate(TrainedModel& model, const io::Dataset& dataset, const EvaluationOptions& options) {
  const std::string& choice = options.calibration;
  if (!choice.empty() && choice != "none" && choice != "training" && choice != "onthefly" && choice != "guided" && choice != "continuous")
    throw Error("evaluation calibration '" + choice + "', expected none, training, onthefly, guided or continuous (or empty: the model's)");
  std::optional<io::Dataset> replayed;
  if (options.replay) replay_rows(replayed.emplace(dataset), *options.replay);
  std::optional<io::Dataset> conditioned;
  const io::Dataset& data = conditioned_for(replayed ? *replayed : dataset, model.glove, conditioned);
  const auto [samples, mode] = samples_for_model(model, data, options.filter, options.stride, choice);
  EvaluationResult r;
  r.rows_replayed = replayed.has_value();
  r.weights = options.weights;
  r.zeroed = zeroed_sensors(samples, model.glove);
  const hand::JointLimits limits = model.info.joint_limits();
  core::ThreadPool pool(options.threads > 0 ? options.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  const bool guided = detail::evaluate_guided(choice, model, data);
  const std::map<std::int64_t, hand::Angles> offsets =
      guided ? guided_offsets(model, data, options.filter, pool) : std::map<std::int64_t, hand::Angles>{};
  const std::vector<float> normalized = options.weights == nn::WeightStorage::F32
                                            ? model.predict(samples, pool, &r.outside_limits, !guided)
                                            : detail::predict_stored(model, samples, options.weights, pool.size(), r.outside_limits, !guided);
  hand::DofSet scored = samples.labelled;  // DoFs with reference angles that the model was trained on
  const hand::DofSet& trained = model.info.labelled_dofs;
  for (std::size_t d = 0; d < hand::kDofCount; ++d) scored[d] = scored[d] && trained[d];
  if (std::find(scored.begin(), scored.end(), true) == scored.end())
    throw Error("the model was trained on " + hand::dof_set_text(trained) + " and the data labels " + hand::dof_set_text(samples.labelled) +
                ": no DoF to score, expected data labelling a DoF the model was trained on");
  AngleErrorAccumulator errors(scored);
  // Simulated data also holds the true angles behind its labels: the same scores against them.
  const bool with_truth = data.has_true_angles();
  AngleErrorAccumulator truth_errors(scored);
  r.predicted.resize(normalized.size());
  std::vector<float> truth(with_truth ? normalized.size() : 0);
  // Fingertips and pinches against the true angles when the data has them, else the labels; a new
  // run at every recording (and wherever time does not go forward).
  FingertipAccumulator tips;
  hand::Kinematics run_hand;
  hand::PinchTracker true_pinch;
  // The contact stage on each person's own hand (as an estimator configured with the user's hand),
  // its state starting over with every recording.
  std::optional<hand::ContactStage> contact;
  // The confidence each frame would carry: the model's errors under the calibration scored.
  const model::PoseErrorModel* own_errors = model.info.pose_error && mode != model::CalibrationMode::None ? &*model.info.pose_error : nullptr;
  const model::ErrorCondition condition = guided                                    ? model::ErrorCondition::Guided
                                          : mode == model::CalibrationMode::OnTheFly ? model::ErrorCondition::MinMax
                                          : mode == model::CalibrationMode::Training ? model::ErrorCondition::Training
                                                                                     : model::ErrorCondition::Continuous;
  std::optional<ConfidenceAccumulator> confidence;
  if (own_errors) confidence.emplace(options.confidence_tolerance * core::kDegreesPerRadian);
  filter::Trend<hand::kDofCount> trend(options.rate_window);
  for (long f = 0; f < samples.frames(); ++f) {
    const auto at = static_cast<std::size_t>(f);
    hand::Angles n{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) n[d] = normalized[at * hand::kDofCount + d];
    hand::Angles radians = limits.denormalize(n);
    if (guided) radians = calibration::with_offsets(radians, offsets.at(samples.run[at]), limits);
    double p[hand::kDofCount], t[hand::kDofCount], q[hand::kDofCount];
    const auto source = static_cast<std::size_t>(samples.source[at]);
    const double time = data.timestamps[source];
    const bool run_start = f == 0 || samples.run[at] != samples.run[at - 1] ||
                           !(time > data.timestamps[static_cast<std::size_t>(samples.source[at - 1])]);
    if (run_start) {
      run_hand = options.hands.of(data.subject[source]);
      tips.begin_run(run_hand);
      true_pinch.reset();
      if (options.contact) contact.emplace(run_hand, limits);
      trend.reset();
    }
    const hand::Angles estimate = radians;  // what the contact stage sees
    if (contact) {
      hand::Skeleton skeleton;
      run_hand.pose(radians, skeleton);
      const hand::ContactResult c = contact->apply(radians, skeleton);
      r.contact_adjusted += c.closed >= 0;
      r.contact_refused += c.refused;
    }
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const std::size_t i = at * hand::kDofCount + d;
      p[d] = radians[d];
      t[d] = samples.angles[i];
      r.predicted[i] = static_cast<float>(p[d]);
      if (with_truth) q[d] = truth[i] = data.true_angles[source * hand::kDofCount + d];
    }
    errors.add(p, t);
    if (with_truth) truth_errors.add(p, q);
    if (confidence) {
      (void)trend.add(time, radians);
      const hand::Angles rate = trend.slope();
      const double frames = samples.motion_frames.empty() ? 0.0 : static_cast<double>(samples.motion_frames[at]);
      hand::Angles c{};
      if (own_errors->confidence(condition, frames, trend.has_slope() ? &rate : nullptr, nullptr, 0, options.confidence_tolerance, c))
        for (std::size_t d = 0; d < hand::kDofCount; ++d)
          if (scored[d] && std::isfinite(with_truth ? q[d] : t[d])) confidence->add(d, (p[d] - (with_truth ? q[d] : t[d])) * core::kDegreesPerRadian, c[d]);
    }
    hand::Angles reference{};
    std::copy(with_truth ? q : t, (with_truth ? q : t) + hand::kDofCount, reference.begin());
    tips.add(radians, reference, time);
    if (options.pinch_distances) {
      PinchDistanceRow row;
      row.truth = hand::pinch_distances(run_hand, reference);
      row.predicted = hand::pinch_distances(run_hand, estimate);
      row.pinching = true_pinch.update(row.truth).pinching;
      row.run_start = run_start;
      r.pinch_distances.push_back(row);
    }
  }
  r.calibration = guided ? "guided" : model::to_string(mode);
  if (const auto window = data.metadata.find("mean_window"); window != data.metadata.end()) r.mean_window = window->second;
  r.vs_labels = errors.report();
  if (confidence && !confidence->empty()) r.confidence = confidence->report();
  const double frame_ms = 1000.0 / data.frame_rate();
  r.lag_ms = lag_frames(r.predicted, samples.angles, samples.source, samples.run, options.stride) * frame_ms;
  if (with_truth) {
    r.vs_truth = truth_errors.report();
    r.truth_lag_ms = lag_frames(r.predicted, truth, samples.source, samples.run, options.stride) * frame_ms;
  }
  if (!tips.empty()) r.fingertips = tips.report();
  r.fingertips_vs_truth = with_truth;
  r.hands = options.hands.description;
  r.contact = options.contact;
  r.source = samples.source;
  r.labels = samples.angles;
  return r;
}

/// @brief The result as `glovepose eval --json` prints it: the angle-error report (to_json of
/// metrics_report.hpp) with "calibration", "weights" (the storage, as --weights spells it: "f32",
/// "f16", "bf16" or "fixed16"), "mean_window", "lag_ms", "scored_against", "vs_labels", "vs_truth",
/// "fingertips", "contact" ({"adjusted_frames", "refused_frames"} or null), "outside_limits"
/// (predicted angles outside the joint limits, held at them) and "confidence" (confidence_json, or
/// null when the model carries no errors of its own or the inputs were not calibrated).
inline std::string to_json(const EvaluationResult& r) {
  const std::string tips =
      r.fingertips ? to_json(*r.fingertips, {{"scored_against", r.fingertips_vs_truth ? "\"truth\"" : "\"labels\""}, {"hands", "\"" + r.hands + "\""}})
                   : "null";
  const std::string contact = r.contact ? "{\"adjusted_frames\": " + std::to_string(r.contact_adjusted) +
                                              ", \"refused_frames\": " + std::to_string(r.contact_refused) + "}"
                                        : "null";
  char lag[32];
  std::snprintf(lag, sizeof lag, "%.3f", r.lag_ms);
  return to_json(r.vs_labels, {{"calibration", "\"" + r.calibration + "\""},
                               {"weights", "\"" + std::string(nn::storage_word(r.weights)) + "\""},
                               {"mean_window", r.mean_window.value_or("null")},
                               {"lag_ms", lag},
                               {"scored_against", "\"labels\""},
                               {"vs_labels", summary_json(r.vs_labels, r.lag_ms)},
                               {"vs_truth", r.vs_truth ? summary_json(*r.vs_truth, r.truth_lag_ms) : "null"},
                               {"fingertips", tips},
                               {"contact", contact},
                               {"outside_limits", std::to_string(r.outside_limits)},
                               {"confidence", r.confidence ? confidence_json(*r.confidence) : "null"}});
}

/// @brief The result as `glovepose eval` prints it: the angle-error table, the lag, the scores
/// against the truth, the angles outside the joint limits, the contact stage's counts and the
/// fingertip table.
inline std::string format_text(const EvaluationResult& r) {
  std::string out = format_table(r.vs_labels);
  char line[512];
  std::snprintf(line, sizeof line, "Motion lag: %.1f ms (the shift that best aligns the frame-to-frame changes of predicted and reference angles)\n",
                r.lag_ms);
  out += line;
  if (r.vs_truth) {
    std::snprintf(line, sizeof line,
                  "Against the true angles behind the labels (simulated data): mean %.2f deg, p95 %.1f deg, %.1f%% under 15 deg, lag %.1f ms\n",
                  r.vs_truth->overall.mean_deg, r.vs_truth->p95_deg, 100.0 * r.vs_truth->share_under_15deg, r.truth_lag_ms);
    out += line;
  }
  std::snprintf(line, sizeof line, "Outside the joint limits: %zu of %zu predicted angles (held at them)\n",
                r.outside_limits, r.predicted.size());
  out += line;
  if (r.contact) {
    std::snprintf(line, sizeof line, "Contact stage: %zu poses adjusted (%.1f%%), %zu adjustments refused (collision)\n", r.contact_adjusted,
                  100.0 * static_cast<double>(r.contact_adjusted) / static_cast<double>(std::max<long>(r.frames(), 1)), r.contact_refused);
    out += line;
  }
  if (r.confidence) {
    const ConfidenceReport& c = *r.confidence;
    std::snprintf(line, sizeof line,
                  "Confidence (within %.0f deg): mean %.3f, share within %.3f; the lowest-confidence quarter of joint-frames has %.2fx the "
                  "error of the highest (within a DoF, median %.2fx)\n",
                  c.tolerance_deg, c.mean_confidence, c.share_within, c.quarter_error_ratio, c.within_dof_ratio);
    out += line;
  }
  if (r.fingertips)
    out += "\n" + format_table(*r.fingertips, std::string(r.fingertips_vs_truth ? "the true angles" : "the labels") + ", " + r.hands);
  return out;
}

namespace detail {

// A CSV file written whole (io::AtomicFile) or an Error naming `what` (the option that asked for
// it), printf-formatted.
class CsvFile {
 public:
  CsvFile(const std::string& path, const std::string& what) : file_(path, what) {}
#if defined(__MINGW32__)  // libstdc++ selects MinGW's own (C99) printf, not msvcrt's: %zu works
  __attribute__((format(gnu_printf, 2, 3)))
#elif defined(__GNUC__)
  __attribute__((format(printf, 2, 3)))
#endif
  void print(const char* format, ...) {
    char text[512];
    std::va_list args;
    va_start(args, format);
    const int n = std::vsnprintf(text, sizeof text, format, args);
    va_end(args);
    if (n > 0) file_.write(text, std::min(static_cast<std::size_t>(n), sizeof text - 1));
  }
  void commit() { file_.commit(); }

 private:
  io::AtomicFile file_;
};

}  // namespace detail

/// @brief Writes one CSV row per scored frame: where it comes from (dataset index, time, subject,
/// session), its label, predicted and (simulated data) true angles, radians. `what` names the
/// request in errors (e.g. "--predictions").
inline void write_predictions(const std::string& path, const io::Dataset& data, const EvaluationResult& r,
                              const std::string& what = "predictions") {
  detail::CsvFile csv(path, what);
  csv.print("frame,time,subject,session");
  for (const char* prefix : {"label_", "pred_", "truth_"})
    if (prefix[0] != 't' || data.has_true_angles())
      for (const hand::Dof& d : hand::kDofs) csv.print(",%s%s", prefix, d.name);
  csv.print("\n");
  for (long f = 0; f < r.frames(); ++f) {
    const auto i = static_cast<std::size_t>(r.source[static_cast<std::size_t>(f)]);
    csv.print("%zu,%.9g,%d,%d", i, data.timestamps[i], data.subject[i], data.session[i]);
    for (const std::vector<float>* v : {&r.labels, &r.predicted})
      for (std::size_t d = 0; d < hand::kDofCount; ++d)
        csv.print(",%.9g", static_cast<double>((*v)[static_cast<std::size_t>(f) * hand::kDofCount + d]));
    if (data.has_true_angles())
      for (std::size_t d = 0; d < hand::kDofCount; ++d) csv.print(",%.9g", static_cast<double>(data.true_angles[i * hand::kDofCount + d]));
    csv.print("\n");
  }
  csv.commit();
}

/// @brief Writes one CSV row per scored frame (EvaluationOptions::pinch_distances): where it comes
/// from, whether a run starts there, the true and predicted thumb-to-fingertip distances (mm) and
/// the true pinch flags (hand/pinch.hpp's rule), for sweeping a detector's threshold offline.
inline void write_pinch_distances(const std::string& path, const io::Dataset& data, const EvaluationResult& r,
                                  const std::string& what = "pinch distances") {
  if (r.pinch_distances.size() != r.source.size())
    throw Error(what + ": the evaluation kept no pinch distances, expected EvaluationOptions::pinch_distances");
  detail::CsvFile csv(path, what);
  csv.print("frame,time,subject,session,run_start");
  for (const char* prefix : {"true_mm_", "pred_mm_", "true_on_"})
    for (std::size_t k = 0; k < hand::kPinchPairCount; ++k)
      csv.print(",%s%s", prefix, hand::to_string(static_cast<hand::Finger>(k + 1)));
  csv.print("\n");
  for (std::size_t f = 0; f < r.source.size(); ++f) {
    const auto i = static_cast<std::size_t>(r.source[f]);
    const PinchDistanceRow& row = r.pinch_distances[f];
    csv.print("%zu,%.9g,%d,%d,%d", i, data.timestamps[i], data.subject[i], data.session[i], row.run_start ? 1 : 0);
    for (double d : row.truth) csv.print(",%.4f", d);
    for (double d : row.predicted) csv.print(",%.4f", d);
    for (bool on : row.pinching) csv.print(",%d", on ? 1 : 0);
    csv.print("\n");
  }
  csv.commit();
}

}  // namespace glovepose::train
