/// @file sequence.hpp
/// @brief A guided calibration sequence: the poses the user is asked to make, one after another,
/// each for a fixed time, as data (docs/calibration.md, the file format). The sequence tells the
/// user what to do (name, instruction, the pose to copy), tells the simulator what its people do,
/// and tells the pose-guided calibration (pose_offset.hpp) what the hand did while each frame was
/// read.
///
/// Most poses a person makes in their own way (each person's flat hand is a little bent, each fist a
/// little different), so their target angles say little about a new user's true angles. Some poses
/// pin angles whatever the person: a hand pressed flat on a table holds every finger flexion at 0.
/// A step lists the angles it pins and how closely a person holds them (`pinned_sd`); only those
/// angles are used as known truth.
///
/// Set-up code: parsing allocates and throws glovepose::Error naming the file, the step and what was
/// expected; step_at() is per-frame.
#pragma once

#include <array>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "../core/units.hpp"
#include "../config.hpp"
#include "../hand/dofs.hpp"
#include "../io/json.hpp"

namespace glovepose::calibration {

/// @brief One step: what the user is asked to do, for how long, and what it means for the angles.
struct Step {
  std::string name;                            ///< Short id, e.g. "flat_on_table".
  std::string instruction;                     ///< What to tell the user.
  double seconds = 0.0;                        ///< Duration of the step (> 0).
  hand::Angles pose{};                         ///< The pose to copy (radians, hand::kDofs order).
  std::array<bool, hand::kDofCount> pinned{};  ///< Angles the step holds at `pose` whatever the person.
  double pinned_sd = 0.0;                      ///< SD (radians) with which a person holds the pinned angles.

  /// @brief Whether the step pins any angle.
  bool pins_any() const noexcept {
    for (bool p : pinned)
      if (p) return true;
    return false;
  }
};

/// @brief The file format's name and version (the "format" member).
inline constexpr const char* kSequenceFormat = "glovepose-calibration-sequence";
/// @brief The version this code reads and writes.
inline constexpr int kSequenceFormatVersion = 1;

/// @brief A calibration sequence: steps back to back from t = 0.
class Sequence {
 public:
  /// @brief A sequence of `steps`; `settle_seconds` is the time after a step starts before its frames
  /// count as holding the pose (the user reads, reacts and moves). Throws glovepose::Error for no
  /// steps, a non-positive or non-finite duration, settle_seconds outside [0, the shortest step), or
  /// a pose outside the joint limits.
  Sequence(std::string id, std::vector<Step> steps, double settle_seconds)
      : id_(std::move(id)), steps_(std::move(steps)), settle_(settle_seconds) {
    if (steps_.empty()) throw Error("calibration sequence '" + id_ + "': no steps, expected at least one");
    const hand::JointLimits limits;
    for (const Step& s : steps_) {
      if (!(s.seconds > 0.0) || !std::isfinite(s.seconds))
        throw Error("calibration sequence '" + id_ + "', step '" + s.name + "': " + std::to_string(s.seconds) +
                    " s, expected a finite duration > 0");
      if (!(settle_ >= 0.0) || !(settle_ < s.seconds))
        throw Error("calibration sequence '" + id_ + "', step '" + s.name + "': settle time " + std::to_string(settle_) +
                    " s, expected 0 <= settle < the step's " + std::to_string(s.seconds) + " s");
      if (!(s.pinned_sd >= 0.0) || !std::isfinite(s.pinned_sd))
        throw Error("calibration sequence '" + id_ + "', step '" + s.name + "': pinned_sd, expected a finite value >= 0");
      for (std::size_t d = 0; d < hand::kDofCount; ++d)
        if (!(s.pose[d] >= limits.min()[d] - 1e-6 && s.pose[d] <= limits.max()[d] + 1e-6))  // slack: angles stored to 1e-6 degree
          throw Error("calibration sequence '" + id_ + "', step '" + s.name + "': " + hand::kDofs[d].name + " = " +
                      std::to_string(s.pose[d] / core::kRadiansPerDegree) + " degrees, expected within the joint limits");
      total_ += s.seconds;
    }
  }

  /// @brief Reads a sequence file (docs/calibration.md). Throws glovepose::Error naming the file.
  static Sequence read(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw Error("calibration sequence '" + path + "': cannot open it, expected a readable file");
    std::stringstream text;
    text << file.rdbuf();
    return parse(text.str(), path);
  }

  /// @brief Parses the JSON text of a sequence file; `source` names it in messages.
  static Sequence parse(const std::string& text, const std::string& source) {
    io::json::Value root;
    try {
      root = io::json::parse(text);
    } catch (const Error& e) {
      throw Error("calibration sequence '" + source + "': " + e.what());
    }
    return from_json(root, source);
  }

