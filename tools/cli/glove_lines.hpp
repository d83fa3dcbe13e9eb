// A glove's own stream as text lines, for the tool's commands that read one (glovepose view --stdin,
// glovepose predict --raw): the line format, and the loop that feeds the lines to an estimator,
// calibrating on the fly from the first seconds of stream time or with the calibration it was given,
// counting the lines it cannot use and telling why a stream cannot serve a pose.
#pragma once

#include <glovepose/estimator.hpp>
#include <glovepose/io/csv_fields.hpp>
#include <glovepose/io/number_text.hpp>
#include <glovepose/sensor/layout.hpp>
#include <glovepose/sensor/solver.hpp>

#include <atomic>
#include <charconv>
#include <cmath>
#include <functional>
#include <iostream>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace glovepose::cli {

/// The lines of a glove's stream, for the model's glove: a frame of its cells, "timestamp,v_0,...,v_{n-1}"
/// (seconds, then the n cells in the order of its description, in the glove's own unit), for any glove;
/// or, when the model knows the glove's wiring (the built-in glove), a raw row "row,value,timestamp".
/// A first line "timestamp,<the cell names>" (or "timestamp_ms,...", as import reads a take) names the
/// columns; it must name the glove's cells in order.
class GloveLineFormat {
 public:
  enum class Kind { Header, Cells, Row };

  /// `shipped_model`: the model is the tool's default, so a message says another glove needs --model.
  GloveLineFormat(const PoseModel& model, bool shipped_model) : glove_(model.glove()), shipped_(shipped_model) {
    if (model.solver()) rows_ = model.solver()->layout().row_count();
  }

  /// One line (not blank, not a comment) into `cells` (a frame) or `row`, `value`, `t`; throws Error
  /// "line N: why" for a line that is neither.
  Kind parse(const std::string& line, long line_no, std::vector<double>& cells, int& row, double& value, double& t) const {
    const std::vector<std::string> fields = io::split_csv_line(line);
    const std::string at = "line " + std::to_string(line_no);
    const auto field = [&](std::size_t i) { return at + ", field " + std::to_string(i + 1) + " ('" + clip(fields[i]) + "')"; };
    if (fields[0] == "timestamp" || fields[0] == "timestamp_ms") return Kind::Header;
    if (fields.size() == cells.size() + 1) {
      t = io::parse_csv_number<double>(fields[0], field(0));
      for (std::size_t c = 0; c < cells.size(); ++c) cells[c] = reading(fields[c + 1], field(c + 1));
      return Kind::Cells;
    }
    if (rows_ > 0 && fields.size() == 3) {
      const std::int32_t r = io::parse_csv_id(fields[0], field(0));
      if (r >= rows_) throw Error(field(0) + " is not a row of the glove's wiring, expected 0.." + std::to_string(rows_ - 1));
      row = r;
      value = reading(fields[1], field(1));
      t = io::parse_csv_number<double>(fields[2], field(2));
      return Kind::Row;
    }
    throw Error(at + ": " + std::to_string(fields.size()) + (fields.size() == 1 ? " field" : " fields") + ", expected " + expected());
  }

  /// The units per second of the time column a header line names ('timestamp': 1, 'timestamp_ms':
  /// 1000); throws Error unless it names a time column and the glove's cells, in order.
  double check_header(const std::string& line, const std::string& where) const {
    std::vector<std::string> fields = io::split_csv_line(line), names{fields[0]};
    names.insert(names.end(), glove_.cell_names().begin(), glove_.cell_names().end());
    if (fields != names)
      throw Error(where + " names the columns '" + clip(line) + "', expected 'timestamp' (seconds) or 'timestamp_ms' and the " +
                  std::to_string(glove_.cell_count()) + " cells of glove '" + glove_.id() +
                  "' in the order of its description: " + join(names));
    return fields[0] == "timestamp_ms" ? 1000.0 : 1.0;
  }

