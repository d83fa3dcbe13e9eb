/// @file world.hpp
/// @brief Named simulated worlds: the settings of every effect that makes a simulated capture as hard
/// as some real one. "clean" is the glove, people and readout of docs/simulator.md with labels equal
/// to the truth; "tracked" adds the reference tracker of sim/tracker.hpp; "worn" adds to that the
/// wear and material effects (glove.hpp WearConfig, recorder.hpp GloveMaterial). Their parameters are
/// assumptions, not yet fitted to the paper's numbers. One table: a world is found by its name, and
/// one table of effects: each can be switched back to the clean world's for an ablation.
#pragma once

#include <array>
#include <cstddef>
#include <string>

#include "../config.hpp"
#include "glove.hpp"
#include "recorder.hpp"
#include "tracker.hpp"

namespace glovepose::sim {

/// @brief A simulated world: its name and the settings of its effects.
struct World {
  const char* name = "clean";  ///< Stable name (dataset metadata "world", `glovepose simulate --world`).
  const char* summary = "";    ///< One line for --help and reports.
  TrackerConfig tracker{};     ///< The reference tracker that labels the frames.
  WearConfig wear{};           ///< How the glove sits and moves on the hand; how gloves differ.
  GloveMaterial material{};    ///< Hysteresis and drift of the sensor material.
  std::string ablated;         ///< Effects switched back to the clean world's by without(), comma-separated.
};

/// @brief Every named world; the first is the default.
inline const std::array<World, 3>& worlds() {
  static const std::array<World, 3> table = [] {
    World clean{"clean", "labels are the true angles", TrackerConfig{}, WearConfig{}, GloveMaterial{}, ""};
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
    World tracked{"tracked", "labels from a simulated depth-camera tracker (assumed parameters)", t, WearConfig{}, GloveMaterial{}, ""};
    WearConfig w;
    w.donning_shift = 3.0;
    w.cell_shift = 2.0;
    w.pre_stretch_spread = 0.04;
    w.slip_sd = 1.5;
    w.slip_time = 600.0;
    w.loose_gain = 1.0;
    w.placement_sd = 1.0;
    GloveMaterial m;
    m.hysteresis_share = 0.2;
    m.hysteresis_width = 0.01;
    m.drift_rate = 0.005;
    m.warmup_gain = 0.02;
    m.warmup_time = 300.0;
    World worn{"worn", "tracked, and a glove that shifts, slips, drifts and differs between copies (assumed parameters)", t, w, m, ""};
    return std::array<World, 3>{clean, tracked, worn};
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

/// @brief The effects a world can switch back to the clean world's settings, for ablations.
enum class Effect : std::uint8_t { Tracker, Donning, Slip, LooseFit, Placement, Hysteresis, Drift, Count };

/// @brief Effect names (`glovepose simulate --without NAME`), in enum order.
inline constexpr std::array<const char*, static_cast<std::size_t>(Effect::Count)> kEffectNames{
    "tracker", "donning", "slip", "loose_fit", "placement", "hysteresis", "drift"};
static_assert(kEffectNames.size() == static_cast<std::size_t>(Effect::Count), "one name per effect");

/// @brief The effect called `name`; throws glovepose::Error naming the known effects.
inline Effect effect_named(const std::string& name) {
  std::string known;
  for (std::size_t i = 0; i < kEffectNames.size(); ++i) {
    if (name == kEffectNames[i]) return static_cast<Effect>(i);
    known += (known.empty() ? "" : ", ") + std::string(kEffectNames[i]);
  }
  throw Error("unknown effect '" + name + "', expected one of " + known);
}

/// @brief `world` with `effect` set back to the clean world's settings, named in World::ablated.
inline World without(World world, Effect effect) {
  const World& clean = worlds().front();
  const std::string name = kEffectNames[static_cast<std::size_t>(effect)];
  if (("," + world.ablated + ",").find("," + name + ",") == std::string::npos) world.ablated += (world.ablated.empty() ? "" : ",") + name;
  switch (effect) {
    case Effect::Tracker: world.tracker = clean.tracker; break;
    case Effect::Donning:
      world.wear.donning_shift = clean.wear.donning_shift;
      world.wear.cell_shift = clean.wear.cell_shift;
      world.wear.pre_stretch_spread = clean.wear.pre_stretch_spread;
      break;
    case Effect::Slip: world.wear.slip_sd = clean.wear.slip_sd; break;
    case Effect::LooseFit: world.wear.loose_gain = clean.wear.loose_gain; break;
    case Effect::Placement: world.wear.placement_sd = clean.wear.placement_sd; break;
    case Effect::Hysteresis:
      world.material.hysteresis_share = clean.material.hysteresis_share;
      world.material.hysteresis_width = clean.material.hysteresis_width;
      break;
    case Effect::Drift:
      world.material.drift_rate = clean.material.drift_rate;
      world.material.warmup_gain = clean.material.warmup_gain;
      break;
    case Effect::Count: break;
  }
  return world;
}

}  // namespace glovepose::sim
