/// @file recording_import.hpp
/// @brief Recordings of any glove, as CSV files with named columns, into one Dataset: the import a
/// glove maker runs before training (`glovepose import`).
///
/// A take is one CSV file. Its first line names the columns, in any order:
/// - every cell of the glove description, by its name (required, each once): the sensor readings;
/// - DoF names of hand::kDofs: the reference angles, radians (or degrees when
///   CsvImportOptions::degrees); DoFs without a column are not labelled (Dataset::labelled_dofs():
///   NaN, not trained, not scored), and every take must label the same DoFs;
/// - optionally `subject`, `session`, `glove` (ids >= 0), `kind` (`recording`, `calibration`, 0 or
///   1) and `timestamp` (seconds) or `timestamp_ms` (milliseconds);
/// - columns listed in CsvImportOptions::ignored_columns, skipped.
/// Any other column is an error. Ids and kind absent from the columns come from the take
/// (CsvTake); session, glove and kind default to 0, 0 and recording, the subject has no default.
/// Without a timestamp column, frames are 1 / frame_rate apart, counted per run (a run: consecutive
/// frames of one subject, session, glove and kind). Blank lines and lines starting with '#' are
/// skipped. Imported frames are not collision outliers (outlier = 0) and donning = session.
///
/// A calibration take must move every sensor: a cell that is flat over a calibration run (the
/// calibration's own rule, sensor::is_flat_range) is an error naming the file, the run's lines and
/// the column, unless CsvImportOptions::allow_flat, which keeps the data and lists the sensor in
/// RecordingImporter::flat_sensors().
///
/// Set-up code: every error is a glovepose::Error starting "CSV file '<path>', line L, column 'C'"
/// (as much of that as applies) and saying what was expected.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <istream>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "../config.hpp"
#include "../grid/glove_description.hpp"
#include "../hand/dofs.hpp"
#include "../io/csv_fields.hpp"
#include "../io/number_text.hpp"
#include "../sensor/calibration.hpp"
#include "../io/dataset.hpp"

namespace glovepose::train {

/// @brief One CSV file and the ids its columns do not carry.
struct CsvTake {
  std::string path;                     ///< The file (named in every error).
  std::optional<std::int32_t> subject;  ///< Subject of every row, when the file has no `subject` column.
  std::optional<std::int32_t> session;  ///< Session of every row, when the file has no `session` column (else 0).
  std::optional<std::uint8_t> kind;     ///< io::kKindRecording or io::kKindCalibration, when the file has no `kind` column.
};

/// @brief How the takes are read.
struct CsvImportOptions {
  double frame_rate =
      0.0;  ///< Frames per second (> 0; 0: the glove description's rate_hz): the dataset's rate, and the spacing without timestamps.
  bool degrees = false;                      ///< Angle columns are in degrees (stored as radians).
  std::vector<std::string> ignored_columns;  ///< Columns to skip (e.g. a frame counter).
  bool allow_flat = false;                   ///< Keep a calibration take where a sensor is flat (listed in flat_sensors()).
};

/// @brief A sensor found flat in a calibration run that was kept (CsvImportOptions::allow_flat).
struct FlatSensor {
  std::string path;                           ///< The take.
  std::size_t first_line = 0, last_line = 0;  ///< The run's lines in the file.
  std::string cell;                           ///< The cell's name.
  double min = 0.0, max = 0.0;                ///< Its readings' range over the run.
};

/// @brief Reads takes into one dataset for one glove.
class RecordingImporter {
 public:
  /// @brief An importer for `glove`; a sensor is flat by the glove's calibration rule
  /// (calibration.flat_relative_range). Throws glovepose::Error unless the rate (options.frame_rate,
  /// else the description's rate_hz) is a positive finite number that the description does not
  /// contradict, and no ignored column is also a cell or DoF name.
  RecordingImporter(grid::GloveDescription glove, CsvImportOptions options)
      : glove_(std::move(glove)),
        options_(std::move(options)),
        data_(static_cast<std::size_t>(glove_.cell_count()), 0, glove_.id(), checked_rate(options_.frame_rate, glove_)) {
    for (const std::string& name : options_.ignored_columns)
      if (cell_of(name) >= 0 || dof_of(name) >= 0)
        throw Error("ignored column '" + name + "' is a cell or DoF of glove '" + glove_.id() + "', expected another column");
  }

  /// @brief Reads the take from its file. Throws glovepose::Error (see the file comment).
  void add(const CsvTake& take) {
    std::ifstream file(take.path);
    if (!file) throw Error("CSV file '" + take.path + "': cannot open, expected a readable file");
    add(file, take);
  }

