/// @file world.hpp
/// @brief Named simulated worlds: the settings of every effect that makes a simulated capture as hard
/// as some real one. "clean" is the glove, people and readout of docs/simulator.md with labels equal
/// to the truth; "tracked" adds the reference tracker of sim/tracker.hpp (its parameters are
/// assumptions, not yet fitted to the paper's numbers). One table: a world is found by its name.
#pragma once

#include <array>
#include <string>

#include "../config.hpp"
#include "tracker.hpp"

namespace glovepose::sim {

/// @brief A simulated world: its name and the settings of its effects.
struct World {
  const char* name = "clean";  ///< Stable name (dataset metadata "world", `glovepose simulate --world`).
  const char* summary = "";    ///< One line for --help and reports.
  TrackerConfig tracker{};     ///< The reference tracker that labels the frames.
};

/// @brief Every named world; the first is the default.
inline const std::array<World, 2>& worlds() {
  static const std::array<World, 2> table = [] {
    World clean{"clean", "labels are the true angles", TrackerConfig{}};
    TrackerConfig t;
    t.flexion_sd = 3.5;
    t.abduction_sd = 2.5;
    t.twist_sd = 1.5;
    t.thumb_factor = 1.5;
    t.occlusion_gain = 1.0;
    t.correlation_time = 0.5;
    t.subject_bias_sd = 2.0;
    t.session_bias_sd = 1.5;
    t.snap_rate = 2.0;
    t.freeze_rate = 2.0;
    t.failure_seconds = 0.5;
    t.snap_abduction = 20.0;
    t.collision_allowance = 20.0;
    t.latency = 1.0 / 60.0;
    t.smoothing = 0.02;
    World tracked{"tracked", "labels from a simulated depth-camera tracker (assumed parameters)", t};
    return std::array<World, 2>{clean, tracked};
  }();
  return table;
}

/// @brief The world called `name`; throws glovepose::Error naming the known worlds.
inline const World& world_named(const std::string& name) {
  std::string known;
  for (const World& w : worlds()) {
    if (name == w.name) return w;
    known += (known.empty() ? "" : ", ") + std::string(w.name);
  }
  throw Error("unknown world '" + name + "', expected one of " + known);
}

}  // namespace glovepose::sim
