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
/// - a hand tracker's keypoints instead of DoF columns (train/keypoint_columns.hpp: `<keypoint>_x`,
///   `_y`, `_z` of MediaPipe's or OpenXR's keypoint names, CsvImportOptions::keypoint_scale mm per
///   unit), or the same in a file of its own with the tracker's timestamps (CsvTake::keypoints);
///   finish() turns them into the labels (train/keypoint_labels.hpp);
/// - columns listed in CsvImportOptions::ignored_columns (names, or patterns with '*' and '?'),
///   skipped; a pattern never skips a cell's or a DoF's column.
/// Any other column is an error. Ids and kind absent from the columns come from the take
/// (CsvTake); session, glove and kind default to 0, 0 and recording, the subject has no default.
/// Without a timestamp column, frames are 1 / frame_rate apart, counted per run (a run: consecutive
/// frames of one subject, session, glove and kind). Blank lines and lines starting with '#' are
/// skipped. Imported frames are not collision outliers (outlier = 0), except frames of keypoint takes
/// without a trusted label (outlier = 1, their angles the rest pose), and donning = session.
///
/// Keypoint takes: finish() fits each subject's hand to all their takes' keypoints, then labels
/// every take (its clock placed on the glove's by the motion both show, unless an offset is given).
/// A take's timestamps that disagree with the frame rate by more than 10% are reported in warnings().
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
#include <array>
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

#include "../core/units.hpp"
#include "../config.hpp"
#include "../core/statistics.hpp"
#include "../grid/glove_description.hpp"
#include "../hand/dofs.hpp"
#include "../io/csv_fields.hpp"
#include "../io/number_text.hpp"
#include "../hand/keypoint_fit.hpp"
#include "../hand/keypoints.hpp"
#include "../io/dataset.hpp"
#include "../sensor/calibration.hpp"
#include "keypoint_columns.hpp"
#include "keypoint_labels.hpp"

namespace glovepose::train {

/// @brief One CSV file and the ids its columns do not carry.
struct CsvTake {
  std::string path;                     ///< The file (named in every error).
  std::optional<std::int32_t> subject;  ///< Subject of every row, when the file has no `subject` column.
  std::optional<std::int32_t> session;  ///< Session of every row, when the file has no `session` column (else 0).
  std::optional<std::uint8_t> kind;     ///< io::kKindRecording or io::kKindCalibration, when the file has no `kind` column.
  std::string keypoints = {};           ///< A hand tracker's keypoint file for the take (read_keypoint_file), or none.
};

/// @brief How the takes are read.
struct CsvImportOptions {
  double frame_rate =
      0.0;  ///< Frames per second (> 0; 0: the glove description's rate_hz): the dataset's rate, and the spacing without timestamps.
  bool degrees = false;                      ///< Angle columns are in degrees (stored as radians).
  std::vector<std::string> ignored_columns;  ///< Columns to skip (e.g. a frame counter): names or patterns ('*', '?'; io::column_matches).
  bool allow_flat = false;                   ///< Keep a calibration take where a sensor is flat (listed in flat_sensors()).
  double keypoint_scale = 1000.0;            ///< Millimetres per keypoint unit (1000: metres, as MediaPipe's world landmarks and OpenXR).
  KeypointLabelConfig keypoint_labels = {};  ///< How keypoints become labels (a known clock offset, the glove's delay, smoothing).
};

/// @brief What finish() found in a keypoint take.
struct KeypointTakeReport {
  std::string path;                  ///< The take.
  std::string keypoint_file;         ///< Its keypoint file, or empty (keypoint columns in the take).
  std::int32_t subject = 0;          ///< Whose hand.
  hand::KeypointLayout layout = hand::KeypointLayout::MediaPipe;
  ClockAlignment clock;              ///< The offset found (correlation NaN: given).
  double median_rms_mm = 0.0;        ///< Median fit residual of its tracker frames.
  double p95_rms_mm = 0.0;           ///< 95th percentile of the same.
  std::size_t frames = 0;            ///< Glove frames of the take.
  std::size_t labelled = 0;          ///< Of those, with a trusted label.
  std::size_t first_frame = 0;       ///< The take's first frame in the dataset.
  std::vector<double> frame_rms_mm;  ///< Per frame of the take: the fit residual behind its label (TakeLabels::frame_rms_mm).
  std::array<double, hand::kDofCount> at_limit{};  ///< Per DoF, the share of labelled frames within 1% of its range of a joint limit (NaN: not labelled).
};

/// @brief A subject's hand as finish() fitted it to their keypoints.
struct KeypointSubjectReport {
  std::int32_t subject = 0;
  double hand_length_mm = 0.0;       ///< Wrist to the middle fingertip along the bones.
  double noise_mm = 0.0;             ///< The keypoints' noise seen on the palm (3D RMS).
  double fit_mm = 0.0;               ///< Median fit residual of the hand (a right hand) to its keypoints as given.
  double mirrored_fit_mm = NAN;      ///< The same for the keypoints mirrored (a left hand's); NaN when they fit no hand.
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
      if (name.find_first_of("*?") == std::string::npos && (cell_of(name) >= 0 || dof_of(name) >= 0))
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
    const std::size_t flats_before = flat_.size(), pending_before = pending_.size(), warnings_before = warnings_.size();
    const auto metadata_before = data_.metadata;
    const bool had_angles = data_.has_angles();
    try {
      read(in, take);
    } catch (...) {
      truncate(before);
      if (!had_angles) data_.angles.clear();  // the NaN angles it gave the sensors-only calibration takes before it
      data_.metadata = metadata_before;
      flat_.resize(flats_before);
      pending_.resize(pending_before);
      warnings_.resize(warnings_before);
      throw;
    }
  }

