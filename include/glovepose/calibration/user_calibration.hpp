/// @file user_calibration.hpp
/// @brief One user's calibration as saved and loaded: the per-sensor range and, when it was
/// pose-guided, the 25 angle offsets (docs/calibration.md, "Saved calibrations").
///
/// The file is sensor::CalibrationRange's text format, followed for a pose-guided calibration by
/// "pose_offsets<TAB>25" and one "dof_name<TAB>radians" line per DoF (hand::kDofs order, 17
/// significant digits). Readers of the range alone stop before that section, so a range-only
/// reader reads either kind.
///
/// Set-up code: throws glovepose::Error naming the file, the line and what was expected.
#pragma once

#include <charconv>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <optional>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../hand/dofs.hpp"
#include "../io/atomic_file.hpp"
#include "../sensor/calibration.hpp"

namespace glovepose::calibration {

/// @brief A user's range and optional pose-guided offsets.
struct UserCalibration {
  sensor::CalibrationRange range;       ///< Per-sensor min-max.
  std::optional<hand::Angles> offsets;  ///< Pose-guided angle offsets (radians), if any.

  /// @brief Writes the file, whole or not at all (io::AtomicFile). Throws glovepose::Error naming
  /// the file and the cause if it cannot be written.
  void save(const std::string& path, const std::string& glove_id) const {
    io::write_file_whole(path, "calibration file", [&](std::ostream& file) {
      range.save(file, glove_id);
      if (!offsets) return;
      file << std::setprecision(17) << "pose_offsets\t" << hand::kDofCount << "\n";
      for (std::size_t d = 0; d < hand::kDofCount; ++d) file << hand::kDofs[d].name << "\t" << (*offsets)[d] << "\n";
    });
  }

  /// @brief Reads a file written by save() (or by CalibrationRange::save) for `glove_id` and its
  /// cells `names`.
  static UserCalibration load(const std::string& path, const std::string& glove_id, const std::vector<std::string>& names,
                              sensor::CalibrationConfig config = {}) {
    std::ifstream file(path);
    if (!file) throw Error("UserCalibration::load: cannot open '" + path + "'");
    return load(file, path, glove_id, names, config);
  }

  /// @brief load()'s parser over a stream; `source` names it in messages.
  static UserCalibration load(std::istream& file, const std::string& source, const std::string& glove_id,
                              const std::vector<std::string>& names, sensor::CalibrationConfig config = {}) {
    UserCalibration out{sensor::CalibrationRange::load(file, source, glove_id, names, config), std::nullopt};
    int line_no = 3 + static_cast<int>(names.size());
    std::string line;
    const auto fail = [&](const std::string& what) {
      return Error("UserCalibration::load: '" + source + "' line " + std::to_string(line_no) + ": " + what);
    };
    const auto next = [&]() {
      ++line_no;
      if (!std::getline(file, line)) return false;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      return true;
    };
    if (!next() || line.empty()) return out;  // a range without offsets
    if (line != "pose_offsets\t" + std::to_string(hand::kDofCount))
      throw fail("'" + line + "', expected 'pose_offsets\t25' or the end of the file");
    hand::Angles offsets{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      if (!next()) throw fail("file ends early, expected 25 offset lines");
      const std::string expected = std::string(hand::kDofs[d].name) + "\t";
      if (line.compare(0, expected.size(), expected) != 0) throw fail("expected '" + expected + "<radians>'");
      const char* begin = line.data() + expected.size();
      const char* end = line.data() + line.size();
      double value = 0.0;
      const auto r = std::from_chars(begin, end, value);
      if (r.ec != std::errc() || r.ptr != end || !std::isfinite(value))
        throw fail("'" + line.substr(expected.size()) + "' is not a finite number");
      offsets[d] = value;
    }
    out.offsets = offsets;
    return out;
  }
};

}  // namespace glovepose::calibration
