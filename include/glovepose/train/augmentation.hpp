/// @file augmentation.hpp
/// @brief Input augmentation for training: each training frame's calibrated cells perturbed as a
/// new user's calibration would leave them. Min-max calibration maps a cell's range to [-1, 1]; a
/// range estimated slightly wrong turns a cell's value x into (1 + g) x + o, and each reading
/// carries noise n. Drawn afresh for every frame of every batch (a network sees frames one at a
/// time, so a per-frame draw is a per-user draw): g, o, n normal with the configured deviations.
#pragma once

#include <string>
#include <utility>

#include "../config.hpp"
#include "../core/random.hpp"

namespace glovepose::train {

/// @brief Standard deviations of the perturbation, in normalised cell units (the calibrated range is 2).
struct Augmentation {
  double gain = 0.0;    ///< Relative scale error of a cell's calibrated range.
  double offset = 0.0;  ///< Shift of a cell's calibrated range.
  double noise = 0.0;   ///< Per-reading noise.

  /// @brief Whether any perturbation is drawn.
  bool active() const noexcept { return gain > 0.0 || offset > 0.0 || noise > 0.0; }

  /// @brief Throws glovepose::Error unless every deviation is finite and in 0..1.
  void validate() const {
    for (const auto& [name, v] : {std::pair<const char*, double>{"gain", gain}, {"offset", offset}, {"noise", noise}})
      if (!(v >= 0.0 && v <= 1.0))
        throw Error(std::string("augmentation ") + name + " deviation " + std::to_string(v) + ", expected 0..1 (normalised cell units)");
  }
};

/// @brief Perturbs `frames` rows of `cells` calibrated values in place: x -> (1 + g) x + o + n per
/// value, g, o, n drawn from `rng` with the deviations of `augmentation`.
inline void augment(float* x, long frames, int cells, const Augmentation& augmentation, core::Rng& rng) noexcept {
  if (!augmentation.active()) return;
  for (long i = 0; i < frames * cells; ++i) {
    const double g = augmentation.gain * rng.normal(), o = augmentation.offset * rng.normal(), n = augmentation.noise * rng.normal();
    x[i] = static_cast<float>((1.0 + g) * x[i] + o + n);
  }
}

}  // namespace glovepose::train
