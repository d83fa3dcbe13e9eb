/// @file keypoint_columns.hpp
/// @brief A hand tracker's keypoints in CSV columns: `<keypoint>_x`, `<keypoint>_y`, `<keypoint>_z`,
/// with the keypoint names of a layout (hand/keypoints.hpp: MediaPipe's landmark names such as
/// `index_finger_tip`, or OpenXR's joint names such as `index_tip`), in a stated unit. A keypoint
/// whose columns are absent is not reported (the digits it belongs to are not labelled); an empty
/// field, `nan` or `NaN` in all three of a keypoint's columns means not seen in that frame.
///
/// Read in a take beside the glove's columns (the recording software paired the rows), or from a
/// file of its own with a `timestamp` (seconds) or `timestamp_ms` column on the tracker's clock
/// (read_keypoint_file). Set-up code: errors are glovepose::Error naming the file, line and column.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <istream>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "../config.hpp"
#include "../hand/keypoints.hpp"
#include "../io/csv_fields.hpp"
#include "../io/number_text.hpp"
#include "keypoint_labels.hpp"

namespace glovepose::train {

/// @brief The keypoint and axis a column name gives in `layout` (keypoint * 3 + axis), or -1.
inline int keypoint_column(const std::string& name, hand::KeypointLayout layout) {
  if (name.size() < 3 || name[name.size() - 2] != '_') return -1;
  const char axis = name.back();
  if (axis != 'x' && axis != 'y' && axis != 'z') return -1;
  const std::string keypoint = name.substr(0, name.size() - 2);
  for (std::size_t k = 0; k < hand::keypoint_count(layout); ++k)
    if (keypoint == hand::keypoint_name(layout, k)) return static_cast<int>(3 * k) + (axis - 'x');
  return -1;
}

/// @brief The layout whose keypoints a header's columns name, or none. Names both layouts share
/// (`wrist`, `thumb_tip`) read as MediaPipe's, which places them alike. Throws glovepose::Error
/// (starting with `at`) when names of both layouts appear.
inline std::optional<hand::KeypointLayout> keypoint_layout_of(const std::vector<std::string>& header, const std::string& at) {
  std::array<int, hand::kKeypointLayoutCount> only{};  // a column of this layout's alone
  std::array<std::string, hand::kKeypointLayoutCount> example;
  bool any = false;
  for (const std::string& name : header) {
    const bool mediapipe = keypoint_column(name, hand::KeypointLayout::MediaPipe) >= 0;
    const bool openxr = keypoint_column(name, hand::KeypointLayout::OpenXr) >= 0;
    any = any || mediapipe || openxr;
    for (std::size_t l = 0; l < hand::kKeypointLayoutCount; ++l)
      if ((l == 0 ? mediapipe && !openxr : openxr && !mediapipe) && only[l]++ == 0) example[l] = name;
  }
  if (only[0] > 0 && only[1] > 0)
    throw Error(at + ": keypoint columns of two layouts ('" + example[0] + "' is MediaPipe's, '" + example[1] +
                "' OpenXR's), expected the keypoints of one tracker");
  if (!any) return std::nullopt;
  return only[1] > 0 ? hand::KeypointLayout::OpenXr : hand::KeypointLayout::MediaPipe;
}

/// @brief Reads the keypoint columns of a header's layout, row by row, into a track.
class KeypointColumns {
 public:
  /// @brief The keypoint columns of `header` in `layout`, values times `scale` (mm per unit).
  /// Throws glovepose::Error (starting with `at`) when a keypoint has one or two of its three columns.
  KeypointColumns(const std::vector<std::string>& header, hand::KeypointLayout layout, double scale, const std::string& at)
      : layout_(layout), scale_(scale), column_(header.size(), -1) {
    std::array<int, hand::kMaxKeypoints> axes{};
    std::vector<int> first(3 * hand::kMaxKeypoints, -1);  // the column of each keypoint coordinate
    for (std::size_t c = 0; c < header.size(); ++c) {
      column_[c] = keypoint_column(header[c], layout);
      if (column_[c] < 0) continue;
      int& earlier = first[static_cast<std::size_t>(column_[c])];
      if (earlier >= 0)
        throw Error(at + ", column " + std::to_string(c + 1) + " '" + header[c] + "': named like column " + std::to_string(earlier + 1) +
                    ", expected each column once");
      earlier = static_cast<int>(c);
      ++axes[static_cast<std::size_t>(column_[c] / 3)];
    }
    for (std::size_t k = 0; k < hand::keypoint_count(layout); ++k) {
      present_[k] = axes[k] == 3;
      if (axes[k] != 0 && axes[k] != 3)
        throw Error(at + ": keypoint '" + hand::keypoint_name(layout, k) + "' has " + std::to_string(axes[k]) +
                    " of its columns, expected " + hand::keypoint_name(layout, k) + "_x, _y and _z");
    }
  }

  /// @brief The layout.
  hand::KeypointLayout layout() const noexcept { return layout_; }
  /// @brief Whether column c is a keypoint's.
  bool is_keypoint(std::size_t c) const noexcept { return column_[c] >= 0; }
  /// @brief The keypoints with columns.
  const std::array<bool, hand::kMaxKeypoints>& present() const noexcept { return present_; }