  /// @brief Turns the keypoint takes' keypoints into labels (see the file comment); call it once
  /// after the last add(). Throws glovepose::Error naming the takes when a subject's hand cannot be
  /// fitted (too few frames, keypoints in another unit), a take's clock cannot be placed, or a take
  /// has no trusted frame; the dataset is then left without those labels.
  void finish() {
    keypoint_takes_.clear();
    keypoint_subjects_.clear();
    std::vector<std::int32_t> subjects;
    for (const Pending& take : pending_)
      if (std::find(subjects.begin(), subjects.end(), take.subject) == subjects.end()) subjects.push_back(take.subject);
    for (const std::int32_t subject : subjects) {
      std::vector<Eigen::Vector3d> points;
      std::string files;
      std::optional<hand::KeypointLayout> layout;
      for (const Pending& take : pending_) {
        if (take.subject != subject) continue;
        files += (files.empty() ? "'" : ", '") + take.path + "'";
        if (layout && *layout != take.layout)
          throw Error("keypoints of subject " + std::to_string(subject) + " (" + files + "): both " + hand::to_string(*layout) + " and " +
                      hand::to_string(take.layout) + " keypoints, expected one tracker's per person");
        layout = take.layout;
        points.insert(points.end(), take.track.points.begin(), take.track.points.end());
      }
      hand::HandShapeFit shape;
      try {
        shape = hand::fit_hand_shape(*layout, points, hand::Kinematics());
      } catch (const Error& e) {
        throw Error("keypoints of subject " + std::to_string(subject) + " (" + files + "), " + e.what() + " (keypoint unit: " +
                    io::number_text(options_.keypoint_scale) + " mm; `glovepose import --keypoint-unit`)");
      }
      const hand::KeypointIk ik(hand::KeypointModel(*layout, hand::Kinematics(shape.model)), hand::JointLimits(), options_.keypoint_labels.ik);
      // Which hand: the glove's model is a right hand, and a left hand's keypoints (or a tracker's
      // mirrored frame) fit it only with joints bent the wrong way. Fitted both ways, the better
      // side must be the one given.
      KeypointSubjectReport report{subject, shape.hand_length_mm, shape.noise_mm * std::sqrt(3.0), median_fit_mm(ik, points), NAN};
      std::vector<Eigen::Vector3d> mirrored = points;
      for (Eigen::Vector3d& p : mirrored) p.x() = -p.x();
      try {
        const hand::HandShapeFit other = hand::fit_hand_shape(*layout, mirrored, hand::Kinematics());
        report.mirrored_fit_mm = median_fit_mm(
            hand::KeypointIk(hand::KeypointModel(*layout, hand::Kinematics(other.model)), hand::JointLimits(), options_.keypoint_labels.ik),
            mirrored);
      } catch (const Error&) {
        // no hand fits them mirrored: they are a right hand's
      }
      const auto mm = [](double v) { return io::number_text(std::round(v * 10.0) / 10.0); };
      if (report.mirrored_fit_mm * kHandednessMargin < report.fit_mm)
        throw Error("keypoints of subject " + std::to_string(subject) + " (" + files + ") fit a left hand, not a right one: median fit residual " +
                    mm(report.fit_mm) + " mm as given, " + mm(report.mirrored_fit_mm) + " mm mirrored; expected a right hand's keypoints, as "
                    "the glove's hand model is: mirror them first (negate one coordinate, e.g. x)");
      if (!(report.mirrored_fit_mm > kHandednessMargin * report.fit_mm))
        warnings_.push_back("keypoints of subject " + std::to_string(subject) + " (" + files + "): a right hand fits them about as well as a left "
                            "one (median fit residual " + mm(report.fit_mm) + " mm as given, " + mm(report.mirrored_fit_mm) +
                            " mm mirrored): check that they are a right hand's");
      keypoint_subjects_.push_back(report);
      for (const Pending& take : pending_) {
        if (take.subject != subject) continue;
        label(take, ik);
      }
    }
    pending_.clear();
  }

