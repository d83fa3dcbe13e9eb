/// @file glove_description.hpp
/// @brief A glove described by data: its id, its sensor cells (how many, their names, where each sits
/// in the 2x5x5 stretch maps), its extra inputs (not on the maps), where each of the 25 DoFs sits in
/// the 5x5 pose map and its settings; read from and written to a small JSON file, so a glove with
/// another layout needs no code.
///
/// File format ("glovepose-glove", version 1; also in weights_format.md, "Glove description files"):
///
/// ```
/// {
///   "format": "glovepose-glove",
///   "version": 1,
///   "id": "glauser2019-44",
///   "cells": [
///     {"name": "cell_0", "channel": 0, "row": 0, "col": 2},
///     ...
///     {"name": "wrist_imu_pitch", "extra": true},
///   ],
///   "dofs": [
///     {"name": "thumb_base_abduction", "row": 0, "col": 0},
///     {"name": "index_base_flexion", "row": 1, "col": 1, "min_degrees": -20, "max_degrees": 100},
///     ...
///   ],
///   "rate_hz": 20,
///   "calibration": {"median_seconds": 0.333, "flat_relative_range": 0.0005, "min_range_to_noise": 12}
/// }
/// ```
///
/// - `cells`: one entry per input, in cell-id order (input i of a frame is entry i). A stretch cell
///   has `channel` (0: the map of stretch along the fingers, 1: across), `row`, `col` 0..4; at most
///   50 (the slots of the two maps), one per slot. An input that is not a stretch cell (an IMU angle,
///   a bend sensor over the wrist) has `"extra": true` instead of a slot: the FCN and the linear map
///   read it beside the cells, the U-Net (which reads only the maps) refuses such a glove. 1 to
///   kMaxGloveInputs inputs with unique non-empty names.
/// - `dofs`: the 25 DoFs, each named by its hand::kDofs name, in any order, each exactly once, one DoF
///   per slot of the single pose map (`row`, `col` 0..4).
/// - Optional (absent: the defaults, which are the built-in glove's): a DoF's `min_degrees` and
///   `max_degrees` (both or neither; min < max): the glove's own joint limits for that DoF, which a
///   model trained for the glove records and normalises its outputs by (default: hand::kDofs');
///   `rate_hz`: the glove's frame rate (positive); `calibration.median_seconds`: the time the
///   on-the-fly calibration's running median spans (positive; default 1/3 s, the paper's 20 frames
///   at 60 Hz); `calibration.flat_relative_range`: a sensor whose calibrated range is within this
///   fraction of its absolute value is flat and zeroed (>= 0; default 0.01, tuned for capacitance: a
///   resistive sensor with a large DC offset needs a smaller one); `calibration.min_range_to_noise`: a
///   sensor whose calibrated range is below this many times its noise SD is noise only (a dead
///   channel) and zeroed (finite, >= 0; default 12; 0: off).
/// - Every other listed key is required and no other key is accepted (a misspelt key is an error, not a
///   silently ignored field); slot numbers are non-negative integers written without fraction or
///   exponent.
///
/// Set-up code: every malformed input is a glovepose::Error naming the field, cell or DoF and what
/// was expected.
#pragma once

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "../core/units.hpp"
#include "../config.hpp"
#include "../hand/dofs.hpp"
#include "../io/atomic_file.hpp"
#include "../io/json.hpp"
#include "../io/number_text.hpp"
#include "../sensor/calibration.hpp"
#include "grid_map.hpp"