  /// What a line holds, for messages.
  std::string expected() const {
    std::string out = std::to_string(glove_.cell_count() + 1) + " (a timestamp in seconds and the " + std::to_string(glove_.cell_count()) +
                      " cells of glove '" + glove_.id() + "': " + clip(join(glove_.cell_names())) + ")";
    if (rows_ > 0) out = "3 (row,value,timestamp: a raw row of its wiring) or " + out;
    if (shipped_) out += "; the glove is the shipped model's: another glove's lines need --model, a model trained for it";
    return out;
  }

  /// A frame is one line of cells; raw rows make one once each of the wiring's rows arrived.
  std::string frames_from() const {
    return rows_ > 0 ? "one per line of cells, or once every one of the wiring's " + std::to_string(rows_) + " rows has arrived"
                     : "one per line of cells";
  }

 private:
  static std::string join(const std::vector<std::string>& names) {
    std::string out;
    for (const std::string& n : names) out += (out.empty() ? "" : ",") + n;
    return out;
  }
  static std::string clip(const std::string& text) { return text.size() > 80 ? text.substr(0, 77) + "..." : text; }
  // A reading: a number, or nan/inf (a reading the glove dropped), which the estimator refuses and
  // counts in the pose's flags, as it does from any source.
  static double reading(const std::string& text, const std::string& where) {
    double v = 0.0;
    const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
    if (!text.empty() && r.ec == std::errc() && r.ptr == text.data() + text.size()) return v;
    return io::parse_csv_number<double>(text, where);  // a leading '+', or the reason it is no number
  }

  const grid::GloveDescription& glove_;
  int rows_ = 0;
  bool shipped_ = false;
};

/// What a glove's stream has told so far (a viewer's page reads it while the stream runs: `lock`).
struct GloveLineCounts {
  mutable std::mutex lock;
  long lines = 0;              // lines read (but blank lines, comments and the header)
  long inputs = 0;             // frames of cells and rows understood
  long skipped = 0;            // lines not understood
  long rejected = 0;           // inputs the estimator refused (readout.hpp statuses: e.g. a timestamp going back)
  long poses = 0;              // poses computed
  std::string first_skipped;   // "line N: why"
  std::string first_rejected;  // "line N: status"
  std::string calibration;     // the calibration's report of sensors read as 0, once it finished
};

/// Where a glove's lines come from, for messages: `in` read until it ends, `name` ("stdin", or a
/// file's name in quotes), `tool` the command telling on `told` ("glovepose view" on stderr).
struct GloveLineSource {
  std::istream& in;
  std::string name;
  std::string tool;
  std::ostream* told = &std::cerr;
};

