/// @file corpus_dataset.hpp
/// @brief A simulated corpus as one dataset file (io::Dataset, the container of weights_format.md).
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "../io/dataset.hpp"
#include "corpus.hpp"

namespace glovepose::sim {

/// @brief The recordings, in plan order, as one dataset: "angles" are the reference tracker's labels,
/// "true_angles" the truth behind them; the metadata records how it was made.
inline io::Dataset to_dataset(const std::vector<SessionRecording>& corpus, const CorpusConfig& config) {
  const bool raw = config.recording.raw_rows;
  io::Dataset out(kCells, raw ? kRows : 0, sensor::TraceLayout::glauser2019().id(), config.recording.cycle_rate);
  std::size_t total = 0;
  for (const SessionRecording& s : corpus) total += static_cast<std::size_t>(s.recording.frames);
  out.cells.reserve(total * kCells);
  out.angles.reserve(total * hand::kDofCount);
  out.true_angles.reserve(total * hand::kDofCount);
  if (raw) out.raw_rows.reserve(total * kRows);
  // A session's clock starts with the removal before it, else its calibration sequence: each recording
  // of the session that follows continues it.
  double offset = 0.0;
  const SessionRecording* previous = nullptr;
  for (const SessionRecording& s : corpus) {
    const Recording& r = s.recording;
    const bool continues = previous && previous->kind != RecordingKind::Session && s.kind != RecordingKind::Removal &&
                           previous->subject == s.subject && previous->glove == s.glove && previous->session == s.session;
    offset = continues && !previous->recording.timestamps.empty() ? offset + previous->recording.timestamps.back() : 0.0;
    previous = &s;
    out.cells.insert(out.cells.end(), r.cells.begin(), r.cells.end());
    const std::vector<float>& labels = r.labels.empty() ? r.angles : r.labels;  // unlabelled: a perfect tracker
    out.angles.insert(out.angles.end(), labels.begin(), labels.end());
    out.true_angles.insert(out.true_angles.end(), r.angles.begin(), r.angles.end());
    if (raw) out.raw_rows.insert(out.raw_rows.end(), r.raw_rows.begin(), r.raw_rows.end());
    for (double t : r.timestamps) out.timestamps.push_back(offset + t);
    out.outlier.insert(out.outlier.end(), r.outlier.begin(), r.outlier.end());
    const auto n = static_cast<std::size_t>(r.frames);
    out.subject.insert(out.subject.end(), n, s.subject);
    out.session.insert(out.session.end(), n, s.session);
    out.glove.insert(out.glove.end(), n, s.glove);
    out.donning.insert(out.donning.end(), n, s.donning);
    out.kind.insert(out.kind.end(), n,
                    s.kind == RecordingKind::Calibration ? io::kKindCalibration
                    : s.kind == RecordingKind::Removal   ? io::kKindRemoval
                                                         : io::kKindRecording);
  }
  char minutes[32];
  std::snprintf(minutes, sizeof minutes, "%g", config.minutes);
  out.metadata["generator"] = "glovepose simulate";
  out.metadata["world"] = config.world.name;
  if (!config.world.ablated.empty()) out.metadata["world_without"] = config.world.ablated;
  if (!config.world.settings.empty()) out.metadata["world_set"] = config.world.settings;
  out.metadata["seed"] = std::to_string(config.seed);
  out.metadata["subjects"] = std::to_string(config.subjects);
  out.metadata["sessions"] = std::to_string(config.sessions);
  out.metadata["intra_sessions"] = std::to_string(config.intra_sessions);
  out.metadata["minutes"] = minutes;
  out.metadata["gloves"] = std::to_string(config.gloves);
  out.metadata["other_glove_sessions"] = std::to_string(config.other_glove_sessions);
  out.metadata["calibration_seconds"] = std::to_string(config.calibration_seconds);
  out.metadata["mean_window"] = std::to_string(config.recording.readout.mean_window);
  if (config.guided_calibration) out.metadata["calibration_sequence"] = config.guided_calibration->id();
  if (config.removal) {
    char removal[96];
    std::snprintf(removal, sizeof removal, "doff %g s, off %g s, don %g s", config.removal->doff_seconds, config.removal->off_seconds,
                  config.removal->don_seconds);
    out.metadata["removal"] = removal;
  }
  std::string sizes = "[";
  for (const Subject& s : make_subjects(config.subjects, config.seed, config.world.people))
    sizes += (s.id ? ", [" : "[") + std::to_string(s.size.length) + ", " + std::to_string(s.size.width) + ", " +
             std::to_string(s.size.height) + "]";
  out.metadata["subject_sizes_mm"] = sizes + "]";
  out.validate();
  return out;
}

}  // namespace glovepose::sim
