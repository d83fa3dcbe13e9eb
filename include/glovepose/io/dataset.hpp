/// @file dataset.hpp
/// @brief A glove recording as training / evaluation data: per frame the solved cell capacitances,
/// optionally the raw compound capacitances, the reference joint angles (the labels a hand tracker
/// reported; for simulated data also the true angles behind them) and the ids of who wore
/// which glove when. Stored in the container of io/tensor_file.hpp (weights_format.md, "Dataset
/// files") and imported from / exported to CSV. Set-up code: errors are glovepose::Error naming the
/// tensor, frame or CSV line and what was expected.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <istream>
#include <map>
#include <ostream>
#include <string>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

#include "../config.hpp"
#include "../hand/dofs.hpp"
#include "atomic_file.hpp"
#include "csv_fields.hpp"
#include "number_text.hpp"
#include "tensor_file.hpp"

namespace glovepose::io {

/// @brief Metadata "format" of a dataset file.
inline constexpr const char* kDatasetFormat = "glovepose-dataset";
/// @brief Metadata "version" of a dataset file this code reads and writes.
inline constexpr const char* kDatasetVersion = "1";
/// @brief Value of `kind` for a frame of a recording.
inline constexpr std::uint8_t kKindRecording = 0;
/// @brief Value of `kind` for a frame of a calibration sequence.
inline constexpr std::uint8_t kKindCalibration = 1;
/// @brief Value of `kind` for a frame of the glove being taken off, lying off the hand and put on
/// again (sim::RemovalConfig): cells only, no pose (its angles and true angles are NaN).
inline constexpr std::uint8_t kKindRemoval = 2;

/// @brief The readout's clock: a frame's R raw rows fill one readout cycle of 1 / frame_rate seconds
/// that ends at the frame's timestamp, row r completing at the end of its slot (sim/recorder.hpp
/// records so). The one home of a raw row's time; Dataset::row_clock() gives a dataset's.
struct RowClock {
  std::size_t rows = 0;     ///< R, raw rows per frame (readout cycle).
  double frame_rate = 0.0;  ///< Frames (readout cycles) per second.

  /// @brief When row `row` of the cycle that ends at `frame_end` was read: R - 1 - row row slots
  /// before the cycle's end.
  double time(double frame_end, std::size_t row) const noexcept {
    return frame_end - static_cast<double>(rows - 1 - row) / (static_cast<double>(rows) * frame_rate);
  }
};

/// @brief N frames of glove recordings, one row per frame in every array (row-major).
///
/// A frame is what the readout delivers when a solve ends: the cell capacitances solved from the
/// compound capacitances of that readout cycle, and (for training data) the reference pose.
struct Dataset {
  std::size_t cell_count = 0;   ///< C, cells per frame (44 for the paper's glove).
  std::size_t row_count = 0;    ///< R, raw readout rows per frame (180 for the paper's glove); 0: no raw rows.
  std::vector<float> cells;     ///< N x C solved cell capacitances C_c, pF; finite.
  std::vector<float> raw_rows;  ///< N x R compound capacitances C_m of the cycle that ended at the frame, pF; NaN = dropped row. Empty when
                                ///< row_count is 0.
  std::vector<float> angles;    ///< N x 25 reference joint angles (the labels trained on and scored against), radians, order hand::kDofs
                                ///< (theta 9..33); NaN for a DoF not labelled (labelled_dofs()); empty: no reference.
  std::vector<float> true_angles;  ///< N x 25 true joint angles behind the labels, radians, all finite; only simulated data has them (the
                                   ///< labels are a simulated tracker's); empty: unknown.
  std::vector<double> timestamps;     ///< N times, seconds since the session start; strictly increasing within a run (see validate()).
  std::vector<std::int32_t> subject;  ///< N subject ids (>= 0).
  std::vector<std::int32_t> session;  ///< N session ids of the subject (>= 0).
  std::vector<std::int32_t> glove;    ///< N glove ids (>= 0): which physical glove.
  std::vector<std::int32_t>
      donning;                     ///< N donning ids (>= 0): the how-many-th time the subject put the glove on; sessions kept on share it.
  std::vector<std::uint8_t> kind;  ///< N kinds: kKindRecording (0), kKindCalibration (1) or kKindRemoval (2).
  std::vector<std::uint8_t>
      outlier;  ///< N flags: 1 when the reference pose's collision energy exceeds hand::kCollisionOutlierThreshold (80), else 0.
  /// @brief String metadata: "format" (kDatasetFormat), "version" (kDatasetVersion), "glove_layout"
  /// (the sensor layout id, e.g. "glauser2019-44"), "frame_rate" (nominal frames per second),
  /// optionally "labelled_dofs" (the DoFs with reference angles, hand::dof_set_text(); absent: all);
  /// other keys are kept.
  std::map<std::string, std::string> metadata{{"format", kDatasetFormat}, {"version", kDatasetVersion}};

