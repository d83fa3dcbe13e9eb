/// @file metrics_report.hpp
/// @brief An AngleErrorReport (metrics.hpp) and a FingertipReport (fingertip_metrics.hpp) as text:
/// JSON objects with stable keys (what `glovepose eval --json` prints) or plain tables.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "../io/number_text.hpp"
#include "fingertip_metrics.hpp"
#include "metrics.hpp"

namespace glovepose::train {

namespace detail {

// Shortest text that reads back to the same double; JSON has no NaN or infinity, so those are null.
inline std::string json_number(double value) { return std::isfinite(value) ? io::number_text(value) : "null"; }

}  // namespace detail

/// @brief The report as one JSON object with stable keys, numbers in shortest round-trip form:
/// "format" ("glovepose-angle-errors"), "version" (1), "frames", "skipped_frames", "angles",
/// "mean_deg", "rms_deg", "max_deg", "median_deg", "p95_deg", "percentile_resolution_deg",
/// "share_under_15deg", "fingers" (array of {"finger", "mean_deg", "rms_deg", "max_deg"}),
/// "scored_dofs", "dofs" (array of {"dof", "theta", "scored", "mean_deg", "rms_deg", "max_deg"}) and "cumulative"
/// ({"threshold_deg": [0..45], "share": [...]}). Non-finite numbers are written as null.
/// `extra` members (key, JSON value text) follow "version", e.g. how the frames were calibrated.
inline std::string to_json(const AngleErrorReport& r, const std::vector<std::pair<std::string, std::string>>& extra = {}) {
  const auto number = detail::json_number;
  const auto summary = [&](const ErrorSummary& e) {
    return "\"mean_deg\": " + number(e.mean_deg) + ", \"rms_deg\": " + number(e.rms_deg) + ", \"max_deg\": " + number(e.max_deg);
  };
  std::string out = "{\n";
  out += "  \"format\": \"glovepose-angle-errors\",\n  \"version\": 1,\n";
  for (const auto& [key, value] : extra) out += "  \"" + key + "\": " + value + ",\n";
  out += "  \"frames\": " + std::to_string(r.frames) + ",\n";
  out += "  \"skipped_frames\": " + std::to_string(r.skipped_frames) + ",\n";
  out += "  \"angles\": " + std::to_string(r.angles) + ",\n";
  out += "  \"scored_dofs\": " + std::to_string(r.scored_dofs) + ",\n";
  out += "  " + summary(r.overall) + ",\n";
  out += "  \"median_deg\": " + number(r.median_deg) + ",\n";
  out += "  \"p95_deg\": " + number(r.p95_deg) + ",\n";
  out += "  \"percentile_resolution_deg\": " + number(r.percentile_resolution_deg) + ",\n";
  out += "  \"share_under_15deg\": " + number(r.share_under_15deg) + ",\n";
  out += "  \"fingers\": [\n";
  for (std::size_t f = 0; f < r.fingers.size(); ++f)
    out += std::string("    {\"finger\": \"") + r.fingers[f].name + "\", " + summary(r.fingers[f].error) + "}" +
           (f + 1 < r.fingers.size() ? ",\n" : "\n");
  out += "  ],\n  \"dofs\": [\n";
  for (std::size_t d = 0; d < r.dofs.size(); ++d)
    out += std::string("    {\"dof\": \"") + r.dofs[d].name + "\", \"theta\": " + std::to_string(r.dofs[d].theta) +
           ", \"scored\": " + (r.dofs[d].scored ? "true" : "false") + ", " + summary(r.dofs[d].error) + "}" +
           (d + 1 < r.dofs.size() ? ",\n" : "\n");
  out += "  ],\n  \"cumulative\": {\n    \"threshold_deg\": [";
  for (std::size_t i = 0; i < r.curve.size(); ++i) out += (i ? ", " : "") + std::to_string(r.curve[i].threshold_deg);
  out += "],\n    \"share\": [";
  for (std::size_t i = 0; i < r.curve.size(); ++i) out += (i ? ", " : "") + number(r.curve[i].share);
  out += "]\n  }\n}\n";
  return out;
}

/// @brief The headline figures of a report as one JSON object: mean, RMS, median, p95, share under
/// 15 degrees and the motion lag (ms) measured beside it.
inline std::string summary_json(const AngleErrorReport& r, double lag_ms) {
  const auto number = detail::json_number;
  return "{\"mean_deg\": " + number(r.overall.mean_deg) + ", \"rms_deg\": " + number(r.overall.rms_deg) + ", \"median_deg\": " +
         number(r.median_deg) + ", \"p95_deg\": " + number(r.p95_deg) + ", \"share_under_15deg\": " + number(r.share_under_15deg) +
         ", \"lag_ms\": " + number(lag_ms) + "}";
}

/// @brief The report as a plain-text table: frames (and skipped frames), the overall line, one line
/// per finger, one per DoF, and the cumulative curve at 5, 10, 15, 20 and 30 degrees.
inline std::string format_table(const AngleErrorReport& r) {
  std::string out;
  char line[256];
  const auto add = [&](const char* format, auto... args) {
    std::snprintf(line, sizeof line, format, args...);
    out += line;
  };
  add("Angle errors (degrees): %zu frames x %zu angles", r.frames, r.scored_dofs);
  if (r.scored_dofs < hand::kDofCount) add(" (%zu DoFs not labelled, not scored)", hand::kDofCount - r.scored_dofs);
  if (r.skipped_frames > 0) add(", %zu frame%s skipped (non-finite angles)", r.skipped_frames, r.skipped_frames == 1 ? "" : "s");
  out += "\n";
  add("%-24s %8s %8s %8s %8s %8s %9s\n", "", "mean", "rms", "max", "median", "p95", "<15 deg");
  add("%-24s %8.3f %8.3f %8.3f %8.3f %8.3f %8.1f%%\n", "all", r.overall.mean_deg, r.overall.rms_deg, r.overall.max_deg, r.median_deg,
      r.p95_deg, 100.0 * r.share_under_15deg);
  add("  (median and p95: nearest rank, resolved to %.4f degree)\n\n", r.percentile_resolution_deg);
  add("%-24s %8s %8s %8s\n", "finger", "mean", "rms", "max");
  for (const FingerError& f : r.fingers) add("%-24s %8.3f %8.3f %8.3f\n", f.name, f.error.mean_deg, f.error.rms_deg, f.error.max_deg);
  add("\n%-24s %8s %8s %8s\n", "DoF", "mean", "rms", "max");
  for (const DofError& d : r.dofs) {
    if (d.scored)
      add("%-24s %8.3f %8.3f %8.3f\n", d.name, d.error.mean_deg, d.error.rms_deg, d.error.max_deg);
    else
      add("%-24s %26s\n", d.name, "not labelled");
  }
  out += "\nShare of angles with error below:";
  for (int t : {5, 10, 15, 20, 30}) {
    const std::size_t i = static_cast<std::size_t>(t);
    if (i < r.curve.size()) add("  %d deg %.1f%%", r.curve[i].threshold_deg, 100.0 * r.curve[i].share);
  }
  out += "\n";
  return out;
}

/// @brief The fingertip report as one JSON object (what `glovepose eval --json` carries as
/// "fingertips"): "frames", "pinch_threshold_mm", "pinch_release_mm", "onset_window_ms", `extra`
/// members (key, JSON value text: e.g. what was scored against and on which hands), "tips" (array of
/// {"finger", "frames", "mean_mm", "median_mm", "p95_mm", "max_mm"}, thumb..pinky then "all") and
/// "pinches" (array of {"finger", "frames", "distance_error_mean_mm", "distance_error_p95_mm",
/// "true_frames", "predicted_frames", "both_frames", "precision", "recall", "onsets",
/// "detected_onsets", "missed_onsets", "false_onsets", "latency_median_ms", "latency_mean_ms",
/// "pinch_tip_error_mean_mm", "pinch_distance_error_mean_mm"},
/// index..pinky then "all"). Undefined figures (no frame, no pinch, no onset) are null.
inline std::string to_json(const FingertipReport& r, const std::vector<std::pair<std::string, std::string>>& extra = {}) {
  const auto number = detail::json_number;
  std::string out = "{\"frames\": " + std::to_string(r.frames) + ", \"pinch_threshold_mm\": " + number(r.config.pinch_threshold_mm) +
                    ", \"pinch_release_mm\": " + number(r.config.pinch_release_mm) +
                    ", \"onset_window_ms\": " + number(1e3 * r.config.onset_window_s);
  for (const auto& [key, value] : extra) out += ", \"" + key + "\": " + value;
  out += ",\n    \"tips\": [";
  const auto tip = [&](const TipErrorSummary& t) {
    return std::string("{\"finger\": \"") + t.finger + "\", \"frames\": " + std::to_string(t.frames) +
           ", \"mean_mm\": " + number(t.mean_mm) + ", \"median_mm\": " + number(t.median_mm) + ", \"p95_mm\": " + number(t.p95_mm) +
           ", \"max_mm\": " + number(t.max_mm) + "}";
  };
  for (const TipErrorSummary& t : r.tips) out += "\n      " + tip(t) + ",";
  out += "\n      " + tip(r.all) + "],\n    \"pinches\": [";
  const auto pinch = [&](const PinchScore& p) {
    return std::string("{\"finger\": \"") + p.finger + "\", \"frames\": " + std::to_string(p.frames) +
           ", \"distance_error_mean_mm\": " + number(p.distance_error_mean_mm) +
           ", \"distance_error_p95_mm\": " + number(p.distance_error_p95_mm) + ", \"true_frames\": " + std::to_string(p.true_frames) +
           ", \"predicted_frames\": " + std::to_string(p.predicted_frames) + ", \"both_frames\": " + std::to_string(p.both_frames) +
           ", \"precision\": " + number(p.precision) + ", \"recall\": " + number(p.recall) + ", \"onsets\": " + std::to_string(p.onsets) +
           ", \"detected_onsets\": " + std::to_string(p.detected_onsets) + ", \"missed_onsets\": " + std::to_string(p.missed_onsets) +
           ", \"false_onsets\": " + std::to_string(p.false_onsets) + ", \"latency_median_ms\": " + number(p.latency_median_ms) +
           ", \"latency_mean_ms\": " + number(p.latency_mean_ms) +
           ", \"pinch_tip_error_mean_mm\": " + number(p.pinch_tip_error_mean_mm) +
           ", \"pinch_distance_error_mean_mm\": " + number(p.pinch_distance_error_mean_mm) + "}";
  };
  for (const PinchScore& p : r.pinches) out += "\n      " + pinch(p) + ",";
  out += "\n      " + pinch(r.all_pinches) + "]}";
  return out;
}

/// @brief The fingertip report as a plain-text table: per digit the tip error (mean, median, p95),
/// per pair the distance error, per-frame precision and recall, onsets missed and the median onset
/// latency; `reference` says what the truth was (e.g. "the true angles, each person's hand").
inline std::string format_table(const FingertipReport& r, const std::string& reference) {
  std::string out;
  char line[256];
  const auto add = [&](const char* format, auto... args) {
    std::snprintf(line, sizeof line, format, args...);
    out += line;
  };
  // A figure, or "-" when it is undefined (no frame, no pinch, no onset).
  const auto figure = [](double value, const char* format) {
    char text[32] = "-";
    if (std::isfinite(value)) std::snprintf(text, sizeof text, format, value);
    return std::string(text);
  };
  add("Fingertips (mm, wrist-relative) against %s: %zu frames\n", reference.c_str(), r.frames);
  add("%-8s %8s %8s %8s %8s\n", "tip", "mean", "median", "p95", "max");
  for (const TipErrorSummary* t : {&r.tips[0], &r.tips[1], &r.tips[2], &r.tips[3], &r.tips[4], &r.all})
    add("%-8s %8s %8s %8s %8s\n", t->finger, figure(t->mean_mm, "%.2f").c_str(), figure(t->median_mm, "%.2f").c_str(),
        figure(t->p95_mm, "%.2f").c_str(), figure(t->max_mm, "%.2f").c_str());
  add("Pinches (thumb tip to fingertip under %g mm, released over %g mm; onsets matched within %g ms):\n", r.config.pinch_threshold_mm,
      r.config.pinch_release_mm, 1e3 * r.config.onset_window_s);
  add("%-8s %10s %9s %9s %7s %7s %7s %7s %11s\n", "thumb +", "|dd| mean", "|dd| p95", "precision", "recall", "onsets", "missed", "false",
      "latency med");
  for (const PinchScore* p : {&r.pinches[0], &r.pinches[1], &r.pinches[2], &r.pinches[3], &r.all_pinches})
    add("%-8s %10s %9s %9s %7s %7zu %7zu %7zu %11s\n", p->finger, figure(p->distance_error_mean_mm, "%.2f").c_str(),
        figure(p->distance_error_p95_mm, "%.2f").c_str(), figure(p->precision, "%.3f").c_str(), figure(p->recall, "%.3f").c_str(),
        p->onsets, p->missed_onsets, p->false_onsets,
        (figure(p->latency_median_ms, "%.0f") + (std::isfinite(p->latency_median_ms) ? " ms" : "")).c_str());
  out += "  (|dd|: error of the thumb-to-fingertip distance, mm; precision and recall per frame; false: predicted onsets matching none)\n";
  return out;
}

}  // namespace glovepose::train