  /// @brief Reads the take from `in` (take.path names it in errors). On an error, the dataset is
  /// left as it was before the call.
  void add(std::istream& in, const CsvTake& take) {
    const std::size_t before = data_.frames();
    const std::size_t flats_before = flat_.size();
    const auto metadata_before = data_.metadata;
    try {
      read(in, take);
    } catch (...) {
      truncate(before);
      data_.metadata = metadata_before;
      flat_.resize(flats_before);
      throw;
    }
  }

  /// @brief The frames read so far.
  const io::Dataset& dataset() const noexcept { return data_; }
  /// @brief Flat sensors of calibration runs kept under allow_flat, in the order met.
  const std::vector<FlatSensor>& flat_sensors() const noexcept { return flat_; }

 private:
  // What each column of a take holds.
  enum class Role { Cell, Dof, Subject, Session, Glove, Kind, Seconds, Milliseconds, Ignored };
  struct Column {
    Role role;
    int index = 0;  // cell or DoF index
  };

  static double checked_rate(double rate, const grid::GloveDescription& glove) {
    const std::optional<double> described = glove.rate_hz();
    if (rate == 0.0 && described) return *described;
    if (!(rate > 0.0) || !std::isfinite(rate))
      throw Error("frame rate " + io::number_text(rate) +
                  ", expected a positive number of frames per second (or a glove description with 'rate_hz')");
    if (described && *described != rate)
      throw Error("frame rate " + io::number_text(rate) + ", but glove '" + glove.id() + "' is described at " +
                  io::number_text(*described) + " frames per second, expected the description's rate (or none)");
    return rate;
  }
  int cell_of(const std::string& name) const {
    const auto& names = glove_.cell_names();
    for (std::size_t c = 0; c < names.size(); ++c)
      if (names[c] == name) return static_cast<int>(c);
    return -1;
  }
  static int dof_of(const std::string& name) {
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      if (name == hand::kDofs[d].name) return static_cast<int>(d);
    return -1;
  }

  std::vector<Column> columns_of(const std::vector<std::string>& header, const std::string& at) const {
    const std::pair<const char*, Role> named[] = {{"subject", Role::Subject},   {"session", Role::Session},
                                                  {"glove", Role::Glove},       {"kind", Role::Kind},
                                                  {"timestamp", Role::Seconds}, {"timestamp_ms", Role::Milliseconds}};
    std::vector<Column> columns;
    std::vector<int> cell_column(static_cast<std::size_t>(glove_.cell_count()), -1);
    int times = 0;
    for (std::size_t k = 0; k < header.size(); ++k) {
      const std::string& name = header[k];
      const std::string where = at + ", column " + std::to_string(k + 1) + " '" + name + "'";
      if (name.empty()) throw Error(at + ", column " + std::to_string(k + 1) + ": empty column name, expected a name");
      for (std::size_t earlier = 0; earlier < k; ++earlier)
        if (header[earlier] == name)
          throw Error(where + ": named like column " + std::to_string(earlier + 1) + ", expected each column once");
      const bool ignored =
          std::find(options_.ignored_columns.begin(), options_.ignored_columns.end(), name) != options_.ignored_columns.end();
      std::optional<Column> column;
      if (ignored) column = Column{Role::Ignored};
      for (const auto& [text, role] : named)
        if (!column && name == text) column = Column{role};
      if (const int c = cell_of(name); !column && c >= 0) {
        column = Column{Role::Cell, c};
        cell_column[static_cast<std::size_t>(c)] = static_cast<int>(k);
      }
      if (const int d = dof_of(name); !column && d >= 0) {
        column = Column{Role::Dof, d};
      }
      if (!column)
        throw Error(where + ": unknown column, expected a cell of glove '" + glove_.id() + "' (e.g. '" + glove_.cell_names().front() +
                    "'), a DoF name (e.g. '" + hand::kDofs[0].name +
                    "'), subject, session, glove, kind, timestamp or timestamp_ms"
                    " (skip other columns by name: ignored_columns, `glovepose import --ignore COLUMN[,COLUMN...]`)");
      times += column->role == Role::Seconds || column->role == Role::Milliseconds;
      columns.push_back(*column);
    }
    for (std::size_t c = 0; c < cell_column.size(); ++c)
      if (cell_column[c] < 0)
        throw Error(at + ": no column '" + glove_.cell_names()[c] + "', expected one column per cell of glove '" + glove_.id() + "' (" +
                    std::to_string(glove_.cell_count()) + " cells)");
    if (times > 1) throw Error(at + ": both timestamp and timestamp_ms, expected at most one time column");
    return columns;
  }