namespace glovepose::grid {

/// @brief Value of the file's "format" key.
inline constexpr const char* kGloveFormat = "glovepose-glove";
/// @brief The file version this build reads and writes.
inline constexpr int kGloveFormatVersion = 1;
/// @brief Largest glove description file read() accepts, bytes (a 50-cell glove takes about 4 KiB).
inline constexpr std::size_t kMaxGloveFileBytes = 1 << 20;
/// @brief Most inputs (stretch cells and extra inputs) a glove may have.
inline constexpr int kMaxGloveInputs = 256;

/// @brief How a glove is calibrated (description key "calibration"). The defaults are the paper's.
struct GloveCalibration {
  /// Time the on-the-fly calibration's running median spans, s: 20 frames at 60 Hz.
  double median_seconds = 1.0 / 3.0;
  /// A sensor whose calibrated range is within this fraction of max(|min|, |max|) is flat (zeroed).
  double flat_relative_range = 0.01;  // sensor::CalibrationConfig's default (test_glove_description checks)
  /// A sensor whose range is below this many times its noise SD is noise only (zeroed); 0: off.
  double min_range_to_noise = 12.0;  // sensor::CalibrationConfig's default (test_glove_description checks)

  /// @brief The calibration settings with this flat rule, this noise rule and the default clamp.
  sensor::CalibrationConfig config() const noexcept {
    sensor::CalibrationConfig c;
    c.min_relative_range = flat_relative_range;
    c.min_range_to_noise = min_range_to_noise;
    return c;
  }
  /// @brief The median window in frames at `frames_per_second` (at least 1).
  int median_frames(double frames_per_second) const noexcept {
    const double frames = std::round(median_seconds * frames_per_second);
    return frames < 1.0 ? 1 : (frames > 1e6 ? 1000000 : static_cast<int>(frames));
  }
  /// @brief Same settings.
  friend bool operator==(const GloveCalibration& a, const GloveCalibration& b) noexcept {
    return a.median_seconds == b.median_seconds && a.flat_relative_range == b.flat_relative_range &&
           a.min_range_to_noise == b.min_range_to_noise;
  }
};

/// @brief A DoF's own limits in a glove description, degrees (min < max).
struct DofLimitsDegrees {
  double min;  ///< Lower limit, degrees.
  double max;  ///< Upper limit, degrees.
};

/// @brief What a glove description may add to its cells and slots: its joint limits, frame rate
/// and calibration. Every field's default is the built-in glove's.
struct GloveSettings {
  std::array<std::optional<DofLimitsDegrees>, hand::kDofCount> limits_degrees{};  ///< Per DoF; none: hand::kDofs'.
  std::optional<double> rate_hz;                                                  ///< Frames per second, if known.
  GloveCalibration calibration{};                                                 ///< Median window and flat rule.
  /// Per input, the seconds of its own past whose mean is taken off each reading (a drift-removing
  /// high-pass, sensor/input_conditioning.hpp); 0: as read. Empty: every input as read.
  std::vector<double> demean_seconds;
};

/// @brief A glove: id, cell names (one per sensor cell, in cell-id order), its GridMap and its
/// settings (joint limits, rate, calibration). Immutable and validated on construction.
class GloveDescription {
 public:
  /// @brief Describes a glove. Throws glovepose::Error when the id is empty, the number of names is
  /// not the map's cell count, a name is empty or used twice, or a setting is out of its range.
  GloveDescription(std::string id, std::vector<std::string> cell_names, GridMap map, GloveSettings settings = {})
      : id_(std::move(id)), cell_names_(std::move(cell_names)), map_(std::move(map)), settings_(settings) {
    if (id_.empty()) throw Error("GloveDescription: empty id, expected a glove id such as 'glauser2019-44'");
    if (map_.cell_count() > kMaxGloveInputs)
      throw Error("GloveDescription '" + id_ + "': " + std::to_string(map_.cell_count()) + " inputs, expected at most " +
                  std::to_string(kMaxGloveInputs));
    check_settings(settings_, "GloveDescription '" + id_ + "': ");
    if (static_cast<int>(cell_names_.size()) != map_.cell_count())
      throw Error("GloveDescription '" + id_ + "': " + std::to_string(cell_names_.size()) + " cell names, expected " +
                  std::to_string(map_.cell_count()) + " (one per cell of the grid map)");
    if (!settings_.demean_seconds.empty() && settings_.demean_seconds.size() != cell_names_.size())
      throw Error("GloveDescription '" + id_ + "': demean_seconds for " + std::to_string(settings_.demean_seconds.size()) +
                  " inputs, expected one per input (" + std::to_string(cell_names_.size()) + ") or none");
    for (std::size_t c = 0; c < cell_names_.size(); ++c) {
      if (cell_names_[c].empty())
        throw Error("GloveDescription '" + id_ + "': cell " + std::to_string(c) + " has an empty name, expected a name");
      for (std::size_t earlier = 0; earlier < c; ++earlier)
        if (cell_names_[earlier] == cell_names_[c])
          throw Error("GloveDescription '" + id_ + "': cell " + std::to_string(c) + " is named '" + cell_names_[c] + "' like cell " +
                      std::to_string(earlier) + ", expected unique cell names");
    }
  }

