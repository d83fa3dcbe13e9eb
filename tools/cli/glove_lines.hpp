// A glove's own stream as text lines, for the tool's commands that read one (glovepose view --stdin,
// glovepose predict --raw): the line format, and the loop that feeds the lines to an estimator,
// calibrating on the fly from the first seconds of stream time or with the calibration it was given,
// counting the lines it cannot use and telling why a stream cannot serve a pose.
#pragma once

#include <glovepose/estimator.hpp>
#include <glovepose/io/csv_fields.hpp>
#include <glovepose/io/number_text.hpp>
#include <glovepose/model/model_info.hpp>  // CalibrationMode; PoseModel::range_map()'s type
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

/// What reading a glove's stream does whatever its form (lines here, wire frames in glove_frames.hpp):
/// the calibration made on the fly over the first seconds of stream time, the inputs fed to the
/// estimator, the counts, and the checks when the stream ends. `unit` names what the stream is made
/// of in messages ("line", "frame").
class GloveFeed {
 public:
  GloveFeed(const GloveLineSource& source, const GloveLineFormat& format, GlovePoseEstimator& estimator,
            std::optional<double> calibration_seconds, GloveLineCounts& counts, const std::function<void(Status)>& pushed, std::string unit)
      : source_(source), format_(format), estimator_(estimator), seconds_(calibration_seconds), counts_(counts), pushed_(pushed),
        unit_(std::move(unit)) {
    if (seconds_) estimator_.start_calibration();
  }

  /// One input at stream time `t` (seconds): `push()` gives it to the estimator and returns its
  /// status; `where()` names it in a message ("line 12").
  template <typename Push, typename Where>
  void input(double t, Push&& push, Where&& where) {
    if (std::isnan(first_)) first_ = t;
    last_ = t;
    if (seconds_ && estimator_.calibration_progress().collecting && t - first_ >= *seconds_) finish_calibration();
    const Status status = push();
    pushed_(status);
    const std::lock_guard<std::mutex> hold(counts_.lock);
    ++counts_.inputs;
    counts_.poses += status == Status::Solved;
    if (status != Status::Solved && status != Status::Ok && status != Status::NotReady && status != Status::Uncalibrated &&
        counts_.rejected++ == 0)
      counts_.first_rejected = where() + ": " + to_string(status);
  }

  /// One more line or frame read (`skipped`: not understood, `why` says so; the first is told).
  void read(bool skipped, const std::string& why = {}) {
    const std::lock_guard<std::mutex> hold(counts_.lock);
    ++counts_.lines;
    if (!skipped || counts_.skipped++ > 0) return;
    counts_.first_skipped = why;
    *source_.told << source_.tool << ": " << source_.name << " " << why << "; skipped (" << unit_
                  << "s that cannot be used are counted, the first is told)\n";
  }

  /// The stream ended: throws Error when it could not serve a pose (see read_glove_lines).
  void end() const {
    const std::lock_guard<std::mutex> hold(counts_.lock);
    if (counts_.inputs == 0)
      throw Error("no " + unit_ + " of " + source_.name + " understood (" + std::to_string(counts_.lines) + " " + unit_ +
                  (counts_.lines == 1 ? "" : "s") + (counts_.skipped > 0 ? ", the first not understood: " + counts_.first_skipped : "") +
                  "), expected " + unit_ + "s of " + format_.expected());
    if (estimator_.calibration_progress().collecting)
      throw Error(source_.name + " ended after " + io::number_text(last_ - first_) +
                  " s of stream time, within the calibration (--calibration-seconds " + io::number_text(*seconds_) +
                  "): no pose was computed, expected a stream that goes on after the calibration");
    if (counts_.poses == 0)
      throw Error("no pose computed from the " + std::to_string(counts_.inputs) + " inputs of " + source_.name + " (" +
                  std::to_string(counts_.rejected) + " refused by the estimator" +
                  (counts_.rejected > 0 ? ", the first: " + counts_.first_rejected : "") + "; frames: " + format_.frames_from() +
                  "), expected frames the estimator takes");
    if (counts_.skipped > 0)
      *source_.told << source_.tool << ": " << counts_.skipped << " of " << counts_.lines << " " << unit_ << "s of " << source_.name
                    << " not understood and skipped (the first: " << counts_.first_skipped << ")\n";
  }

 private:
  // Ends the calibration at its time: enough frames, or an Error saying how many came.
  void finish_calibration() {
    const CalibrationProgress progress = estimator_.calibration_progress();
    if (!progress.ready)
      throw Error("the calibration took " + std::to_string(progress.frames) + " frames in the first " + io::number_text(*seconds_) +
                  " s of stream time (--calibration-seconds), expected at least " + std::to_string(progress.frames_needed) +
                  " (its running median's window; frames: " + format_.frames_from() + ")");
    const std::string report = estimator_.finish_calibration().flat_report();
    if (!report.empty()) *source_.told << source_.tool << ": calibration: " << report << "\n";
    const std::lock_guard<std::mutex> hold(counts_.lock);
    counts_.calibration = report;
  }

  const GloveLineSource& source_;
  const GloveLineFormat& format_;
  GlovePoseEstimator& estimator_;
  std::optional<double> seconds_;
  GloveLineCounts& counts_;
  const std::function<void(Status)>& pushed_;
  std::string unit_;
  double first_ = std::nan(""), last_ = std::nan("");
};