  /// @brief An empty dataset: no frames, no cells; set the counts and metadata before use.
  Dataset() = default;

  /// @brief An empty dataset for a glove with `cells` cells and `rows` raw rows (0: no raw rows).
  Dataset(std::size_t cells, std::size_t rows, const std::string& glove_layout, double frame_rate) : cell_count(cells), row_count(rows) {
    metadata["glove_layout"] = glove_layout;
    metadata["frame_rate"] = io::number_text(frame_rate);
  }

  /// @brief Number of frames N.
  std::size_t frames() const noexcept { return timestamps.size(); }
  /// @brief Whether the frames carry ground-truth angles.
  bool has_angles() const noexcept { return !angles.empty(); }
  /// @brief Whether the frames carry the true angles behind their labels (simulated data).
  bool has_true_angles() const noexcept { return !true_angles.empty(); }
  /// @brief Whether the frames carry raw readout rows.
  bool has_raw_rows() const noexcept { return row_count > 0; }

  /// @brief Metadata "glove_layout"; throws glovepose::Error when it is missing.
  const std::string& glove_layout() const { return meta("glove_layout"); }
  /// @brief Metadata "frame_rate" as a number; throws glovepose::Error unless it is a positive finite number.
  double frame_rate() const {
    const std::string& text = meta("frame_rate");
    double v = 0.0;
    const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
    if (r.ec != std::errc() || r.ptr != text.data() + text.size() || !std::isfinite(v) || v <= 0.0)
      throw Error("Dataset: metadata 'frame_rate' is '" + text + "', expected a positive number (frames per second)");
    return v;
  }

  /// @brief The clock of the raw rows: row_count rows per frame at frame_rate(). Throws like frame_rate().
  RowClock row_clock() const { return {row_count, frame_rate()}; }
  /// @brief When raw row `row` of frame `frame` was read (RowClock::time). Reads the metadata at
  /// each call: in a loop over rows, take row_clock() once.
  double row_time(std::size_t frame, std::size_t row) const { return row_clock().time(timestamps[frame], row); }
  /// @brief The first frame after the calibration frames (kind kKindCalibration) the dataset starts
  /// with: where a simulated user's session begins after their calibration sequence; 0 when it
  /// starts with none, frames() when every frame is calibration.
  std::size_t first_session_frame() const noexcept {
    std::size_t f = 0;
    while (f < kind.size() && kind[f] == kKindCalibration) ++f;
    return f;
  }

  /// @brief The DoFs with reference angles: metadata "labelled_dofs", every DoF when it is absent.
  /// Throws glovepose::Error when the metadata does not name a set of DoFs.
  hand::DofSet labelled_dofs() const {
    const auto it = metadata.find("labelled_dofs");
    return it == metadata.end() ? hand::all_dofs() : hand::parse_dof_set(it->second, "Dataset: metadata 'labelled_dofs'");
  }

  /// @brief Records which DoFs have reference angles (all of them: the metadata key is removed).
  void set_labelled_dofs(const hand::DofSet& labelled) {
    if (labelled == hand::all_dofs())
      metadata.erase("labelled_dofs");
    else
      metadata["labelled_dofs"] = hand::dof_set_text(labelled);
  }