  /// @brief A sequence from a parsed JSON object (the file's top level, or a member of another file).
  static Sequence from_json(const io::json::Value& root, const std::string& source) {
    using io::json::Value;
    const io::json::Fields f("calibration sequence '" + source + "': ");
    const auto fail = [&](const std::string& what) { return f.fail(what); };
    f.format(root, kSequenceFormat, kSequenceFormatVersion);
    const std::string id = f.string(root, "id", "the top level");
    const double settle = f.number(root, "settle_seconds", "the top level");
    std::vector<Step> steps;
    for (const Value& item : f.array(root, "steps", "the top level")) {
      const std::string where = "step " + std::to_string(steps.size());
      if (!item.is_object()) throw fail(where + " is " + io::json::describe(item) + ", expected an object");
      Step s;
      s.name = f.string(item, "name", where);
      s.instruction = f.string(item, "instruction", where);
      s.seconds = f.number(item, "seconds", where);
      const Value& pose = f.object(item, "pose_degrees", where);
      std::array<bool, hand::kDofCount> seen{};
      for (const auto& [name, value] : pose.items()) {
        const std::size_t d = dof_or_fail(name, where, fail);
        if (!value.is_number()) throw fail(where + ": pose_degrees." + name + " is " + io::json::describe(value) + ", expected a number");
        seen[d] = true;
        s.pose[d] = value.get<double>() * core::kRadiansPerDegree;
      }
      for (std::size_t d = 0; d < hand::kDofCount; ++d)
        if (!seen[d]) throw fail(where + ": pose_degrees lacks " + std::string(hand::kDofs[d].name) + ", expected all 25 angles");
      if (const Value* pinned = io::json::Fields::find(item, "pinned")) {
        if (!pinned->is_array()) throw fail(where + ": 'pinned' is " + io::json::describe(*pinned) + ", expected an array of DoF names");
        for (const Value& name : *pinned) {
          if (!name.is_string()) throw fail(where + ": 'pinned' holds " + io::json::describe(name) + ", expected DoF names");
          s.pinned[dof_or_fail(name.get<std::string>(), where, fail)] = true;
        }
        s.pinned_sd = f.number(item, "pinned_sd_degrees", where) * core::kRadiansPerDegree;
      }
      steps.push_back(std::move(s));
    }
    try {
      return Sequence(id, std::move(steps), settle);
    } catch (const Error& e) {
      throw f.fail(e.what());
    }
  }

  /// @brief The JSON text of the sequence (read() reads it back; angles to 1e-6 degree).
  std::string to_json() const {
    std::ostringstream out;
    out.precision(10);
    out << "{\n  \"format\": " << io::json::quote(kSequenceFormat) << ",\n  \"version\": " << kSequenceFormatVersion
        << ",\n  \"id\": " << io::json::quote(id_) << ",\n  \"settle_seconds\": " << settle_ << ",\n  \"steps\": [\n";
    for (std::size_t i = 0; i < steps_.size(); ++i) {
      const Step& s = steps_[i];
      out << "    {\n      \"name\": " << io::json::quote(s.name) << ",\n      \"instruction\": " << io::json::quote(s.instruction)
          << ",\n      \"seconds\": " << s.seconds << ",\n      \"pose_degrees\": {";
      for (std::size_t d = 0; d < hand::kDofCount; ++d)
        out << (d ? "," : "") << (d % 4 == 0 ? "\n        " : " ") << io::json::quote(hand::kDofs[d].name) << ": "
            << std::round(s.pose[d] / core::kRadiansPerDegree * 1e6) / 1e6;
      out << "\n      }";
      if (s.pins_any()) {
        out << ",\n      \"pinned\": [";
        bool first = true;
        for (std::size_t d = 0; d < hand::kDofCount; ++d)
          if (s.pinned[d]) {
            out << (first ? "" : ", ") << io::json::quote(hand::kDofs[d].name);
            first = false;
          }
        out << "],\n      \"pinned_sd_degrees\": " << s.pinned_sd / core::kRadiansPerDegree;
      }
      out << "\n    }" << (i + 1 < steps_.size() ? "," : "") << "\n";
    }
    out << "  ]\n}\n";
    return out.str();
  }

  /// @brief The sequence's name.
  const std::string& id() const noexcept { return id_; }
  /// @brief The steps in order.
  const std::vector<Step>& steps() const noexcept { return steps_; }
  /// @brief Seconds after a step's start before its frames count as holding the pose.
  double settle_seconds() const noexcept { return settle_; }
  /// @brief Length of the whole sequence (s).
  double total_seconds() const noexcept { return total_; }
  /// @brief Start time (s) of step `i`.
  double step_start(std::size_t i) const noexcept {
    double t = 0.0;
    for (std::size_t k = 0; k < i && k < steps_.size(); ++k) t += steps_[k].seconds;
    return t;
  }
  /// @brief The step under way at `t` seconds since the sequence started; -1 before 0 or after the end.
  GLOVEPOSE_REALTIME int step_at(double t) const noexcept {
    if (!(t >= 0.0)) return -1;
    double end = 0.0;
    for (std::size_t i = 0; i < steps_.size(); ++i) {
      end += steps_[i].seconds;
      if (t < end) return static_cast<int>(i);
    }
    return -1;
  }
  /// @brief Whether at `t` the user holds the pose of the step under way (past its settle time).
  GLOVEPOSE_REALTIME bool holding_at(double t) const noexcept {
    const int i = step_at(t);
    return i >= 0 && t - step_start(static_cast<std::size_t>(i)) >= settle_;
  }

 private:
  template <typename Fail>
  static std::size_t dof_or_fail(const std::string& name, const std::string& where, const Fail& fail) {
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      if (name == hand::kDofs[d].name) return d;
    throw fail(where + ": '" + name + "' is not a DoF name, expected one of hand::kDofs (e.g. index_base_flexion)");
  }

  std::string id_;
  std::vector<Step> steps_;
  double settle_ = 0.0;
  double total_ = 0.0;
};

}  // namespace glovepose::calibration