/// Feeds `source`'s lines of `format` to `estimator` until they end (or `stop`), calling `pushed`
/// with the estimator's status after each input. With `calibration_seconds` the first that many
/// seconds of stream time calibrate on the fly (the model's glove's median window and flat and noise
/// rules); without, the estimator's calibration in use (a loaded file) serves every frame. Lines not
/// understood are counted in `counts`, the first told on stderr when it comes, the count when the
/// stream ends. Throws Error when the stream cannot serve a pose: no line understood, a header naming
/// other columns or coming late, a calibration without enough frames, a stream that ends within the
/// calibration, or no input the estimator took for a pose.
inline void read_glove_lines(const GloveLineSource& source, const GloveLineFormat& format, GlovePoseEstimator& estimator,
                             std::optional<double> calibration_seconds, GloveLineCounts& counts, const std::function<void(Status)>& pushed,
                             const std::atomic<bool>* stop = nullptr) {
  const auto stopped = [&] { return stop != nullptr && stop->load(); };
  // Ends the calibration at its time: enough frames, or an Error saying how many came.
  const auto finish_calibration = [&] {
    const CalibrationProgress progress = estimator.calibration_progress();
    if (!progress.ready)
      throw Error("the calibration took " + std::to_string(progress.frames) + " frames in the first " +
                  io::number_text(*calibration_seconds) + " s of stream time (--calibration-seconds), expected at least " +
                  std::to_string(progress.frames_needed) + " (its running median's window; frames: " + format.frames_from() + ")");
    const std::string report = estimator.finish_calibration().flat_report();
    if (!report.empty()) *source.told << source.tool << ": calibration: " << report << "\n";
    const std::lock_guard<std::mutex> hold(counts.lock);
    counts.calibration = report;
  };
  std::string line;
  long line_no = 0;
  bool header_allowed = true;
  double units_per_second = 1.0;  // of the time column; a header may say milliseconds
  double first = std::nan(""), last = std::nan("");
  std::vector<double> cells(static_cast<std::size_t>(estimator.model().cell_count()));
  if (calibration_seconds) estimator.start_calibration();
  while (!stopped() && std::getline(source.in, line)) {
    ++line_no;
    if (io::blank_csv_line(line) || line[line.find_first_not_of(" \t")] == '#') continue;
    GloveLineFormat::Kind kind;
    int row = 0;
    double value = 0.0, t = 0.0;
    try {
      kind = format.parse(line, line_no, cells, row, value, t);
    } catch (const Error& e) {
      const std::lock_guard<std::mutex> hold(counts.lock);
      ++counts.lines;
      if (counts.skipped++ == 0) {
        counts.first_skipped = e.what();
        *source.told << source.tool << ": " << source.name << " " << e.what()
                     << "; skipped (lines that do not parse are counted, the first is told)\n";
      }
      continue;
    }
    if (kind == GloveLineFormat::Kind::Header) {
      const std::string where = source.name + " line " + std::to_string(line_no);
      if (!header_allowed) throw Error(where + " names columns after the first line, expected rows of values");
      units_per_second = format.check_header(line, where);
      header_allowed = false;
      continue;
    }
    header_allowed = false;
    t /= units_per_second;
    if (std::isnan(first)) first = t;
    last = t;
    if (calibration_seconds && estimator.calibration_progress().collecting && t - first >= *calibration_seconds) finish_calibration();
    const Status status = kind == GloveLineFormat::Kind::Cells ? estimator.push_cells(cells.data(), static_cast<int>(cells.size()), t)
                                                               : estimator.push_row(row, value, t);
    pushed(status);
    const std::lock_guard<std::mutex> hold(counts.lock);
    ++counts.lines;
    ++counts.inputs;
    counts.poses += status == Status::Solved;
    if (status != Status::Solved && status != Status::Ok && status != Status::NotReady && status != Status::Uncalibrated &&
        counts.rejected++ == 0)
      counts.first_rejected = "line " + std::to_string(line_no) + ": " + to_string(status);
  }
  if (stopped()) return;
  const std::lock_guard<std::mutex> hold(counts.lock);
  if (counts.inputs == 0)
    throw Error("no line of " + source.name + " understood (" + std::to_string(counts.lines) + (counts.lines == 1 ? " line" : " lines") +
                (counts.skipped > 0 ? ", the first not understood: " + counts.first_skipped : "") + "), expected lines of " +
                format.expected());
  if (estimator.calibration_progress().collecting)
    throw Error(source.name + " ended after " + io::number_text(last - first) +
                " s of stream time, within the calibration (--calibration-seconds " + io::number_text(*calibration_seconds) +
                "): no pose was computed, expected a stream that goes on after the calibration");
  if (counts.poses == 0)
    throw Error("no pose computed from the " + std::to_string(counts.inputs) + " inputs of " + source.name + " (" +
                std::to_string(counts.rejected) + " refused by the estimator" +
                (counts.rejected > 0 ? ", the first: " + counts.first_rejected : "") + "; frames: " + format.frames_from() +
                "), expected frames the estimator takes");
  if (counts.skipped > 0)
    *source.told << source.tool << ": " << counts.skipped << " of " << counts.lines << " lines of " << source.name
                 << " not understood and skipped (the first: " << counts.first_skipped << ")\n";
}

/// The on-the-fly calibration's seconds, or none when a saved calibration `file` was given.
inline std::optional<double> on_the_fly_seconds(double seconds, const std::string& file) {
  return file.empty() ? std::optional<double>(seconds) : std::nullopt;
}

}  // namespace glovepose::cli