  /// @brief Checks every size, value range and the metadata; throws glovepose::Error naming the
  /// tensor (and frame) that is wrong and what was expected. Timestamps must increase strictly
  /// within each run of consecutive frames sharing (subject, glove, session, kind).
  void validate() const {
    if (meta("format") != kDatasetFormat)
      throw Error("Dataset: metadata 'format' is '" + meta("format") + "', expected '" + kDatasetFormat + "'");
    if (meta("version") != kDatasetVersion)
      throw Error("Dataset: metadata 'version' is '" + meta("version") + "', expected '" + kDatasetVersion + "'");
    if (glove_layout().empty()) throw Error("Dataset: metadata 'glove_layout' is empty, expected a sensor layout id");
    frame_rate();
    if (cell_count == 0) throw Error("Dataset: cell_count is 0, expected at least 1 cell per frame");
    const std::size_t n = frames();
    check_count("cells", cells.size(), n, cell_count, "cell_count");
    check_count("raw_rows", raw_rows.size(), n, row_count, "row_count");
    if (has_angles()) check_count("angles", angles.size(), n, hand::kDofCount, "25 DoFs");
    check_count("subject", subject.size(), n, 1, "");
    check_count("session", session.size(), n, 1, "");
    check_count("glove", glove.size(), n, 1, "");
    check_count("donning", donning.size(), n, 1, "");
    check_count("kind", kind.size(), n, 1, "");
    check_count("outlier", outlier.size(), n, 1, "");
    for (std::size_t i = 0; i < n; ++i)
      if (kind[i] > kKindRemoval)
        throw Error("Dataset: tensor 'kind': frame " + std::to_string(i) + " is " + std::to_string(kind[i]) +
                    ", expected 0 (recording), 1 (calibration) or 2 (removal)");
    if (has_true_angles()) {
      if (!has_angles()) throw Error("Dataset: tensor 'true_angles' without 'angles', expected the labels beside the true angles");
      check_count("true_angles", true_angles.size(), n, hand::kDofCount, "25 DoFs");
      for (std::size_t i = 0; i < true_angles.size(); ++i) {
        const bool removal = kind[i / hand::kDofCount] == kKindRemoval;
        if (removal ? !std::isnan(true_angles[i]) : !std::isfinite(true_angles[i]))
          throw Error("Dataset: tensor 'true_angles': frame " + std::to_string(i / hand::kDofCount) + ", DoF '" +
                      hand::kDofs[i % hand::kDofCount].name + "' is " + io::number_text(true_angles[i]) +
                      (removal ? ", expected NaN (a removal frame has no pose)" : ", expected a finite angle (radians)"));
      }
    }
    for (std::size_t i = 0; i < cells.size(); ++i)
      if (!std::isfinite(cells[i]))
        throw Error("Dataset: tensor 'cells': frame " + std::to_string(i / cell_count) + ", cell " + std::to_string(i % cell_count) +
                    " is " + io::number_text(cells[i]) + ", expected a finite capacitance (pF)");
    for (std::size_t i = 0; i < raw_rows.size(); ++i)
      if (std::isinf(raw_rows[i]))
        throw Error("Dataset: tensor 'raw_rows': frame " + std::to_string(i / row_count) + ", row " + std::to_string(i % row_count) +
                    " is infinite, expected a finite capacitance (pF) or NaN (a dropped row)");
    const hand::DofSet labelled = labelled_dofs();
    for (std::size_t i = 0; i < angles.size(); ++i) {
      const bool has = labelled[i % hand::kDofCount];
      const std::size_t frame = i / hand::kDofCount;
      if (has && std::isnan(angles[i]) && kind[frame] == kKindCalibration) continue;  // a sensors-only calibration
      if (kind[frame] == kKindRemoval) {
        if (!std::isnan(angles[i]))
          throw Error("Dataset: tensor 'angles': frame " + std::to_string(frame) + ", DoF '" + hand::kDofs[i % hand::kDofCount].name +
                      "' is " + io::number_text(angles[i]) + ", expected NaN (a removal frame has no pose)");
        continue;
      }
      if (has ? !std::isfinite(angles[i]) : !std::isnan(angles[i]))
        throw Error("Dataset: tensor 'angles': frame " + std::to_string(i / hand::kDofCount) + ", DoF '" +
                    hand::kDofs[i % hand::kDofCount].name + "' is " + io::number_text(angles[i]) +
                    (has ? ", expected a finite angle (radians)" : ", expected NaN (the DoF is not labelled: metadata 'labelled_dofs')"));
    }
    const std::pair<const char*, const std::vector<std::int32_t>*> ids[] = {
        {"subject", &subject}, {"session", &session}, {"glove", &glove}, {"donning", &donning}};
    for (const auto& [name, values] : ids)
      for (std::size_t i = 0; i < n; ++i)
        if ((*values)[i] < 0)
          throw Error(std::string("Dataset: tensor '") + name + "': frame " + std::to_string(i) + " is " + std::to_string((*values)[i]) +
                      ", expected an id >= 0");
    for (std::size_t i = 0; i < n; ++i) {
      if (outlier[i] > 1)
        throw Error("Dataset: tensor 'outlier': frame " + std::to_string(i) + " is " + std::to_string(outlier[i]) + ", expected 0 or 1");
      if (!std::isfinite(timestamps[i]))
        throw Error("Dataset: tensor 'timestamps': frame " + std::to_string(i) + " is " + io::number_text(timestamps[i]) +
                    ", expected finite seconds");
      if (i > 0 && same_run(i - 1, i) && !(timestamps[i] > timestamps[i - 1]))
        throw Error("Dataset: tensor 'timestamps': frame " + std::to_string(i) + " is " + io::number_text(timestamps[i]) +
                    " s, not after frame " + std::to_string(i - 1) + " (" + io::number_text(timestamps[i - 1]) +
                    " s) of the same run (subject " + std::to_string(subject[i]) + ", glove " + std::to_string(glove[i]) + ", session " +
                    std::to_string(session[i]) + ", kind " + std::to_string(kind[i]) + "), expected strictly increasing times");
    }
  }