/// Feeds `source`'s lines of `format` to `estimator` until they end (or `stop`), calling `pushed`
/// with the estimator's status after each input. With `calibration_seconds` the first that many
/// seconds of stream time calibrate on the fly (the model's glove's median window and flat and noise
/// rules); without, the estimator's calibration in use (a loaded file) serves every frame. Lines not
/// understood are counted in `counts`, the first told on stderr when it comes, the count when the
/// stream ends. Throws Error when the stream cannot serve a pose: no line understood, a header naming
/// other columns or coming late, a calibration without enough frames, a stream that ends within the
/// calibration, or no input the estimator took for a pose. `first_bytes`: bytes already taken from
/// `source.in` (glove_frames.hpp looks at a stream's start; no line end among them), read as the
/// start of its first line.
inline void read_glove_lines(const GloveLineSource& source, const GloveLineFormat& format, GlovePoseEstimator& estimator,
                             std::optional<double> calibration_seconds, GloveLineCounts& counts, const std::function<void(Status)>& pushed,
                             const std::atomic<bool>* stop = nullptr, std::string first_bytes = {}) {
  const auto stopped = [&] { return stop != nullptr && stop->load(); };
  GloveFeed feed(source, format, estimator, calibration_seconds, counts, pushed, "line");
  std::string line;
  long line_no = 0;
  bool header_allowed = true;
  double units_per_second = 1.0;  // of the time column; a header may say milliseconds
  std::vector<double> cells(static_cast<std::size_t>(estimator.model().cell_count()));
  bool first_pending = !first_bytes.empty();
  const auto next_line = [&] {
    const bool got = static_cast<bool>(std::getline(source.in, line));
    if (first_pending) {  // the stream's first bytes begin its first line (and are a whole line if nothing follows)
      line = first_bytes + (got ? line : std::string());
      first_pending = false;
      return true;
    }
    return got;
  };
  while (!stopped() && next_line()) {
    ++line_no;
    if (io::blank_csv_line(line) || line[line.find_first_not_of(" \t")] == '#') continue;
    GloveLineFormat::Kind kind;
    int row = 0;
    double value = 0.0, t = 0.0;
    try {
      kind = format.parse(line, line_no, cells, row, value, t);
    } catch (const Error& e) {
      feed.read(true, e.what());
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
    feed.input(
        t,
        [&] {
          return kind == GloveLineFormat::Kind::Cells ? estimator.push_cells(cells.data(), static_cast<int>(cells.size()), t)
                                                      : estimator.push_row(row, value, t);
        },
        [&] { return "line " + std::to_string(line_no); });
    feed.read(false);
  }
  if (stopped()) return;
  feed.end();
}

/// How a stream's glove is calibrated: a saved calibration, the model's own (the training-set range
/// of a model trained with it), on the fly over the stream's first seconds, or continuously from
/// the first frame (no calibration step).
struct GloveCalibrationChoice {
  std::optional<double> on_the_fly;  ///< Seconds of stream time to calibrate over; none: no calibration on the fly.
  bool training_range = false;       ///< The model's training-set range (use_training_calibration()).
  std::string text;                  ///< The choice in words, for the user.
  bool continuous = false;           ///< From the wearer's free motion, poses from the first frame (use_continuous_calibration()).

  /// Sets `estimator` up for it (a saved `file` is loaded by the caller, who may first look for one).
  /// On the fly, no pose comes before the calibration ends (the tools' documented behaviour), so the
  /// continuous calibration a model with a range map starts with is cleared.
  void apply(GlovePoseEstimator& estimator) const {
    if (training_range)
      estimator.use_training_calibration();
    else if (continuous)
      estimator.use_continuous_calibration();
    else if (on_the_fly)
      estimator.clear_calibration();
  }
};

/// The calibration a stream gets: the saved `file` when given; else on the fly over `seconds` when
/// they were given or the model was trained so (on-the-fly calibration); else the model's
/// training-set range. Throws Error for a model trained on uncalibrated cells, which the estimator
/// (it calibrates every frame) cannot run as it was trained.
inline GloveCalibrationChoice choose_glove_calibration(const PoseModel& model, double seconds, bool seconds_given, const std::string& file) {
  const model::CalibrationMode trained = model.info().calibration;
  if (trained == model::CalibrationMode::None)
    throw Error("the model was trained on uncalibrated cells (--calibration-mode none), which a glove's stream cannot give (the estimator "
                "calibrates every frame), expected a model trained with --calibration-mode onthefly or training");
  if (!file.empty()) return {std::nullopt, false, "the saved calibration '" + file + "'"};
  if (seconds_given && seconds == 0.0) {
    if (!model.range_map())
      throw Error("--calibration-seconds 0 (no calibration step): the model carries no range map, expected a model fitted by glovepose "
                  "fit-guided, or S > 0 seconds to calibrate over");
    return {std::nullopt, false, "continuous from the first frame, from the wearer's free motion (no calibration step)", true};
  }
  if (trained == model::CalibrationMode::Training && !seconds_given)
    return {std::nullopt, true,
            "the model's training-set range, as it was trained (--calibration-seconds S calibrates on the fly over the first S s "
            "instead)"};
  return {seconds, false,
          "on the fly over the first " + io::number_text(seconds) + " s of stream time, the user moving through extreme poses" +
              (trained == model::CalibrationMode::Training ? " (the model was trained with its training-set range)" : "")};
}

}  // namespace glovepose::cli