  void read(std::istream& in, const CsvTake& take) {
    const std::string at = "CSV file '" + take.path + "'";
    std::string line;
    std::size_t line_no = 0;
    bool header_read = false;
    while (!header_read && std::getline(in, line)) {
      ++line_no;
      header_read = !skipped(line);
    }
    if (!header_read)
      throw Error(at + ", line " + std::to_string(line_no + 1) + ": " + std::string(in.bad() ? "read error" : "no header") +
                  ", expected the column names (the glove's cells, optionally the 25 DoFs, subject, session, glove, kind, timestamp)");
    const std::size_t header_line = line_no;
    const std::vector<std::string> header = io::split_csv_line(line);
    const std::vector<Column> columns = columns_of(header, at + ", line " + std::to_string(header_line));
    const auto has = [&](Role role) {
      return std::any_of(columns.begin(), columns.end(), [&](const Column& c) { return c.role == role; });
    };
    if (!has(Role::Subject) && !take.subject)
      throw Error(at + ", line " + std::to_string(header_line) +
                  ": no 'subject' column and no subject given for the file, expected one of them");
    const bool angles = has(Role::Dof);
    hand::DofSet labelled{};
    for (const Column& column : columns)
      if (column.role == Role::Dof) labelled[static_cast<std::size_t>(column.index)] = true;
    if (data_.frames() > 0 && angles != data_.has_angles())
      throw Error(at + ", line " + std::to_string(header_line) + ": " + std::string(angles ? "has" : "has no") + " DoF columns, expected " +
                  (data_.has_angles() ? "the DoFs" : "none") + " as the takes before it");
    if (angles && data_.frames() > 0 && labelled != data_.labelled_dofs())
      throw Error(at + ", line " + std::to_string(header_line) + ": DoF columns " + hand::dof_set_text(labelled) +
                  ", expected the DoFs of the takes before it (" + hand::dof_set_text(data_.labelled_dofs()) + ")");
    if (angles && data_.frames() == 0) data_.set_labelled_dofs(labelled);
    const double deg = options_.degrees ? 3.14159265358979323846 / 180.0 : 1.0;
    const std::size_t first_frame = data_.frames();
    std::vector<std::size_t> line_of;  // file line of each frame of this take
    std::vector<float> cells(static_cast<std::size_t>(glove_.cell_count()));
    std::vector<float> pose(angles ? hand::kDofCount : 0);
    while (std::getline(in, line)) {
      ++line_no;
      if (skipped(line)) continue;
      const std::vector<std::string> fields = io::split_csv_line(line);
      const std::string at_line = at + ", line " + std::to_string(line_no);
      if (fields.size() != columns.size())
        throw Error(at_line + ": " + std::to_string(fields.size()) + " fields, expected " + std::to_string(columns.size()) +
                    " (one per column of line " + std::to_string(header_line) + ")");
      std::int32_t subject = take.subject.value_or(0), session = take.session.value_or(0), glove = 0;
      std::uint8_t kind = take.kind.value_or(io::kKindRecording);
      std::optional<double> time;
      std::fill(pose.begin(), pose.end(), NAN);
      for (std::size_t k = 0; k < fields.size(); ++k) {
        const std::string where = at_line + ", column '" + header[k] + "': '" + fields[k] + "'";
        const Column& column = columns[k];
        switch (column.role) {
          case Role::Cell:
            cells[static_cast<std::size_t>(column.index)] = io::parse_csv_number<float>(fields[k], where);
            break;
          case Role::Dof:
            pose[static_cast<std::size_t>(column.index)] = static_cast<float>(io::parse_csv_number<double>(fields[k], where) * deg);
            if (!std::isfinite(pose[static_cast<std::size_t>(column.index)])) throw Error(where + " is not a finite angle");
            break;
          case Role::Subject:
            subject = io::parse_csv_id(fields[k], where);
            break;
          case Role::Session:
            session = io::parse_csv_id(fields[k], where);
            break;
          case Role::Glove:
            glove = io::parse_csv_id(fields[k], where);
            break;
          case Role::Kind:
            kind = parse_kind(fields[k], where);
            break;
          case Role::Seconds:
            time = parse_time(fields[k], where);
            break;
          case Role::Milliseconds:
            time = parse_time(fields[k], where) / 1000.0;
            break;
          case Role::Ignored:
            break;
        }
      }
      const std::size_t n = data_.frames();
      const bool continues = n > 0 && data_.subject[n - 1] == subject && data_.session[n - 1] == session && data_.glove[n - 1] == glove &&
                             data_.kind[n - 1] == kind;
      if (!time) time = continues ? data_.timestamps[n - 1] + 1.0 / data_.frame_rate() : 0.0;
      if (continues && !(*time > data_.timestamps[n - 1]))
        throw Error(at_line + ": time " + io::number_text(*time) + " s is not after the frame before (" +
                    io::number_text(data_.timestamps[n - 1]) + " s) of subject " + std::to_string(subject) + ", session " +
                    std::to_string(session) + ", expected increasing times within a run (give each take its own session id)");
      data_.cells.insert(data_.cells.end(), cells.begin(), cells.end());
      data_.angles.insert(data_.angles.end(), pose.begin(), pose.end());
      data_.timestamps.push_back(*time);
      data_.subject.push_back(subject);
      data_.session.push_back(session);
      data_.glove.push_back(glove);
      data_.donning.push_back(session);
      data_.kind.push_back(kind);
      data_.outlier.push_back(0);
      line_of.push_back(line_no);
    }
    if (in.bad()) throw Error(at + ", line " + std::to_string(line_no + 1) + ": read error");
    if (line_of.empty()) throw Error(at + ": no frames after the header, expected at least one row of readings");
    check_calibration_runs(first_frame, line_of, take.path);
  }