  /// @brief Appends the frames of `other`. Both must agree on cell_count, row_count, glove_layout,
  /// frame_rate and on having angles (unless one side has no frames); a dataset with no frames and
  /// no cells takes everything from `other`. Throws glovepose::Error naming the disagreement.
  void append(const Dataset& other) {
    if (frames() == 0 && cell_count == 0) {
      *this = other;
      return;
    }
    const auto disagree = [](const std::string& what, const std::string& mine, const std::string& theirs) {
      return Error("Dataset::append: the appended dataset has " + what + " " + theirs + ", expected " + mine + " as this one");
    };
    if (other.cell_count != cell_count) throw disagree("cell_count", std::to_string(cell_count), std::to_string(other.cell_count));
    if (other.row_count != row_count) throw disagree("row_count", std::to_string(row_count), std::to_string(other.row_count));
    for (const char* key : {"glove_layout", "frame_rate", "labelled_dofs"}) {
      const auto quoted = [key](const Dataset& d) {
        const auto it = d.metadata.find(key);
        return it == d.metadata.end() ? std::string("(none)") : "'" + it->second + "'";
      };
      const std::string a = quoted(*this), b = quoted(other);
      if (a != b) throw disagree(std::string("metadata '") + key + "'", a, b);
    }
    if (frames() > 0 && other.frames() > 0 && has_angles() != other.has_angles())
      throw disagree("angles", has_angles() ? "present" : "absent", other.has_angles() ? "present" : "absent");
    if (frames() > 0 && other.frames() > 0 && has_true_angles() != other.has_true_angles())
      throw disagree("true_angles", has_true_angles() ? "present" : "absent", other.has_true_angles() ? "present" : "absent");
    append_range(other, 0, other.frames());
  }

  /// @brief The frames i for which keep(i) is true, in order, with this dataset's counts and metadata.
  template <typename Keep>
  Dataset select(Keep&& keep) const {
    Dataset out = empty_like();
    const std::size_t n = frames();
    for (std::size_t begin = 0; begin < n;) {
      if (!keep(begin)) {
        ++begin;
        continue;
      }
      std::size_t end = begin + 1;
      while (end < n && keep(end)) ++end;
      out.append_range(*this, begin, end);
      begin = end;
    }
    return out;
  }