  /// @brief The 44-cell glove of Glauser et al. 2019: id "glauser2019-44", GridMap::glauser2019(),
  /// cells named "cell_0".."cell_43" (the cell ids of the paper's Fig. 4, as in the dataset CSV columns).
  static GloveDescription glauser2019() {
    GridMap map = GridMap::glauser2019();
    std::vector<std::string> names;
    for (int c = 0; c < map.cell_count(); ++c) names.push_back("cell_" + std::to_string(c));
    return GloveDescription("glauser2019-44", std::move(names), std::move(map));
  }

  /// @brief The glove a model file was trained for, from its metadata: the description it carries
  /// (`description`, JSON text; may be empty), else the built-in glove when `id` names it. Throws
  /// glovepose::Error when the file names another glove without describing it.
  static GloveDescription of_model(const std::string& id, const std::string& description) {
    if (!description.empty()) return from_metadata(description);
    GloveDescription builtin = glauser2019();
    if (id != builtin.id())
      throw Error("the model reads glove '" + id + "' and carries no glove description, expected the built-in glove '" + builtin.id() +
                  "' or a model with metadata 'glove_description'");
    return builtin;
  }

  /// @brief Glove id (e.g. the "glove" of a model file's metadata).
  const std::string& id() const noexcept { return id_; }
  /// @brief Name of each cell, in cell-id order.
  const std::vector<std::string>& cell_names() const noexcept { return cell_names_; }
  /// @brief Where the cells and DoFs go in the maps.
  const GridMap& map() const noexcept { return map_; }
  /// @brief Number of sensor cells.
  int cell_count() const noexcept { return map_.cell_count(); }
  /// @brief Joint limits, rate and calibration as described.
  const GloveSettings& settings() const noexcept { return settings_; }
  /// @brief The calibration's median window and flat-sensor rule.
  const GloveCalibration& calibration() const noexcept { return settings_.calibration; }
  /// @brief The glove's frame rate, when the description gives one.
  std::optional<double> rate_hz() const noexcept { return settings_.rate_hz; }
  /// @brief Per input, the seconds of demean_seconds (0: as read); empty when no input is conditioned.
  std::vector<double> conditioning_seconds() const {
    const bool any = std::any_of(settings_.demean_seconds.begin(), settings_.demean_seconds.end(), [](double v) { return v > 0.0; });
    return any ? settings_.demean_seconds : std::vector<double>{};
  }
  /// @brief Per input, the frames its rolling mean spans (demean_seconds at rate_hz, at least 2), 0
  /// for an input read as it is; empty when no input is conditioned.
  std::vector<int> demean_frames() const {
    std::vector<int> frames;
    for (std::size_t c = 0; c < settings_.demean_seconds.size(); ++c) {
      const double seconds = settings_.demean_seconds[c];
      if (seconds > 0.0 && frames.empty()) frames.assign(settings_.demean_seconds.size(), 0);
      if (seconds > 0.0) frames[c] = std::max(2, static_cast<int>(std::lround(seconds * *settings_.rate_hz)));
    }
    return frames;
  }
  /// @brief The joint limits a model for this glove normalises its outputs by: the description's
  /// where it gives them, hand::kDofs' elsewhere.
  hand::JointLimits joint_limits() const {
    hand::Angles lo{}, hi{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const auto& own = settings_.limits_degrees[d];
      lo[d] = own ? own->min * core::kRadiansPerDegree : hand::kDofs[d].min;
      hi[d] = own ? own->max * core::kRadiansPerDegree : hand::kDofs[d].max;
    }
    return hand::JointLimits(lo, hi);
  }

