/// @file world.hpp
/// @brief Named simulated worlds: the settings of every effect that makes a simulated capture as hard
/// as some real one. "clean" is the glove, people and readout of docs/simulator.md with labels equal
/// to the truth; "tracked" adds the reference tracker of sim/tracker.hpp; "worn" adds to that the
/// wear and material effects (glove.hpp WearConfig, recorder.hpp GloveMaterial), with assumed
/// parameters; "fitted" is "worn" with parameters fitted openly to the paper's Table 1. One table: a
/// world is found by its name; one table of effects: each can be switched back to the clean world's
/// for an ablation; one table of parameters: each can be set by name (`glovepose simulate --set`),
/// for fitting a world openly.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <string>
#include <utility>

#include "../config.hpp"
#include "glove.hpp"
#include "recorder.hpp"
#include "subject.hpp"
#include "tracker.hpp"

namespace glovepose::sim {

/// @brief A simulated world: its name and the settings of its effects.
struct World {
  const char* name = "clean";  ///< Stable name (dataset metadata "world", `glovepose simulate --world`).
  const char* summary = "";    ///< One line for --help and reports.
  TrackerConfig tracker{};     ///< The reference tracker that labels the frames.
  WearConfig wear{};           ///< How the glove sits and moves on the hand; how gloves differ.
  GloveMaterial material{};    ///< Hysteresis and drift of the sensor material.
  PeopleConfig people{};       ///< How the people differ and perform the calibration.
  std::string ablated;         ///< Effects switched back to the clean world's by without(), comma-separated.
  std::string settings;        ///< Parameters set by with(), "name=value" comma-separated.
};

/// @brief A world's parameter that can be set by name: "group.field" as in the tables of
/// docs/simulator.md.
struct WorldParameter {
  const char* name;
  double& (*field)(World&);
  double minimum = 0.0;  ///< Smallest value that means something (a hand's size in mm is not 0).
};

/// @brief Every parameter a world's effects have, by name.
inline const std::array<WorldParameter, 40>& world_parameters() {
#define GLOVEPOSE_WORLD_PARAMETER_AT_LEAST(group, field, minimum) \
  WorldParameter { #group "." #field, [](World& w) -> double& { return w.group.field; }, minimum }
#define GLOVEPOSE_WORLD_PARAMETER(group, field) GLOVEPOSE_WORLD_PARAMETER_AT_LEAST(group, field, 0.0)
  static const std::array<WorldParameter, 40> table{
      GLOVEPOSE_WORLD_PARAMETER(tracker, flexion_sd),
      GLOVEPOSE_WORLD_PARAMETER(tracker, abduction_sd),
      GLOVEPOSE_WORLD_PARAMETER(tracker, twist_sd),
      GLOVEPOSE_WORLD_PARAMETER(tracker, thumb_factor),
      GLOVEPOSE_WORLD_PARAMETER(tracker, occlusion_gain),
      GLOVEPOSE_WORLD_PARAMETER(tracker, correlation_time),
      GLOVEPOSE_WORLD_PARAMETER(tracker, subject_bias_sd),
      GLOVEPOSE_WORLD_PARAMETER(tracker, session_bias_sd),
      GLOVEPOSE_WORLD_PARAMETER(tracker, snap_rate),
      GLOVEPOSE_WORLD_PARAMETER(tracker, freeze_rate),
      GLOVEPOSE_WORLD_PARAMETER(tracker, failure_seconds),
      GLOVEPOSE_WORLD_PARAMETER(tracker, snap_abduction),
      GLOVEPOSE_WORLD_PARAMETER(tracker, collision_allowance),
      GLOVEPOSE_WORLD_PARAMETER(tracker, latency),
      GLOVEPOSE_WORLD_PARAMETER(tracker, smoothing),
      GLOVEPOSE_WORLD_PARAMETER(tracker, size_power),
      GLOVEPOSE_WORLD_PARAMETER(tracker, subject_noise_spread),
      GLOVEPOSE_WORLD_PARAMETER(wear, donning_shift),
      GLOVEPOSE_WORLD_PARAMETER(wear, cell_shift),
      GLOVEPOSE_WORLD_PARAMETER(wear, pre_stretch_spread),
      GLOVEPOSE_WORLD_PARAMETER(wear, slip_sd),
      GLOVEPOSE_WORLD_PARAMETER(wear, slip_time),
      GLOVEPOSE_WORLD_PARAMETER(wear, loose_gain),
      GLOVEPOSE_WORLD_PARAMETER(wear, placement_sd),
      GLOVEPOSE_WORLD_PARAMETER(wear, size_coupling),
      GLOVEPOSE_WORLD_PARAMETER(wear, loose_slack),
      GLOVEPOSE_WORLD_PARAMETER_AT_LEAST(wear, relaxed_length, 100.0),
      GLOVEPOSE_WORLD_PARAMETER_AT_LEAST(wear, relaxed_width, 50.0),
      GLOVEPOSE_WORLD_PARAMETER(wear, length_misplacement),
      GLOVEPOSE_WORLD_PARAMETER(wear, neighbour_hold),
      GLOVEPOSE_WORLD_PARAMETER(wear, slide_share),
      GLOVEPOSE_WORLD_PARAMETER_AT_LEAST(wear, stick_angle, 1.0),
      GLOVEPOSE_WORLD_PARAMETER(material, hysteresis_share),
      GLOVEPOSE_WORLD_PARAMETER(material, hysteresis_width),
      GLOVEPOSE_WORLD_PARAMETER(material, drift_rate),
      GLOVEPOSE_WORLD_PARAMETER(material, warmup_gain),
      GLOVEPOSE_WORLD_PARAMETER(material, warmup_time),
      GLOVEPOSE_WORLD_PARAMETER(people, skin_spread),
      GLOVEPOSE_WORLD_PARAMETER(people, calibration_shortfall),
      GLOVEPOSE_WORLD_PARAMETER(people, independent_fingers)};
#undef GLOVEPOSE_WORLD_PARAMETER
#undef GLOVEPOSE_WORLD_PARAMETER_AT_LEAST
  return table;
}

/// @brief `world` with the parameter `name` set to `value`, recorded in World::settings. Throws
/// glovepose::Error for an unknown name (naming the known ones) or a non-finite value below the
/// parameter's minimum (every parameter is a size, a share, a rate or a time).
inline World with(World world, const std::string& name, double value) {
  std::string known;
  for (const WorldParameter& p : world_parameters()) {
    if (name != p.name) {
      known += (known.empty() ? "" : ", ") + std::string(p.name);
      continue;
    }
    if (!(value >= p.minimum) || !std::isfinite(value)) {
      char minimum[32];
      std::snprintf(minimum, sizeof minimum, "%g", p.minimum);
      throw Error("world parameter " + name + " = " + std::to_string(value) + ", expected a finite value >= " + minimum);
    }
    p.field(world) = value;
    char text[64];
    std::snprintf(text, sizeof text, "%.6g", value);
    world.settings += (world.settings.empty() ? "" : ",") + name + "=" + text;
    return world;
  }
  throw Error("unknown world parameter '" + name + "', expected one of " + known);
}

/// @brief `world` with an assignment "name=value" applied (`glovepose simulate --set`); throws
/// glovepose::Error for text that is not one.
inline World with(World world, const std::string& assignment) {
  const std::size_t equals = assignment.find('=');
  const std::string value = equals == std::string::npos ? "" : assignment.substr(equals + 1);
  char* end = nullptr;
  const double number = std::strtod(value.c_str(), &end);
  if (equals == std::string::npos || value.empty() || *end != '\0')
    throw Error("world setting '" + assignment + "', expected NAME=NUMBER (e.g. people.skin_spread=0.5)");
  return with(std::move(world), assignment.substr(0, equals), number);
}

/// @brief A named world: `base` with the parameters `values` set by their world_parameters() names,
/// the vocabulary of `glovepose simulate --set` and of docs/simulator.md's tables (its own values,
/// so World::settings stays empty).
inline World named_world(const World& base, const char* name, const char* summary,
                         std::initializer_list<std::pair<const char*, double>> values) {
  World world = base;
  world.name = name;
  world.summary = summary;
  for (const auto& [parameter, value] : values) world = with(std::move(world), parameter, value);
  world.settings.clear();
  return world;
}

/// @brief Every named world; the first, "clean", is the physics the library's tests measure against.
inline const std::array<World, 4>& worlds() {
  static const std::array<World, 4> table = [] {
    const World clean{"clean", "labels are the true angles", TrackerConfig{}, WearConfig{}, GloveMaterial{}, PeopleConfig{}, "", ""};
    const World tracked = named_world(clean, "tracked", "labels from a simulated depth-camera tracker (assumed parameters)",
                                      {{"tracker.flexion_sd", 3.5},
                                       {"tracker.abduction_sd", 2.5},
                                       {"tracker.twist_sd", 1.5},
                                       {"tracker.thumb_factor", 1.5},
                                       {"tracker.occlusion_gain", 1.0},
                                       {"tracker.correlation_time", 0.5},
                                       {"tracker.subject_bias_sd", 2.0},
                                       {"tracker.session_bias_sd", 1.5},
                                       {"tracker.snap_rate", 2.0},
                                       {"tracker.freeze_rate", 2.0},
                                       {"tracker.failure_seconds", 0.5},
                                       {"tracker.collision_allowance", 20.0},
                                       {"tracker.latency", 1.0 / 60.0},
                                       {"tracker.smoothing", 0.02}});
    const World worn =
        named_world(tracked, "worn", "tracked, and a glove that shifts, slips, drifts and differs between copies (assumed parameters)",
                    {{"wear.donning_shift", 3.0},
                     {"wear.cell_shift", 2.0},
                     {"wear.pre_stretch_spread", 0.04},
                     {"wear.slip_sd", 1.5},
                     {"wear.slip_time", 600.0},
                     {"wear.loose_gain", 1.0},
                     {"wear.placement_sd", 1.0},
                     {"material.hysteresis_share", 0.2},
                     {"material.hysteresis_width", 0.01},
                     {"material.drift_rate", 0.005},
                     {"material.warmup_gain", 0.02},
                     {"material.warmup_time", 300.0}});
    // The parameters fitted to the paper's Table 1 and outlier share (docs/simulator.md, "Fitting a
    // world to the paper"): the same as `--world worn --set` with these values.
    const World fitted = named_world(worn, "fitted", "worn, with parameters fitted to the paper's Table 1 and outlier share",
                                     {{"tracker.subject_bias_sd", 5.0},
                                      {"wear.pre_stretch_spread", 0.01},
                                      {"wear.size_coupling", 0.5},
                                      {"material.drift_rate", 0.01},
                                      {"people.skin_spread", 0.7},
                                      {"people.calibration_shortfall", 0.5},
                                      {"people.independent_fingers", 0.4}});
    return std::array<World, 4>{clean, tracked, worn, fitted};
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

/// @brief The simulator's default world (`glovepose simulate`, the demo, the viewer's simulated user):
/// the world fitted to the paper's measurements, so that every figure the tools print is from the
/// world as hard as the paper's. sim::CorpusConfig itself starts from the clean world.
inline const World& default_world() { return world_named("fitted"); }

/// @brief The effects a world can switch back to the clean world's settings, for ablations.
enum class Effect : std::uint8_t { Tracker, Donning, Slip, LooseFit, Placement, SizeCoupling, Hysteresis, Drift, Skin, Shortfall, Independent, Count };

/// @brief Effect names (`glovepose simulate --without NAME`), in enum order.
inline constexpr std::array<const char*, static_cast<std::size_t>(Effect::Count)> kEffectNames{
    "tracker", "donning", "slip", "loose_fit", "placement", "size_coupling", "hysteresis", "drift", "skin", "shortfall", "independent"};
static_assert(kEffectNames.size() == static_cast<std::size_t>(Effect::Count), "one name per effect");

/// @brief The parameters each effect switches back (world_parameters() names, comma-separated; a
/// group name ending in '.' is all of that group's parameters), in enum order.
inline constexpr std::array<const char*, static_cast<std::size_t>(Effect::Count)> kEffectParameters{
    "tracker.",
    "wear.donning_shift,wear.cell_shift,wear.pre_stretch_spread",
    "wear.slip_sd",
    "wear.loose_gain",
    "wear.placement_sd",
    "wear.size_coupling",
    "material.hysteresis_share,material.hysteresis_width",
    "material.drift_rate,material.warmup_gain",
    "people.skin_spread",
    "people.calibration_shortfall",
    "people.independent_fingers"};

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
  World clean = worlds().front();  // a copy: WorldParameter::field takes a World it may write
  const std::string name = kEffectNames[static_cast<std::size_t>(effect)];
  if (("," + world.ablated + ",").find("," + name + ",") == std::string::npos) world.ablated += (world.ablated.empty() ? "" : ",") + name;
  const std::string listed = "," + std::string(kEffectParameters[static_cast<std::size_t>(effect)]) + ",";
  for (const WorldParameter& p : world_parameters()) {
    const std::string parameter = p.name, group = parameter.substr(0, parameter.find('.') + 1);
    if (listed.find("," + parameter + ",") != std::string::npos || listed.find("," + group + ",") != std::string::npos)
      p.field(world) = p.field(clean);
  }
  return world;
}

}  // namespace glovepose::sim