  /// @brief Appends one row's keypoints (fields of the header's columns) to `points`: mm, NaN for
  /// a keypoint not seen. Throws glovepose::Error (starting with `at_line`) for a field that is not a
  /// finite number or empty/nan, and for a keypoint seen in some of its coordinates only.
  void read_row(const std::vector<std::string>& fields, const std::vector<std::string>& header, const std::string& at_line,
                std::vector<Eigen::Vector3d>& points) const {
    const std::size_t count = hand::keypoint_count(layout_);
    const std::size_t first = points.size();
    points.resize(first + count, Eigen::Vector3d::Constant(NAN));
    std::array<int, hand::kMaxKeypoints> seen{};
    for (std::size_t c = 0; c < fields.size(); ++c) {
      if (column_[c] < 0) continue;
      const std::string& text = fields[c];
      if (text.empty() || text == "nan" || text == "NaN") continue;
      const double value = io::parse_csv_number<double>(text, at_line + ", column '" + header[c] + "': '" + text + "'") * scale_;
      if (!std::isfinite(value))
        throw Error(at_line + ", column '" + header[c] + "': '" + text + "' is out of range in millimetres, expected a coordinate");
      const auto k = static_cast<std::size_t>(column_[c] / 3);
      points[first + k][column_[c] % 3] = value;
      ++seen[k];
    }
    for (std::size_t k = 0; k < count; ++k)
      if (seen[k] != 0 && seen[k] != 3)
        throw Error(at_line + ": keypoint '" + std::string(hand::keypoint_name(layout_, k)) + "' has " + std::to_string(seen[k]) +
                    " of its 3 coordinates, expected all three or none (empty or nan: not seen)");
  }

 private:
  hand::KeypointLayout layout_;
  double scale_;
  std::vector<int> column_;  // keypoint * 3 + axis, or -1
  std::array<bool, hand::kMaxKeypoints> present_{};
};

/// @brief A tracker's keypoints read from a CSV file of its own.
struct KeypointFile {
  hand::KeypointLayout layout = hand::KeypointLayout::MediaPipe;
  std::array<bool, hand::kMaxKeypoints> present{};  ///< Keypoints with columns.
  KeypointTrack track;                              ///< Times on the tracker's clock, points in mm.
};

/// @brief Reads a keypoint file: a header with `timestamp` (seconds) or `timestamp_ms`, keypoint
/// columns of one layout and the columns listed in `ignored` (names or patterns, io::column_listed); then one line per tracker frame,
/// times increasing. Blank lines and lines starting with '#' are skipped. `scale`: mm per unit.
/// Throws glovepose::Error "keypoint file '<path>', line L, column 'C': ..." for anything else.
inline KeypointFile read_keypoint_file(std::istream& in, const std::string& path, double scale, const std::vector<std::string>& ignored) {
  const std::string at = "keypoint file '" + path + "'";
  std::string line;
  std::size_t line_no = 0;
  if (!io::next_csv_line(in, line, line_no)) throw Error(at + ", line " + std::to_string(line_no + 1) + ": no header, expected timestamp and keypoint columns");
  const std::string at_header = at + ", line " + std::to_string(line_no);
  const std::vector<std::string> header = io::split_csv_line(line);
  const std::optional<hand::KeypointLayout> layout = keypoint_layout_of(header, at_header);
  if (!layout)
    throw Error(at_header + ": no keypoint columns, expected columns such as index_finger_tip_x (MediaPipe) or index_tip_x (OpenXR)");
  const KeypointColumns columns(header, *layout, scale, at_header);
  int time_column = -1;
  double time_unit = 1.0;
  for (std::size_t c = 0; c < header.size(); ++c) {
    if (columns.is_keypoint(c) || io::column_listed(header[c], ignored)) continue;
    if ((header[c] == "timestamp" || header[c] == "timestamp_ms") && time_column < 0) {
      time_column = static_cast<int>(c);
      time_unit = header[c] == "timestamp" ? 1.0 : 1e-3;
      continue;
    }
    throw Error(at_header + ", column " + std::to_string(c + 1) + " '" + header[c] +
                "': unknown column, expected one timestamp or timestamp_ms column and keypoint columns "
                "(skip others with ignored_columns, `glovepose import --ignore`)");
  }
  if (time_column < 0) throw Error(at_header + ": no timestamp or timestamp_ms column, expected the tracker's time of each frame");
  KeypointFile out;
  out.layout = *layout;
  out.present = columns.present();
  while (io::next_csv_line(in, line, line_no)) {
    const std::string at_line = at + ", line " + std::to_string(line_no);
    const std::vector<std::string> fields = io::split_csv_line(line);
    if (fields.size() != header.size())
      throw Error(at_line + ": " + std::to_string(fields.size()) + " fields, expected " + std::to_string(header.size()));
    const std::string& stamp = fields[static_cast<std::size_t>(time_column)];
    const double time =
        io::parse_csv_number<double>(stamp, at_line + ", column '" + header[static_cast<std::size_t>(time_column)] + "': '" + stamp + "'") *
        time_unit;
    if (!out.track.times.empty() && !(time > out.track.times.back()))
      throw Error(at_line + ": time " + io::number_text(time) + " s is not after the line before's (" +
                  io::number_text(out.track.times.back()) + " s), expected increasing times");
    columns.read_row(fields, header, at_line, out.track.points);
    out.track.times.push_back(time);
  }
  if (in.bad()) throw Error(at + ", line " + std::to_string(line_no + 1) + ": read error");
  if (out.track.times.empty()) throw Error(at + ": no frames after the header, expected one line per tracker frame");
  return out;
}

}  // namespace glovepose::train