  /// @brief The container of this dataset (validated first): tensors "cells", "raw_rows" (when
  /// row_count > 0), "angles" and "true_angles" (when present), "timestamps", "subject", "session", "glove", "donning",
  /// "kind", "outlier" and the metadata.
  io::TensorFile to_tensor_file() const {
    validate();
    const auto n = static_cast<std::int64_t>(frames());
    io::TensorFile file;
    file.metadata = metadata;
    file.tensors["cells"] = io::RawTensor::from({n, static_cast<std::int64_t>(cell_count)}, cells);
    if (has_raw_rows()) file.tensors["raw_rows"] = io::RawTensor::from({n, static_cast<std::int64_t>(row_count)}, raw_rows);
    if (has_angles()) file.tensors["angles"] = io::RawTensor::from({n, static_cast<std::int64_t>(hand::kDofCount)}, angles);
    if (has_true_angles())
      file.tensors["true_angles"] = io::RawTensor::from({n, static_cast<std::int64_t>(hand::kDofCount)}, true_angles);
    file.tensors["timestamps"] = io::RawTensor::from({n}, timestamps);
    file.tensors["subject"] = io::RawTensor::from({n}, subject);
    file.tensors["session"] = io::RawTensor::from({n}, session);
    file.tensors["glove"] = io::RawTensor::from({n}, glove);
    file.tensors["donning"] = io::RawTensor::from({n}, donning);
    file.tensors["kind"] = io::RawTensor::from({n}, kind);
    file.tensors["outlier"] = io::RawTensor::from({n}, outlier);
    return file;
  }

  /// @brief The dataset in a container; throws glovepose::Error for a wrong format or version, an
  /// unknown or missing tensor, a wrong dtype or shape, or contents validate() refuses.
  static Dataset from_tensor_file(io::TensorFile file) {
    Dataset out;
    out.metadata = std::move(file.metadata);
    for (const char* key : {"format", "version"})
      if (out.metadata.find(key) == out.metadata.end())
        throw Error(std::string("metadata '") + key + "' is missing, expected '" +
                    (std::string(key) == "format" ? kDatasetFormat : kDatasetVersion) + "'");
    if (out.meta("format") != kDatasetFormat)
      throw Error("metadata 'format' is '" + out.meta("format") + "', expected '" + kDatasetFormat + "'");
    if (out.meta("version") != kDatasetVersion)
      throw Error("metadata 'version' is '" + out.meta("version") + "', expected '" + kDatasetVersion + "'");
    for (const auto& entry : file.tensors) {
      bool known = false;
      for (const char* name : kTensorNames) known = known || entry.first == name;
      if (!known)
        throw Error("unknown tensor '" + entry.first +
                    "', expected only cells, raw_rows, angles, true_angles, timestamps, subject, session, glove, donning, kind, outlier");
    }
    const io::RawTensor& times = tensor(file, "timestamps", io::DType::F64, "[N]");
    if (times.shape.size() != 1) throw Error("tensor 'timestamps' has shape " + io::shape_string(times.shape) + ", expected [N] (frames)");
    const std::int64_t n = times.shape[0];
    out.timestamps = take<double>(file, "timestamps", io::DType::F64, {n}, "frames");
    out.cell_count = width(file, "cells", n);
    out.cells = take<float>(file, "cells", io::DType::F32, {n, static_cast<std::int64_t>(out.cell_count)}, "frames x cells");
    if (file.tensors.count("raw_rows")) {
      out.row_count = width(file, "raw_rows", n);
      out.raw_rows = take<float>(file, "raw_rows", io::DType::F32, {n, static_cast<std::int64_t>(out.row_count)}, "frames x rows");
    }
    if (file.tensors.count("angles"))
      out.angles = take<float>(file, "angles", io::DType::F32, {n, static_cast<std::int64_t>(hand::kDofCount)}, "frames x 25 DoFs");
    if (file.tensors.count("true_angles"))
      out.true_angles = take<float>(file, "true_angles", io::DType::F32, {n, static_cast<std::int64_t>(hand::kDofCount)}, "frames x 25 DoFs");
    out.subject = take<std::int32_t>(file, "subject", io::DType::I32, {n}, "frames");
    out.session = take<std::int32_t>(file, "session", io::DType::I32, {n}, "frames");
    out.glove = take<std::int32_t>(file, "glove", io::DType::I32, {n}, "frames");
    out.donning = take<std::int32_t>(file, "donning", io::DType::I32, {n}, "frames");
    out.kind = take<std::uint8_t>(file, "kind", io::DType::U8, {n}, "frames");
    out.outlier = take<std::uint8_t>(file, "outlier", io::DType::U8, {n}, "frames");
    out.validate();
    return out;
  }