  /// @brief The keypoint takes finish() labelled, in the order of their subjects.
  const std::vector<KeypointTakeReport>& keypoint_takes() const noexcept { return keypoint_takes_; }
  /// @brief The hands finish() fitted.
  const std::vector<KeypointSubjectReport>& keypoint_subjects() const noexcept { return keypoint_subjects_; }
  /// @brief What the takes read so far did that may be a mistake (a frame rate their timestamps contradict).
  const std::vector<std::string>& warnings() const noexcept { return warnings_; }

  /// @brief The frames read so far (keypoint takes without labels until finish()).
  const io::Dataset& dataset() const noexcept { return data_; }
  /// @brief Flat sensors of calibration runs kept under allow_flat, in the order met.
  const std::vector<FlatSensor>& flat_sensors() const noexcept { return flat_; }

 private:
  // A DoF whose labels sit at a joint limit in more of a take's frames than this is warned about.
  static constexpr double kPinnedShare = 0.25;
  static constexpr double kPinnedRange = 0.01;  // within this share of its range of a limit: at the limit
  // How much better one side must fit than the other to tell a right hand from a left one.
  static constexpr double kHandednessMargin = 1.5;

  // The median fit residual of `ik`'s hand over up to 300 frames spread across `points`.
  static double median_fit_mm(const hand::KeypointIk& ik, const std::vector<Eigen::Vector3d>& points) {
    const std::size_t count = ik.model().count(), frames = points.size() / count;
    const std::size_t step = std::max<std::size_t>(1, frames / 300);
    std::vector<double> residuals;
    for (std::size_t f = 0; f < frames; f += step) {
      hand::KeypointPositions observed{};
      for (std::size_t k = 0; k < count; ++k) observed[k] = points[f * count + k];
      const double rms = ik.solve(observed, hand::JointLimits().rest(), nullptr).rms_mm;
      if (std::isfinite(rms)) residuals.push_back(rms);
    }
    return residuals.empty() ? NAN : core::percentile(residuals, 0.5);
  }

  // What each column of a take holds.
  enum class Role { Cell, Dof, Keypoint, Subject, Session, Glove, Kind, Seconds, Milliseconds, Ignored };
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

  // A keypoint take waiting for finish(): its frames and the tracker's keypoints.
  struct Pending {
    std::string path, keypoint_file;
    std::int32_t subject = 0;
    std::size_t first = 0, end = 0;  // its frames
    hand::KeypointLayout layout = hand::KeypointLayout::MediaPipe;
    std::array<bool, hand::kMaxKeypoints> present{};
    KeypointTrack track;
  };