  /// @brief Cell id of the cell called `name`; throws glovepose::Error if no cell has that name.
  /// (Selects the columns of a bigger glove's data for a glove made of some of its cells.)
  int cell_index(const std::string& name) const {
    const auto it = std::find(cell_names_.begin(), cell_names_.end(), name);
    if (it == cell_names_.end())
      throw Error("GloveDescription '" + id_ + "': no cell named '" + name + "', expected one of its " +
                  std::to_string(cell_names_.size()) + " cell names (e.g. '" + cell_names_.front() + "')");
    return static_cast<int>(it - cell_names_.begin());
  }

  /// @brief Same id, cell names, slots and settings.
  friend bool operator==(const GloveDescription& a, const GloveDescription& b) noexcept {
    if (a.id_ != b.id_ || a.cell_names_ != b.cell_names_) return false;
    if (a.settings_.rate_hz != b.settings_.rate_hz || !(a.settings_.calibration == b.settings_.calibration)) return false;
    if (a.conditioning_seconds() != b.conditioning_seconds()) return false;
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const auto &p = a.settings_.limits_degrees[d], &q = b.settings_.limits_degrees[d];
      if (p.has_value() != q.has_value() || (p && (p->min != q->min || p->max != q->max))) return false;
    }
    const auto same = [](const Slot& s, const Slot& t) { return s.channel == t.channel && s.row == t.row && s.col == t.col; };
    for (std::size_t c = 0; c < a.cell_names_.size(); ++c)
      if (!same(a.map_.cell_slots()[c], b.map_.cell_slots()[c])) return false;
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      if (!same(a.map_.dof_slots()[d], b.map_.dof_slots()[d])) return false;
    return true;
  }
  /// @brief Not operator==.
  friend bool operator!=(const GloveDescription& a, const GloveDescription& b) noexcept { return !(a == b); }

