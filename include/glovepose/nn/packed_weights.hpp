/// @file packed_weights.hpp
/// @brief A layer's weights, already in the kernels' layout (column panels, pair layout for BF16 and
/// Fixed16), encoded in the storage chosen at load. Packing (where each weight goes) is the
/// network's business; this file only turns packed floats into stored values and says which array
/// the kernels read.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "../config.hpp"
#include "fixed16.hpp"
#include "../io/half.hpp"
#include "kernels/weight_load.hpp"
#include "tensor.hpp"
#include "weight_storage.hpp"

namespace glovepose::nn {

/// @brief One layer's packed weights; exactly one of the arrays is filled.
struct PackedWeights {
  AlignedVector<float> w32;                // F32
  AlignedVector<std::uint16_t> w16;        // F16 bits
  AlignedVector<kernels::BFloat16> wbf16;  // BF16, pair layout
  AlignedVector<kernels::Fixed16> wfx16;   // Fixed16 codes, pair layout (fixed16.hpp)
  AlignedVector<float> fixed_scale;        // Fixed16: one scale per (padded) output channel

  /// @brief Whether the weights are Fixed16 codes (the layer must finish with fixed16 scales).
  bool fixed16() const noexcept { return !wfx16.empty(); }
  /// @brief Bytes of one stored weight: 4 for F32, 2 otherwise.
  std::size_t weight_size() const noexcept { return w32.empty() ? sizeof(std::uint16_t) : sizeof(float); }
  /// @brief Bytes the kernels stream to read every weight once (Fixed16 scales included).
  std::size_t bytes() const noexcept {
    return w32.size() * sizeof(float) + w16.size() * sizeof(std::uint16_t) + wbf16.size() * sizeof(kernels::BFloat16) +
           wfx16.size() * sizeof(kernels::Fixed16) + fixed_scale.size() * sizeof(float);
  }
  /// @brief Calls `use(pointer)` with the filled array's data (its type picks the kernels' widening).
  template <typename Use>
  void visit(Use&& use) const noexcept {
    if (!w32.empty())
      use(w32.data());
    else if (!w16.empty())
      use(w16.data());
    else if (!wbf16.empty())
      use(wbf16.data());
    else
      use(wfx16.data());
  }
};

/// @brief Encodes `packed` (floats in the kernels' layout) as `storage`. Fixed16 needs, per packed
/// slot, its output channel `column_of[i]` in 0..channels (padding included) and an even size.
/// Throws glovepose::Error, naming `what`, for a weight the storage cannot represent (a weight
/// beyond binary16's range, or a Fixed16 scale beyond float's), suggesting F32.
inline PackedWeights encode_weights(const std::vector<float>& packed, WeightStorage storage, const std::vector<int>& column_of,
                                    int channels, const std::string& what) {
  const bool fixed = storage == WeightStorage::Fixed16;
  const float limit = storage == WeightStorage::F16 ? 65504.0f
                      : fixed                       ? static_cast<float>(std::numeric_limits<float>::max() * kFixed16Range)
                                                    : std::numeric_limits<float>::max();
  for (float v : packed)
    if (!(std::abs(v) <= limit))
      throw Error(what + " has a weight of " + std::to_string(v) + ", expected magnitudes up to " + std::to_string(limit) + " for " +
                  (storage == WeightStorage::F32 ? "F32" : std::string(storage_name(storage)) + " storage (load as F32 instead)"));
  PackedWeights w;
  if (storage == WeightStorage::F32) {
    w.w32.assign(packed.begin(), packed.end());
  } else if (storage == WeightStorage::F16) {
    w.w16.resize(packed.size());
    for (std::size_t i = 0; i < packed.size(); ++i) w.w16[i] = io::float_to_f16(packed[i]);
  } else if (storage == WeightStorage::BF16) {
    w.wbf16.resize(packed.size());
    for (std::size_t i = 0; i < packed.size(); ++i) {
      w.wbf16[i] = static_cast<kernels::BFloat16>(io::float_to_bf16(packed[i]));
      if (!std::isfinite(kernels::weight_value(w.wbf16[i])))  // within float range, but rounds up past bfloat16's largest
        throw Error(what + " has a weight of " + std::to_string(packed[i]) + ", too large for BF16 storage (load as F32 instead)");
    }
  } else {
    // Per output channel the scale that maps its largest |weight| to the largest code, then each
    // 32-bit word's two codes (fixed16.hpp).
    if (column_of.size() != packed.size() || packed.size() % 2 != 0)
      throw Error(what + ": Fixed16 packing of " + std::to_string(packed.size()) + " weights with " + std::to_string(column_of.size()) +
                  " channel indices, expected an even count and one index per weight");
    std::vector<double> largest(static_cast<std::size_t>(channels), 0.0);
    for (std::size_t i = 0; i < packed.size(); ++i) {
      double& m = largest[static_cast<std::size_t>(column_of[i])];
      m = std::max(m, static_cast<double>(std::abs(packed[i])));
    }
    w.fixed_scale.assign(largest.size(), 0.0f);
    for (std::size_t c = 0; c < largest.size(); ++c) w.fixed_scale[c] = static_cast<float>(fixed16_scale(largest[c]));
    const auto units = [&](std::size_t i) {  // against the float scale the layer multiplies by
      const double s = w.fixed_scale[static_cast<std::size_t>(column_of[i])];
      return s > 0.0 ? packed[i] / s : 0.0;
    };
    w.wfx16.resize(packed.size());
    for (std::size_t i = 0; i + 1 < packed.size(); i += 2) {
      const std::uint32_t word = fixed16_encode_pair(units(i), units(i + 1));
      w.wfx16[i] = static_cast<kernels::Fixed16>(word & 0xFFFFu);
      w.wfx16[i + 1] = static_cast<kernels::Fixed16>(word >> 16);
    }
  }
  return w;
}

}  // namespace glovepose::nn