  std::vector<Column> columns_of(const std::vector<std::string>& header, const std::string& at, const KeypointColumns* keypoints) const {
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
      const bool ignored = cell_of(name) < 0 && dof_of(name) < 0 && io::column_listed(name, options_.ignored_columns);
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
      if (!column && keypoints && keypoints->is_keypoint(k)) column = Column{Role::Keypoint};
      if (!column)
        throw Error(where + ": unknown column, expected a cell of glove '" + glove_.id() + "' (e.g. '" + glove_.cell_names().front() +
                    "'), a DoF name (e.g. '" + hand::kDofs[0].name +
                    "'), a keypoint coordinate (e.g. 'index_finger_tip_x'), subject, session, glove, kind, timestamp or timestamp_ms"
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
    if (!io::next_csv_line(in, line, line_no))
      throw Error(at + ", line " + std::to_string(line_no + 1) + ": " + std::string(in.bad() ? "read error" : "no header") +
                  ", expected the column names (the glove's cells, optionally the 25 DoFs, subject, session, glove, kind, timestamp)");
    const std::size_t header_line = line_no;
    const std::vector<std::string> header = io::split_csv_line(line);
    const std::string at_header = at + ", line " + std::to_string(header_line);
    // Keypoints: columns of this take, or a file of the tracker's own.
    std::optional<KeypointColumns> keypoint_columns;
    if (const std::optional<hand::KeypointLayout> layout = keypoint_layout_of(header, at_header))
      keypoint_columns.emplace(header, *layout, options_.keypoint_scale, at_header);
    std::optional<KeypointFile> keypoint_file;
    if (!take.keypoints.empty()) {
      if (keypoint_columns)
        throw Error(at_header + ": keypoint columns and a keypoint file ('" + take.keypoints + "'), expected one of them");
      std::ifstream file(take.keypoints);
      if (!file) throw Error("keypoint file '" + take.keypoints + "': cannot open, expected a readable file");
      keypoint_file = read_keypoint_file(file, take.keypoints, options_.keypoint_scale, options_.ignored_columns);
    }
    const std::vector<Column> columns = columns_of(header, at_header, keypoint_columns ? &*keypoint_columns : nullptr);
    const auto has = [&](Role role) {
      return std::any_of(columns.begin(), columns.end(), [&](const Column& c) { return c.role == role; });
    };
    const bool keypoints = keypoint_columns || keypoint_file;
    if (keypoints && has(Role::Dof))
      throw Error(at_header + ": DoF columns and keypoints, expected the reference as angles or as keypoints, not both");
    if (!has(Role::Subject) && !take.subject)
      throw Error(at + ", line " + std::to_string(header_line) +
                  ": no 'subject' column and no subject given for the file, expected one of them");
    const bool angles = has(Role::Dof) || keypoints;
    hand::DofSet labelled{};
    for (const Column& column : columns)
      if (column.role == Role::Dof) labelled[static_cast<std::size_t>(column.index)] = true;
    Pending pending;
    if (keypoints) {
      pending.path = take.path;
      pending.keypoint_file = take.keypoints;
      pending.layout = keypoint_file ? keypoint_file->layout : keypoint_columns->layout();
      pending.present = keypoint_file ? keypoint_file->present : keypoint_columns->present();
      if (keypoint_file) pending.track = std::move(keypoint_file->track);
      labelled = labelled_by(hand::KeypointModel(pending.layout, hand::Kinematics()), pending.present);
      if (labelled == hand::DofSet{})
        throw Error(at_header + ": keypoints that complete no digit, expected every keypoint of at least one digit");
    }
    // A calibration take may be sensors only (its frames' angles NaN) beside labelled takes.
    const bool calibration_take = take.kind && *take.kind == io::kKindCalibration && !has(Role::Kind);
    const bool only_calibration_before =
        std::all_of(data_.kind.begin(), data_.kind.end(), [](std::uint8_t k) { return k == io::kKindCalibration; });
    if (data_.frames() > 0 && angles != data_.has_angles() && !(angles ? only_calibration_before : calibration_take))
      throw Error(at + ", line " + std::to_string(header_line) + ": " + std::string(angles ? "has" : "has no") + " DoF columns, expected " +
                  (data_.has_angles() ? "the DoFs" : "none") +
                  " as the recording takes before it (a calibration take, given with --calibration or kind calibration, may be "
                  "sensors only; recording takes all carry the reference or none do)");
    if (angles && data_.has_angles() && labelled != data_.labelled_dofs())
      throw Error(at + ", line " + std::to_string(header_line) + ": DoF columns " + hand::dof_set_text(labelled) +
                  ", expected the DoFs of the takes before it (" + hand::dof_set_text(data_.labelled_dofs()) + ")");
    if (angles && !data_.has_angles()) {
      data_.angles.assign(data_.frames() * hand::kDofCount, NAN);  // sensors-only calibration takes before it
      data_.set_labelled_dofs(labelled);
    }
    const double deg = options_.degrees ? core::kRadiansPerDegree : 1.0;
    const std::size_t first_frame = data_.frames();
    std::vector<std::size_t> line_of;  // file line of each frame of this take
    std::vector<float> cells(static_cast<std::size_t>(glove_.cell_count()));
    std::vector<float> pose(angles || data_.has_angles() ? hand::kDofCount : 0);  // NaN in a sensors-only calibration take
    while (io::next_csv_line(in, line, line_no)) {
      const std::vector<std::string> fields = io::split_csv_line(line);
      const std::string at_line = at + ", line " + std::to_string(line_no);
      if (fields.size() != columns.size())
        throw Error(at_line + ": " + std::to_string(fields.size()) + " fields, expected " + std::to_string(columns.size()) +
                    " (one per column of line " + std::to_string(header_line) + ")");
      std::int32_t subject = take.subject.value_or(0), session = take.session.value_or(0), glove = 0;
      std::uint8_t kind = take.kind.value_or(io::kKindRecording);
      std::optional<double> time;
      std::fill(pose.begin(), pose.end(), NAN);
      if (keypoint_columns) keypoint_columns->read_row(fields, header, at_line, pending.track.points);
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
          case Role::Keypoint:
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
    if (has(Role::Seconds) || has(Role::Milliseconds)) check_rate(first_frame, take.path);
    if (keypoints) {
      pending.subject = data_.subject[first_frame];
      for (std::size_t i = first_frame; i < data_.frames(); ++i)
        if (data_.subject[i] != pending.subject)
          throw Error(at + ", line " + std::to_string(line_of[i - first_frame]) + ": subject " + std::to_string(data_.subject[i]) +
                      " in a take with keypoints of subject " + std::to_string(pending.subject) +
                      ", expected one person per keypoint take (their hand is fitted to them)");
      pending.first = first_frame;
      pending.end = data_.frames();
      if (keypoint_columns) pending.track.times.assign(data_.timestamps.begin() + static_cast<std::ptrdiff_t>(first_frame), data_.timestamps.end());
      pending_.push_back(std::move(pending));
    }
  }

  // A take whose timestamps' median spacing disagrees with the frame rate by more than 10%.
  void check_rate(std::size_t first, const std::string& path) {
    std::vector<double> spacing;
    for (std::size_t i = first + 1; i < data_.frames(); ++i)
      if (data_.same_run(i - 1, i)) spacing.push_back(data_.timestamps[i] - data_.timestamps[i - 1]);
    if (spacing.size() < 2) return;
    const double rate = 1.0 / core::percentile(spacing, 0.5);
    if (std::abs(rate - data_.frame_rate()) > 0.1 * data_.frame_rate())
      warnings_.push_back("CSV file '" + path + "': its timestamps are " + io::number_text(std::round(rate * 100.0) / 100.0) + " frames per second, the dataset's rate is " +
                          io::number_text(data_.frame_rate()) + " (the glove description's rate_hz or --rate): one of them is wrong");
  }

  // Labels of one keypoint take from the subject's fitted hand; untrusted frames become outliers.
  void label(const Pending& take, const hand::KeypointIk& ik) {
    const std::size_t C = data_.cell_count, D = hand::kDofCount;
    const hand::DofSet labelled = labelled_by(ik.model(), take.present);
    const std::vector<double> times(data_.timestamps.begin() + static_cast<std::ptrdiff_t>(take.first),
                                    data_.timestamps.begin() + static_cast<std::ptrdiff_t>(take.end));
    const std::vector<double> cells(data_.cells.begin() + static_cast<std::ptrdiff_t>(take.first * C),
                                    data_.cells.begin() + static_cast<std::ptrdiff_t>(take.end * C));
    TakeLabels labels;
    try {
      KeypointLabelConfig config = options_.keypoint_labels;
      if (take.keypoint_file.empty() && !config.offset) config.offset = 0.0;  // keypoints in the take's own rows: one clock, no search
      labels = label_take(ik, take.track, labelled, times, cells, C, config);
    } catch (const Error& e) {
      throw Error("keypoints of '" + take.path + "'" + (take.keypoint_file.empty() ? "" : " ('" + take.keypoint_file + "')") + ": " + e.what());
    }
    KeypointTakeReport report;
    report.path = take.path;
    report.keypoint_file = take.keypoint_file;
    report.subject = take.subject;
    report.layout = take.layout;
    report.clock = labels.clock;
    std::vector<double> residuals;
    for (double r : labels.rms_mm)
      if (std::isfinite(r)) residuals.push_back(r);
    report.median_rms_mm = core::percentile(residuals, 0.5);
    report.p95_rms_mm = core::percentile(residuals, 0.95);
    report.frames = take.end - take.first;
    report.first_frame = take.first;
    report.frame_rms_mm = labels.frame_rms_mm;
    const hand::Angles rest = hand::JointLimits().rest();
    for (std::size_t i = 0; i < report.frames; ++i) {
      const std::size_t frame = take.first + i;
      report.labelled += labels.trusted[i];
      data_.outlier[frame] = labels.trusted[i] ? 0 : 1;
      for (std::size_t d = 0; d < D; ++d)
        data_.angles[frame * D + d] = !labelled[d] ? NAN : labels.trusted[i] ? labels.angles[i * D + d] : static_cast<float>(rest[d]);
    }
    // Labels pinned at a joint limit: the IK could not follow the keypoints (another hand, layout or unit).
    const hand::JointLimits limits;
    for (std::size_t d = 0; d < D; ++d) {
      std::size_t pinned = 0;
      for (std::size_t i = 0; i < report.frames; ++i) {
        const double a = data_.angles[(take.first + i) * D + d];
        pinned += labels.trusted[i] && std::min(a - limits.min()[d], limits.max()[d] - a) < kPinnedRange * (limits.max()[d] - limits.min()[d]);
      }
      report.at_limit[d] = labelled[d] && report.labelled > 0 ? static_cast<double>(pinned) / static_cast<double>(report.labelled) : NAN;
      if (report.at_limit[d] > kPinnedShare)
        warnings_.push_back("labels of '" + take.path + "': " + hand::kDofs[d].name + " at a joint limit in " +
                            io::number_text(std::round(report.at_limit[d] * 100.0)) +
                            "% of the labelled frames: are the keypoints of this hand, layout and unit?");
    }
    if (report.labelled == 0)
      throw Error("keypoints of '" + take.path + "'" + (take.keypoint_file.empty() ? "" : " ('" + take.keypoint_file + "')") + ": no frame with a trusted fit (median residual " + io::number_text(report.median_rms_mm) +
                  " mm; every keypoint of the labelled digits seen?), expected a take the tracker followed");
    keypoint_takes_.push_back(std::move(report));
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
  std::vector<Pending> pending_;
  std::vector<KeypointTakeReport> keypoint_takes_;
  std::vector<KeypointSubjectReport> keypoint_subjects_;
  std::vector<std::string> warnings_;
};

}  // namespace glovepose::train
