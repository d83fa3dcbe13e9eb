/// @file glove_description_fuzz.cpp
/// @brief Fuzz target: the bytes as a glove description (grid/glove_description.hpp JSON, also the
/// "glove_description" metadata of model files), through GloveDescription::from_json, the parser
/// GloveDescription::read uses after reading the file.
///
/// Invariants: bad input is refused with glovepose::Error only; an accepted description writes
/// (to_json) text that parses to an equal description, maps plausible cells to finite stretch
/// maps, and has usable settings: joint limits that JointLimits accepts (finite, min < max), a
/// median window of at least one frame, a flat rule in [0, 1), input conditioning that the
/// estimator accepts and that conditions a frame to finite values.
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <glovepose/grid/glove_description.hpp>
#include <glovepose/sensor/input_conditioning.hpp>

#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::optional<glovepose::grid::GloveDescription> glove;
  try {
    glove.emplace(glovepose::grid::GloveDescription::from_json(text));
  } catch (const glovepose::Error&) {
    return 0;
  }
  const glovepose::grid::GloveDescription again = glovepose::grid::GloveDescription::from_json(glove->to_json());
  GLOVEPOSE_FUZZ_REQUIRE(again == *glove);
  GLOVEPOSE_FUZZ_REQUIRE(glove->cell_count() >= 1 && glove->cell_count() <= glovepose::grid::kMaxGloveInputs);
  const int on_maps = glove->cell_count() - glove->map().extra_input_count();
  GLOVEPOSE_FUZZ_REQUIRE(on_maps >= 0 && on_maps <= glovepose::grid::kStretchValues);
  GLOVEPOSE_FUZZ_REQUIRE(static_cast<int>(glove->cell_names().size()) == glove->cell_count());

  const glovepose::hand::JointLimits limits = glove->joint_limits();  // throws (a finding) unless finite with min < max
  for (std::size_t d = 0; d < glovepose::hand::kDofCount; ++d) GLOVEPOSE_FUZZ_REQUIRE(limits.min()[d] < limits.max()[d]);
  GLOVEPOSE_FUZZ_REQUIRE(glove->calibration().median_frames(glove->rate_hz().value_or(60.0)) >= 1);
  GLOVEPOSE_FUZZ_REQUIRE(glove->calibration().flat_relative_range >= 0.0 && glove->calibration().flat_relative_range < 1.0);
  GLOVEPOSE_FUZZ_REQUIRE(glove->calibration().min_range_to_noise >= 0.0 && std::isfinite(glove->calibration().min_range_to_noise));

  std::vector<double> cells(static_cast<std::size_t>(glove->cell_count()));
  for (std::size_t c = 0; c < cells.size(); ++c) cells[c] = -1.0 + 2.0 * static_cast<double>(c) / static_cast<double>(cells.size());

  const std::vector<int> windows = glove->demean_frames();  // the estimator's conditioner, as it builds it
  GLOVEPOSE_FUZZ_REQUIRE(windows.empty() || windows.size() == cells.size());
  glovepose::sensor::InputConditioner conditioner(windows);  // throws (a finding) for a window it refuses
  std::vector<double> conditioned(cells.size());
  for (int frame = 0; frame < 3 && conditioner.active(); ++frame) {
    conditioner.apply(cells.data(), conditioned.data());
    for (const double v : conditioned) GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(v));
  }
  std::array<float, glovepose::grid::kStretchValues> maps{};
  GLOVEPOSE_FUZZ_REQUIRE(glove->map().to_stretch_maps(cells.data(), maps) == glovepose::Status::Ok);
  GLOVEPOSE_FUZZ_REQUIRE(glovepose::fuzz::all_finite(maps));
  for (std::size_t c = 0; c < cells.size(); ++c) {  // a cell on its slot; an extra input on none
    const glovepose::grid::Slot& slot = glove->map().cell_slots()[c];
    if (slot.on_maps()) GLOVEPOSE_FUZZ_REQUIRE(maps[static_cast<std::size_t>(slot.flat())] == static_cast<float>(cells[c]));
  }
  return 0;
}
