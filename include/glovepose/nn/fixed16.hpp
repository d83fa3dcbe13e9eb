/// @file fixed16.hpp
/// @brief Fixed16 weight codes (WeightStorage::Fixed16): 16 bits per weight, one scale per output
/// channel, widened to float by one integer instruction for half the weights and two for the
/// other half, where binary16 needs the conversion unit (`vcvtph2ps`, twice an FMA's issue slot on
/// the development machine; docs/performance.md).
///
/// Codes are kept in pair layout (kernels/weight_load.hpp): 32-bit word j of a group holds the
/// code of its low column in bits 0..15 and of its high column in bits 16..31. The kernels do not
/// multiply by the weight but by the code's *level* v, a float in [1, 2) made by placing bits
/// under the exponent of 1.0:
///   low column:   v = 1 + low / 2^16          bits 0x3F800000 | ((word << 7) & 0x7FFFFF)
///   high column:  v = 1 + (word >> 9) / 2^23  bits 0x3F800000 | (word >> 9), one double shift
/// The high level thus carries the low code's top 7 bits below its own 16; the encoder chooses the
/// high code knowing them, so both levels are within half a step (2^-17) of their targets.
///
/// The weight is scale * (v - kFixed16Offset). A layer accumulates acc = sum of v * x over its
/// inputs x and finishes each output as scale * (acc - kFixed16Offset * sum of x) + bias: one
/// multiply per output instead of one per weight. The offset costs accuracy only through the
/// accumulation's rounding (relative 2^-24 of a sum about as large as the inputs'); the codes'
/// own rounding is at most 2^-16 of the channel's largest weight.
#pragma once

#include <cmath>
#include <cstdint>

#include "../io/half.hpp"

namespace glovepose::nn {

/// @brief The level that codes weight 0: weight = scale * (level - kFixed16Offset).
inline constexpr float kFixed16Offset = 1.5f;

/// @brief Largest |weight| / scale: codes stay within 1..65535 (fixed16_scale()).
inline constexpr double kFixed16Range = 32767.0 / 65536.0;

/// @brief Level of a word's low code: 1 + low / 2^16.
inline float fixed16_low_level(std::uint32_t word) noexcept { return io::bits_float(0x3F800000u | ((word << 7) & 0x007FFFFFu)); }

/// @brief Level of a word's high code: 1 + (word >> 9) / 2^23 (the high code and the low code's top 7 bits).
inline float fixed16_high_level(std::uint32_t word) noexcept { return io::bits_float(0x3F800000u | (word >> 9)); }

/// @brief The scale of an output channel whose largest |weight| is `largest` (0 for an all-zero channel).
inline double fixed16_scale(double largest) noexcept { return largest / kFixed16Range; }

/// @brief The word coding weights `low` and `high`, each given as weight / scale (within
/// +-kFixed16Range): levels within 2^-17 of 1.5 + weight / scale.
inline std::uint32_t fixed16_encode_pair(double low, double high) noexcept {
  const auto code = [](double units) {
    const double r = std::nearbyint(units);
    return static_cast<std::uint32_t>(r < 0.0 ? 0.0 : (r > 65535.0 ? 65535.0 : r));
  };
  const std::uint32_t lo = code((low + kFixed16Offset - 1.0) * 65536.0);
  // The high level is 1 + (hi * 128 + (lo >> 9)) / 2^23: choose hi for what lo leaves below it.
  const std::uint32_t hi = code(((high + kFixed16Offset - 1.0) * 8388608.0 - static_cast<double>(lo >> 9)) / 128.0);
  return hi << 16 | lo;
}

/// @brief Finishes one output row of a product of levels: row[c] = scale[c] * (row[c] -
/// kFixed16Offset * input_sum) + bias[c] for c < count, `input_sum` the sum of the inputs the row met.
inline void finish_fixed16_row(float* row, int count, const float* scale, const float* bias, float input_sum) noexcept {
  const float offset = kFixed16Offset * input_sum;
  for (int c = 0; c < count; ++c) row[c] = scale[c] * (row[c] - offset) + bias[c];
}

}  // namespace glovepose::nn