  /// @brief The description as JSON text (the file format above): one cell or DoF per line, DoFs in
  /// hand::kDofs order, ending with a newline.
  std::string to_json() const {
    std::string out = "{\n  \"format\": " + io::json::quote(kGloveFormat) + ",\n  \"version\": " + std::to_string(kGloveFormatVersion) +
                      ",\n  \"id\": " + io::json::quote(id_) + ",\n  \"cells\": [\n";
    for (std::size_t c = 0; c < cell_names_.size(); ++c) {
      const Slot& s = map_.cell_slots()[c];
      out += "    {\"name\": " + io::json::quote(cell_names_[c]);
      out += s.on_maps() ? ", \"channel\": " + std::to_string(s.channel) + ", \"row\": " + std::to_string(s.row) +
                               ", \"col\": " + std::to_string(s.col)
                         : ", \"extra\": true";
      if (c < settings_.demean_seconds.size() && settings_.demean_seconds[c] > 0.0)
        out += ", \"demean_seconds\": " + io::number_text(settings_.demean_seconds[c]);
      out += "}";
      out += c + 1 < cell_names_.size() ? ",\n" : "\n";
    }
    out += "  ],\n  \"dofs\": [\n";
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const Slot& s = map_.dof_slots()[d];
      out += "    {\"name\": " + io::json::quote(hand::kDofs[d].name) + ", \"row\": " + std::to_string(s.row) +
             ", \"col\": " + std::to_string(s.col);
      if (const auto& own = settings_.limits_degrees[d])
        out += ", \"min_degrees\": " + io::number_text(own->min) + ", \"max_degrees\": " + io::number_text(own->max);
      out += d + 1 < hand::kDofCount ? "},\n" : "}\n";
    }
    out += "  ]";
    if (settings_.rate_hz) out += ",\n  \"rate_hz\": " + io::number_text(*settings_.rate_hz);
    if (!(settings_.calibration == GloveCalibration{}))
      out += ",\n  \"calibration\": {\"median_seconds\": " + io::number_text(settings_.calibration.median_seconds) +
             ", \"flat_relative_range\": " + io::number_text(settings_.calibration.flat_relative_range) +
             // Only when set: descriptions written before the key existed keep their text.
             (settings_.calibration.min_range_to_noise == GloveCalibration{}.min_range_to_noise
                  ? std::string()
                  : ", \"min_range_to_noise\": " + io::number_text(settings_.calibration.min_range_to_noise)) +
             "}";
    return out + "\n}\n";
  }

  /// @brief Parses JSON text in the file format above. Throws glovepose::Error naming the field,
  /// cell or DoF that is wrong and what was expected.
  static GloveDescription from_json(const std::string& text) {
    io::json::Value root;
    try {
      root = io::json::parse(text);
    } catch (const Error& e) {
      throw fail(std::string("not valid JSON (") + e.what() + "), expected a JSON object");
    }
    const io::json::Fields f(kFailPrefix);
    f.format(root, kGloveFormat, kGloveFormatVersion);
    f.only(root, {"format", "version", "id", "cells", "dofs", "rate_hz", "calibration"}, "the top-level object");
    const std::string id = f.string(root, "id", "the top-level object");
    if (id.empty()) throw fail("'id' is empty, expected a glove id such as 'glauser2019-44'");

    // Cells: names and slots, checked here so that messages name the cell (GridMap checks again).
    const io::json::Value& cells = f.at(root, "cells", "the top-level object");
    if (!cells.is_array()) throw fail("'cells' is " + io::json::describe(cells) + ", expected an array of cells");
    if (cells.empty()) throw fail("'cells' is empty, expected at least one cell");
    if (cells.size() > static_cast<std::size_t>(kMaxGloveInputs))
      throw fail("'cells' lists " + std::to_string(cells.size()) + " inputs, expected at most " + std::to_string(kMaxGloveInputs) +
                 " (at most " + std::to_string(kStretchValues) + " stretch cells, one per slot of the maps, and extra inputs)");
    GloveSettings settings;
    if (root.contains("rate_hz")) settings.rate_hz = f.number(root, "rate_hz", "the top-level object");
    if (const io::json::Value* calibration = io::json::Fields::find(root, "calibration")) {
      const std::string where = "'calibration'";
      if (!calibration->is_object())
        throw fail(where + " is " + io::json::describe(*calibration) +
                   ", expected an object {\"median_seconds\", \"flat_relative_range\", \"min_range_to_noise\"}");
      f.only(*calibration, {"median_seconds", "flat_relative_range", "min_range_to_noise"}, where);
      if (calibration->contains("median_seconds")) settings.calibration.median_seconds = f.number(*calibration, "median_seconds", where);
      if (calibration->contains("flat_relative_range"))
        settings.calibration.flat_relative_range = f.number(*calibration, "flat_relative_range", where);
      if (calibration->contains("min_range_to_noise"))
        settings.calibration.min_range_to_noise = f.number(*calibration, "min_range_to_noise", where);
    }
    try {
      check_settings(settings, "");
    } catch (const Error& e) {
      throw fail(e.what());
    }
    std::vector<std::string> names;
    std::vector<Slot> cell_slots;
    std::array<int, kStretchValues> cell_owner{};
    cell_owner.fill(-1);
    int stretch_cells = 0;
    for (std::size_t c = 0; c < cells.size(); ++c) {
      const io::json::Value& cell = cells[c];
      std::string where = "cells[" + std::to_string(c) + "]";
      if (!cell.is_object())
        throw fail(where + " is " + io::json::describe(cell) + ", expected an object {\"name\", \"channel\", \"row\", \"col\"}");
      f.only(cell, {"name", "channel", "row", "col", "extra", "demean_seconds"}, where);
      const std::string name = f.string(cell, "name", where);
      if (name.empty()) throw fail(where + ": 'name' is empty, expected a cell name");
      where += " ('" + name + "')";
      if (cell.contains("demean_seconds")) {
        const double seconds = f.number(cell, "demean_seconds", where);
        if (!(seconds > 0.0 && seconds <= kMaxDemeanSeconds))
          throw fail(where + ": 'demean_seconds' is " + io::number_text(seconds) + ", expected a time > 0 s (at most " +
                     io::number_text(kMaxDemeanSeconds) + ")");
        if (!settings.rate_hz)
          throw fail(where + " has 'demean_seconds' but the description has no 'rate_hz', expected the frames per second that make "
                     "the seconds frames");
        settings.demean_seconds.resize(cells.size(), 0.0);
        settings.demean_seconds[c] = seconds;
      }
      for (std::size_t earlier = 0; earlier < c; ++earlier)
        if (names[earlier] == name)
          throw fail(where + " has the name of cells[" + std::to_string(earlier) + "], expected unique cell names");
      if (const io::json::Value* extra = io::json::Fields::find(cell, "extra")) {
        if (*extra != true)
          throw fail(where + ": 'extra' is " + io::json::describe(*extra) +
                     ", expected true (an input that is not on the stretch maps) or no 'extra'");
        for (const char* key : {"channel", "row", "col"})
          if (cell.contains(key))
            throw fail(where + " has 'extra' and '" + key + "', expected either a slot (channel, row, col) or \"extra\": true");
        names.push_back(name);
        cell_slots.push_back(kOffMaps);
        continue;
      }
      if (++stretch_cells > kStretchValues)
        throw fail(where + " is stretch cell " + std::to_string(stretch_cells) + ", but the stretch maps (" +
                   std::to_string(kStretchChannels) + " x " + std::to_string(kGridSize) + " x " + std::to_string(kGridSize) +
                   ") have only " + std::to_string(kStretchValues) + " slots, expected at most " + std::to_string(kStretchValues) +
                   " stretch cells (an input not on the maps is \"extra\": true)");
      const Slot slot{f.index(cell, "channel", kStretchChannels, where), f.index(cell, "row", kGridSize, where),
                      f.index(cell, "col", kGridSize, where)};
      int& owner = cell_owner[static_cast<std::size_t>(slot.flat())];
      if (owner >= 0)
        throw fail(where + " is placed at " + describe(slot, true) + ", the slot of cells[" + std::to_string(owner) + "] ('" +
                   names[static_cast<std::size_t>(owner)] + "'), expected one cell per slot");
      owner = static_cast<int>(c);
      names.push_back(name);
      cell_slots.push_back(slot);
    }

    // DoFs: by name, any order, each exactly once.
    const io::json::Value& dofs = f.at(root, "dofs", "the top-level object");
    if (!dofs.is_array())
      throw fail("'dofs' is " + io::json::describe(dofs) + ", expected an array of the " + std::to_string(hand::kDofCount) + " DoFs");
    std::array<Slot, hand::kDofCount> dof_slots{};
    std::array<int, hand::kDofCount> dof_entry{};  // which entry of 'dofs' placed each DoF
    dof_entry.fill(-1);
    std::array<int, kMapSlots> dof_owner{};  // which DoF holds each pose-map slot
    dof_owner.fill(-1);
    for (std::size_t e = 0; e < dofs.size(); ++e) {
      const io::json::Value& entry = dofs[e];
      std::string where = "dofs[" + std::to_string(e) + "]";
      if (!entry.is_object()) throw fail(where + " is " + io::json::describe(entry) + ", expected an object {\"name\", \"row\", \"col\"}");
      f.only(entry, {"name", "row", "col", "min_degrees", "max_degrees"}, where);
      const std::string name = f.string(entry, "name", where);
      const std::size_t d = dof_named(name, where);
      where += " ('" + name + "')";
      if (dof_entry[d] >= 0)
        throw fail(where + " repeats the DoF of dofs[" + std::to_string(dof_entry[d]) + "], expected each of the " +
                   std::to_string(hand::kDofCount) + " DoFs exactly once");
      const Slot slot{0, f.index(entry, "row", kGridSize, where), f.index(entry, "col", kGridSize, where)};
      int& owner = dof_owner[static_cast<std::size_t>(slot.flat())];
      if (owner >= 0)
        throw fail(where + " is placed at " + describe(slot, false) + ", the slot of DoF '" +
                   hand::kDofs[static_cast<std::size_t>(owner)].name + "', expected one DoF per slot");
      owner = static_cast<int>(d);
      dof_entry[d] = static_cast<int>(e);
      dof_slots[d] = slot;
      const bool has_min = entry.contains("min_degrees"), has_max = entry.contains("max_degrees");
      if (has_min != has_max)
        throw fail(where + " has '" + (has_min ? "min_degrees" : "max_degrees") + "' without '" +
                   (has_min ? "max_degrees" : "min_degrees") + "', expected both limits or neither");
      if (has_min) {
        const double lo = f.number(entry, "min_degrees", where), hi = f.number(entry, "max_degrees", where);
        if (!(lo < hi) || lo < -360.0 || hi > 360.0)
          throw fail(where + " has limits [" + io::number_text(lo) + ", " + io::number_text(hi) +
                     "] degrees, expected min_degrees < max_degrees within [-360, 360]");
        settings.limits_degrees[d] = DofLimitsDegrees{lo, hi};
      }
    }
    std::string missing;
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      if (dof_entry[d] < 0) missing += std::string(missing.empty() ? "" : ", ") + hand::kDofs[d].name;
    if (!missing.empty())
      throw fail("'dofs' lacks " + missing + ", expected each of the " + std::to_string(hand::kDofCount) + " DoFs exactly once");

    try {
      return GloveDescription(id, std::move(names), GridMap(std::move(cell_slots), dof_slots), settings);
    } catch (const Error& e) {
      throw fail(e.what());  // not reached for a file that passed the checks above; kept for safety
    }
  }

  /// @brief Reads a glove description file; messages start with "glove description file '<path>': ".
  static GloveDescription read(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw Error("glove description file '" + path + "': cannot open, expected a readable file");
    std::string text;
    char buffer[4096];
    while (file.read(buffer, sizeof buffer) || file.gcount() > 0) {
      text.append(buffer, static_cast<std::size_t>(file.gcount()));
      if (text.size() > kMaxGloveFileBytes)
        throw Error("glove description file '" + path + "': larger than " + std::to_string(kMaxGloveFileBytes) +
                    " bytes, expected a small JSON file");
    }
    if (file.bad()) throw Error("glove description file '" + path + "': read error, expected a readable file");
    try {
      return from_json(text);
    } catch (const Error& e) {
      throw Error("glove description file '" + path + "': " + e.what());
    }
  }

  /// @brief Writes to_json() to `path`, whole or not at all (io::AtomicFile); throws
  /// glovepose::Error naming the file and the cause if it cannot be written.
  void write(const std::string& path) const {
    io::write_file_whole(path, "glove description file", [&](std::ostream& file) { file << to_json(); });
  }

  /// @brief The description as a metadata string of a model or dataset file: the JSON text.
  std::string to_metadata() const { return to_json(); }
  /// @brief Parses a metadata string written by to_metadata() (same rules and messages as from_json()).
  static GloveDescription from_metadata(const std::string& text) { return from_json(text); }

 private:
  static constexpr double kMaxMedianSeconds = 10.0;  // the paper's window is 1/3 s
  static constexpr double kMaxDemeanSeconds = 600.0;  // a window kept in memory per input, frame by frame
  static constexpr double kMaxDemeanFrames = 16777216.0;  // every input's window together: 128 MiB of readings
  static constexpr double kMaxRangeToNoise = 1000.0;  // moving cells of simulated corpora reach 32-119: more would zero them

  static constexpr const char* kFailPrefix = "glove description: ";
  static Error fail(const std::string& what) { return Error(kFailPrefix + what); }

  // The settings' ranges (the limits' order is checked where they are read, naming the DoF entry).
  static void check_settings(const GloveSettings& s, const std::string& prefix) {
    if (s.rate_hz && !(*s.rate_hz > 0.0 && *s.rate_hz <= 1e6))
      throw Error(prefix + "'rate_hz' is " + io::number_text(*s.rate_hz) + ", expected frames per second > 0 (at most 1e6)");
    if (!(s.calibration.median_seconds > 0.0 && s.calibration.median_seconds <= kMaxMedianSeconds))
      throw Error(prefix + "'calibration.median_seconds' is " + io::number_text(s.calibration.median_seconds) +
                  ", expected a time > 0 s (at most " + io::number_text(kMaxMedianSeconds) +
                  ": the median runs over the window every frame)");
    if (!(s.calibration.flat_relative_range >= 0.0 && s.calibration.flat_relative_range < 1.0))
      throw Error(prefix + "'calibration.flat_relative_range' is " + io::number_text(s.calibration.flat_relative_range) +
                  ", expected a fraction >= 0 and < 1 (0.01: a range within 1% of the value is flat)");
    if (!(s.calibration.min_range_to_noise >= 0.0 && s.calibration.min_range_to_noise <= kMaxRangeToNoise))
      throw Error(prefix + "'calibration.min_range_to_noise' is " + io::number_text(s.calibration.min_range_to_noise) +
                  ", expected a multiple of the noise SD >= 0 and at most " + io::number_text(kMaxRangeToNoise) +
                  " (12: a range below 12 x its noise SD is noise only; 0: off)");
    for (const double seconds : s.demean_seconds) {
      if (!(seconds >= 0.0 && seconds <= kMaxDemeanSeconds))
        throw Error(prefix + "demean_seconds " + io::number_text(seconds) + ", expected a time >= 0 s (0: as read) and at most " +
                    io::number_text(kMaxDemeanSeconds));
      if (seconds > 0.0 && !s.rate_hz)
        throw Error(prefix + "demean_seconds without 'rate_hz', expected the frames per second that make the seconds frames");
    }
    if (s.rate_hz) {
      double frames = 0.0;
      for (const double seconds : s.demean_seconds) frames += seconds * *s.rate_hz;
      if (frames > kMaxDemeanFrames)
        throw Error(prefix + "demean_seconds at rate_hz " + io::number_text(*s.rate_hz) + " keep " + std::to_string(std::llround(frames)) +
                    " readings in all, expected at most " + std::to_string(std::llround(kMaxDemeanFrames)) +
                    " (shorter windows, fewer inputs demeaned)");
    }
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      if (const auto& own = s.limits_degrees[d]; own && !(own->min < own->max && std::isfinite(own->min) && std::isfinite(own->max)))
        throw Error(prefix + "DoF '" + hand::kDofs[d].name + "' has limits [" + io::number_text(own->min) + ", " +
                    io::number_text(own->max) + "] degrees, expected finite min < max");
  }

  static std::string describe(const Slot& s, bool with_channel) {
    return std::string("(") + (with_channel ? "channel " + std::to_string(s.channel) + ", " : "") + "row " + std::to_string(s.row) +
           ", column " + std::to_string(s.col) + ")";
  }

  static std::size_t dof_named(const std::string& name, const std::string& where) {
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      if (name == hand::kDofs[d].name) return d;
    std::string list;
    for (const hand::Dof& dof : hand::kDofs) list += std::string(list.empty() ? "" : ", ") + dof.name;
    throw fail(where + ": unknown DoF '" + name + "', expected one of the names of hand::kDofs: " + list);
  }

  std::string id_;
  std::vector<std::string> cell_names_;
  GridMap map_;
  GloveSettings settings_;
};

}  // namespace glovepose::grid