  // A time stamp as a number; a time of day (a common logger format) is named as such, with the ways out.
  static double parse_time(const std::string& text, const std::string& where) {
    if (text.find(':') != std::string::npos)
      throw Error(where + " is a time of day, expected a number of seconds (or milliseconds for timestamp_ms): convert the column, "
                          "or skip it (ignored_columns, `glovepose import --ignore COLUMN`) and frames are 1/rate apart");
    return io::parse_csv_number<double>(text, where);
  }

  static std::uint8_t parse_kind(const std::string& text, const std::string& where) {
    if (text == "recording" || text == "0") return io::kKindRecording;
    if (text == "calibration" || text == "1") return io::kKindCalibration;
    throw Error(where + " is not a kind, expected recording, calibration, 0 or 1");
  }

  // Blank lines and comments ('#' first) are not read.
  static bool skipped(const std::string& line) { return io::blank_csv_line(line) || line[line.find_first_not_of(" \t")] == '#'; }

  // Every calibration run of the frames from `first` on: a flat cell is an error, or kept and listed.
  void check_calibration_runs(std::size_t first, const std::vector<std::size_t>& line_of, const std::string& path) {
    const std::size_t cells = data_.cell_count;
    const sensor::CalibrationConfig flat_rule = glove_.calibration().config();
    for (std::size_t begin = first; begin < data_.frames();) {
      std::size_t end = begin + 1;
      while (end < data_.frames() && data_.same_run(begin, end)) ++end;
      if (data_.kind[begin] == io::kKindCalibration) {
        for (std::size_t c = 0; c < cells; ++c) {
          double lo = std::numeric_limits<double>::infinity(), hi = -lo;
          for (std::size_t i = begin; i < end; ++i) {
            lo = std::min(lo, static_cast<double>(data_.cells[i * cells + c]));
            hi = std::max(hi, static_cast<double>(data_.cells[i * cells + c]));
          }
          if (!sensor::is_flat_range(lo, hi, flat_rule)) continue;
          FlatSensor flat{path, line_of[begin - first], line_of[end - 1 - first], glove_.cell_names()[c], lo, hi};
          if (!options_.allow_flat)
            throw Error("CSV file '" + path + "', lines " + std::to_string(flat.first_line) + "-" + std::to_string(flat.last_line) +
                        " (calibration of subject " + std::to_string(data_.subject[begin]) + ", session " +
                        std::to_string(data_.session[begin]) + "), column '" + flat.cell + "': flat (" + io::number_text(lo) + " to " +
                        io::number_text(hi) + ", a range within " + io::number_text(100.0 * flat_rule.min_relative_range) +
                        "% of its value), expected a calibration that moves every sensor (calibrated, it would read 0; "
                        "allow flat sensors to keep the take, or give the glove description a smaller calibration.flat_relative_range)");
          flat_.push_back(std::move(flat));
        }
      }
      begin = end;
    }
  }

  void truncate(std::size_t frames) {
    const auto cut = [frames](auto& v, std::size_t per_frame) { v.resize(std::min(v.size(), frames * per_frame)); };
    cut(data_.cells, data_.cell_count);
    cut(data_.angles, hand::kDofCount);
    cut(data_.timestamps, 1);
    cut(data_.subject, 1);
    cut(data_.session, 1);
    cut(data_.glove, 1);
    cut(data_.donning, 1);
    cut(data_.kind, 1);
    cut(data_.outlier, 1);
  }

  grid::GloveDescription glove_;
  CsvImportOptions options_;
  io::Dataset data_;
  std::vector<FlatSensor> flat_;
};

}  // namespace glovepose::train