  /// @brief Writes the dataset file (validated first). Throws glovepose::Error if it cannot.
  void write(const std::string& path) const { to_tensor_file().write(path, "dataset file"); }

  /// @brief Reads and checks a dataset file; messages start with "dataset file '<path>': ".
  static Dataset read(const std::string& path) { return io::TensorFile::read_as(path, "dataset file", from_tensor_file); }

  /// @brief Writes the frames as CSV (validated first): the header
  /// `subject,session,timestamp,cell_0,...,cell_{C-1}` followed by the labelled DoFs' names (all 25
  /// unless labelled_dofs() says otherwise), in hand::kDofs order, when the dataset has angles, then one line per frame; cells and angles
  /// with 9 significant digits, timestamps with 17 (exact round trip), independent of the locale. glove, donning, kind, outlier, raw_rows,
  /// true_angles and the metadata are not part of the CSV.
  void write_csv(std::ostream& out) const {
    validate();
    const hand::DofSet labelled = labelled_dofs();
    std::string line = "subject,session,timestamp";
    for (std::size_t c = 0; c < cell_count; ++c) line += ",cell_" + std::to_string(c);
    if (has_angles())
      for (std::size_t d = 0; d < hand::kDofCount; ++d)
        if (labelled[d]) line += std::string(",") + hand::kDofs[d].name;
    out << line << '\n';
    char buf[64];
    const auto put = [&](auto v, int digits) {
      const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, digits);
      line += ',';
      line.append(buf, r.ptr);
    };
    for (std::size_t i = 0; i < frames(); ++i) {
      line = std::to_string(subject[i]) + "," + std::to_string(session[i]);
      put(timestamps[i], 17);
      for (std::size_t c = 0; c < cell_count; ++c) put(cells[i * cell_count + c], 9);
      if (has_angles())
        for (std::size_t d = 0; d < hand::kDofCount; ++d)
          if (labelled[d]) put(angles[i * hand::kDofCount + d], 9);
      out << line << '\n';
    }
    if (!out) throw Error("Dataset::write_csv: cannot write");
  }

  /// @brief Writes the frames as a CSV file (see write_csv(std::ostream&)), whole or not at all.
  void write_csv(const std::string& path) const {
    AtomicFile file(path, "CSV file");
    write_csv(file.stream());
    file.commit();
  }

  /// @brief Reads CSV in the layout of write_csv(): the cell count comes from the header, angles
  /// when the header lists DoF names (in hand::kDofs order; those missing are not labelled); glove = 0, donning = session, kind = 0,
  /// outlier = 0; `glove_layout` and `frame_rate` become the metadata (CSV does not carry them). Throws glovepose::Error naming the line
  /// (and column): unknown header, wrong column count, a value that is not a number (or not a finite one, or a non-negative integer for
  /// subject and session), a timestamp not after the one of the line before when both lines have the same subject and session (validate()'s
  /// run rule, with glove and kind unknown).
  static Dataset read_csv(std::istream& in, const std::string& glove_layout, double frame_rate) {
    std::string line;
    std::size_t line_no = 1;
    if (!std::getline(in, line))
      throw Error("line 1: no header, expected subject,session,timestamp,cell_0,...,cell_{C-1} and optionally DoF names");
    const std::vector<std::string> header = io::split_csv_line(line);
    const auto expected_header = [&](std::size_t column, const std::string& expected) {
      return Error("line 1, column " + std::to_string(column + 1) + ": unknown column '" + header[column] + "', expected " + expected +
                   " (the header is subject,session,timestamp,cell_0,...,cell_{C-1} and optionally DoF names in the order of hand::kDofs)");
    };
    const char* fixed[] = {"subject", "session", "timestamp"};
    for (std::size_t k = 0; k < 3; ++k) {
      if (k >= header.size())
        throw Error("line 1: " + std::to_string(header.size()) + " columns, expected subject,session,timestamp,cell_0,... (at least 4)");
      if (header[k] != fixed[k]) throw expected_header(k, std::string("'") + fixed[k] + "'");
    }
    std::size_t cells = 0;
    while (3 + cells < header.size() && header[3 + cells] == "cell_" + std::to_string(cells)) ++cells;
    if (cells == 0) {
      if (header.size() == 3) throw Error("line 1: 3 columns, expected subject,session,timestamp,cell_0,... (at least 4)");
      throw expected_header(3, "'cell_0'");
    }
    const std::size_t dofs = header.size() - 3 - cells;
    std::vector<std::size_t> dof_of_column;  // the DoF of each angle column: a subsequence of hand::kDofs
    hand::DofSet labelled{};
    for (std::size_t k = 0; k < dofs; ++k) {
      const std::size_t column = 3 + cells + k;
      std::size_t d = dof_of_column.empty() ? 0 : dof_of_column.back() + 1;
      while (d < hand::kDofCount && header[column] != hand::kDofs[d].name) ++d;
      if (d == hand::kDofCount)
        throw expected_header(column, k == 0 ? "'cell_" + std::to_string(cells) + "' or a DoF name"
                                             : std::string("a DoF after '") + hand::kDofs[dof_of_column.back()].name +
                                                   "' (the DoFs in the order of hand::kDofs)");
      dof_of_column.push_back(d);
      labelled[d] = true;
    }

    Dataset out(cells, 0, glove_layout, frame_rate);
    if (dofs > 0) out.set_labelled_dofs(labelled);
    std::vector<float> pose(dofs > 0 ? hand::kDofCount : 0);
    while (std::getline(in, line)) {
      ++line_no;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.find_first_not_of(" \t") == std::string::npos) continue;
      const std::vector<std::string> fields = io::split_csv_line(line);
      if (fields.size() != header.size())
        throw Error("line " + std::to_string(line_no) + ": " + std::to_string(fields.size()) + " columns, expected " +
                    std::to_string(header.size()));
      const auto where = [&](std::size_t k) {
        return "line " + std::to_string(line_no) + ", column '" + header[k] + "': '" + fields[k] + "'";
      };
      const std::int32_t subject = io::parse_csv_id(fields[0], where(0));
      const std::int32_t session = io::parse_csv_id(fields[1], where(1));
      const double time = io::parse_csv_number<double>(fields[2], where(2));
      // The run rule of validate() as far as CSV can tell: rows of one (subject, session) in a row.
      const std::size_t n = out.frames();
      if (n > 0 && out.subject[n - 1] == subject && out.session[n - 1] == session && !(time > out.timestamps[n - 1]))
        throw Error("line " + std::to_string(line_no) + ": timestamp " + io::number_text(time) + " is not after the previous " +
                    io::number_text(out.timestamps[n - 1]) + " of subject " + std::to_string(subject) + " session " +
                    std::to_string(session));
      for (std::size_t c = 0; c < cells; ++c) out.cells.push_back(io::parse_csv_number<float>(fields[3 + c], where(3 + c)));
      std::fill(pose.begin(), pose.end(), NAN);
      for (std::size_t k = 0; k < dofs; ++k)
        pose[dof_of_column[k]] = io::parse_csv_number<float>(fields[3 + cells + k], where(3 + cells + k));
      out.angles.insert(out.angles.end(), pose.begin(), pose.end());
      out.timestamps.push_back(time);
      out.subject.push_back(subject);
      out.session.push_back(session);
      out.glove.push_back(0);
      out.donning.push_back(session);
      out.kind.push_back(kKindRecording);
      out.outlier.push_back(0);
    }
    if (in.bad()) throw Error("line " + std::to_string(line_no + 1) + ": read error");
    if (!out.has_angles()) out.set_labelled_dofs(hand::all_dofs());  // no frames, no angles: nothing is labelled or not
    out.validate();
    return out;
  }

  /// @brief Reads a CSV file (see read_csv(std::istream&, ...)); messages start with "CSV file '<path>': ".
  static Dataset read_csv(const std::string& path, const std::string& glove_layout, double frame_rate) {
    std::ifstream file(path);
    if (!file) throw Error("CSV file '" + path + "': cannot open");
    try {
      return read_csv(file, glove_layout, frame_rate);
    } catch (const Error& e) {
      throw Error("CSV file '" + path + "': " + e.what());
    }
  }

  /// @brief Whether frames a and b share (subject, glove, session, kind): the same run (validate()).
  bool same_run(std::size_t a, std::size_t b) const noexcept {
    return subject[a] == subject[b] && glove[a] == glove[b] && session[a] == session[b] && kind[a] == kind[b];
  }

 private:
  static constexpr const char* kTensorNames[] = {"cells",   "raw_rows", "angles",  "true_angles", "timestamps", "subject",
                                                 "session", "glove",    "donning", "kind",        "outlier"};

  const std::string& meta(const std::string& key) const {
    const auto it = metadata.find(key);
    if (it == metadata.end()) throw Error("Dataset: metadata '" + key + "' is missing");
    return it->second;
  }

  void check_count(const char* name, std::size_t size, std::size_t n, std::size_t per_frame, const char* per_frame_name) const {
    if (size == n * per_frame) return;
    throw Error(std::string("Dataset: tensor '") + name + "' holds " + std::to_string(size) + " values, expected " +
                (per_frame == 1 ? "one per frame: " + std::to_string(n)
                                : std::to_string(n) + " frames x " + std::to_string(per_frame) + " (" + per_frame_name +
                                      ") = " + std::to_string(n * per_frame)));
  }

  Dataset empty_like() const {
    Dataset out;
    out.cell_count = cell_count;
    out.row_count = row_count;
    out.metadata = metadata;
    return out;
  }

  // Appends frames [begin, end) of src (same counts).
  void append_range(const Dataset& src, std::size_t begin, std::size_t end) {
    const auto rows = [&](auto& dst, const auto& from, std::size_t per_frame) {
      dst.insert(dst.end(), from.begin() + static_cast<std::ptrdiff_t>(begin * per_frame),
                 from.begin() + static_cast<std::ptrdiff_t>(end * per_frame));
    };
    rows(cells, src.cells, cell_count);
    rows(raw_rows, src.raw_rows, row_count);
    if (src.has_angles()) rows(angles, src.angles, hand::kDofCount);
    if (src.has_true_angles()) rows(true_angles, src.true_angles, hand::kDofCount);
    rows(timestamps, src.timestamps, 1);
    rows(subject, src.subject, 1);
    rows(session, src.session, 1);
    rows(glove, src.glove, 1);
    rows(donning, src.donning, 1);
    rows(kind, src.kind, 1);
    rows(outlier, src.outlier, 1);
  }

  static const io::RawTensor& tensor(const io::TensorFile& file, const char* name, io::DType dtype, const std::string& shape) {
    const auto it = file.tensors.find(name);
    if (it == file.tensors.end())
      throw Error(std::string("tensor '") + name + "' is missing, expected " + io::dtype_name(dtype) + " " + shape);
    if (it->second.dtype != dtype)
      throw Error(std::string("tensor '") + name + "' has dtype " + io::dtype_name(it->second.dtype) + ", expected " +
                  io::dtype_name(dtype));
    return it->second;
  }

  // The second dimension of the [N, C] cells or [N, R] raw rows (>= 1), with the dtype checked (F32).
  static std::size_t width(const io::TensorFile& file, const char* name, std::int64_t n) {
    const bool is_cells = std::string(name) == "cells";
    const io::RawTensor& t = tensor(file, name, io::DType::F32, is_cells ? "[N, C]" : "[N, R]");
    if (t.shape.size() != 2 || t.shape[0] != n || t.shape[1] < 1)
      throw Error(std::string("tensor '") + name + "' has shape " + io::shape_string(t.shape) + ", expected [" + std::to_string(n) +
                  (is_cells ? ", C] with C >= 1 (frames x cells)" : ", R] with R >= 1 (frames x rows)"));
    return static_cast<std::size_t>(t.shape[1]);
  }

  // The values of a tensor of the given dtype and shape; erased from the file to bound memory.
  template <typename T>
  static std::vector<T> take(io::TensorFile& file, const char* name, io::DType dtype, const std::vector<std::int64_t>& shape,
                             const char* meaning) {
    const io::RawTensor& t = tensor(file, name, dtype, io::shape_string(shape));
    if (t.shape != shape)
      throw Error(std::string("tensor '") + name + "' has shape " + io::shape_string(t.shape) + ", expected " + io::shape_string(shape) +
                  " (" + meaning + ")");
    std::vector<T> values = t.to<T>();
    file.tensors.erase(name);
    return values;
  }
};

}  // namespace glovepose::io
