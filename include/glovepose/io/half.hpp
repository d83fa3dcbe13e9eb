/// @file half.hpp
/// @brief Exact conversions between float and the two 16-bit float formats of the weight file:
/// IEEE 754 binary16 ("F16") and bfloat16 ("BF16"). Round to nearest, ties to even.
#pragma once

#include <cstdint>
#include <cstring>

namespace glovepose::io {

/// @brief The bits of a float.
inline std::uint32_t float_bits(float f) noexcept {
  std::uint32_t u = 0;
  std::memcpy(&u, &f, sizeof u);
  return u;
}
/// @brief The float with these bits.
inline float bits_float(std::uint32_t u) noexcept {
  float f = 0.0f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

/// @brief bfloat16 -> float (exact: bfloat16 is the top half of a float).
inline float bf16_to_float(std::uint16_t h) noexcept { return bits_float(static_cast<std::uint32_t>(h) << 16); }

/// @brief float -> bfloat16, round to nearest even; NaN stays NaN.
inline std::uint16_t float_to_bf16(float f) noexcept {
  const std::uint32_t u = float_bits(f);
  if ((u & 0x7fffffffu) > 0x7f800000u) return static_cast<std::uint16_t>((u >> 16) | 0x40u);  // quiet NaN
  const std::uint32_t rounding = 0x7fffu + ((u >> 16) & 1u);
  return static_cast<std::uint16_t>((u + rounding) >> 16);
}

/// @brief binary16 -> float (exact, subnormals included).
inline float f16_to_float(std::uint16_t h) noexcept {
  const std::uint32_t sign = static_cast<std::uint32_t>(h & 0x8000u) << 16;
  const std::uint32_t exponent = (h >> 10) & 0x1fu;
  std::uint32_t mantissa = h & 0x3ffu;
  if (exponent == 0x1f) return bits_float(sign | 0x7f800000u | (mantissa << 13));  // inf / NaN
  if (exponent != 0) return bits_float(sign | ((exponent + 112u) << 23) | (mantissa << 13));
  if (mantissa == 0) return bits_float(sign);  // +-0
  // Subnormal: normalise.
  int e = -1;
  do {
    ++e;
    mantissa <<= 1;
  } while ((mantissa & 0x400u) == 0);
  return bits_float(sign | (static_cast<std::uint32_t>(112 - e) << 23) | ((mantissa & 0x3ffu) << 13));
}

/// @brief float -> binary16, round to nearest even; overflow gives infinity, NaN stays NaN.
inline std::uint16_t float_to_f16(float f) noexcept {
  const std::uint32_t u = float_bits(f);
  const std::uint16_t sign = static_cast<std::uint16_t>((u >> 16) & 0x8000u);
  const std::uint32_t magnitude = u & 0x7fffffffu;
  if (magnitude > 0x7f800000u) return static_cast<std::uint16_t>(sign | 0x7e00u);   // NaN
  if (magnitude >= 0x477ff000u) return static_cast<std::uint16_t>(sign | 0x7c00u);  // >= 65520: infinity
  if (magnitude >= 0x38800000u) {                                                   // normal half
    const std::uint32_t rounded = magnitude + 0xfffu + ((magnitude >> 13) & 1u);
    return static_cast<std::uint16_t>(sign | ((rounded - 0x38000000u) >> 13));
  }
  if (magnitude < 0x33000000u) return sign;  // below half the smallest subnormal: +-0
  // Subnormal half: shift the mantissa (with its implicit 1) into place, rounding to nearest even.
  const std::uint32_t exponent = magnitude >> 23;
  const std::uint32_t mantissa = (magnitude & 0x7fffffu) | 0x800000u;
  const std::uint32_t shift = 126u - exponent;  // 14..24
  const std::uint32_t half_mantissa = mantissa >> shift;
  const std::uint32_t remainder = mantissa & ((1u << shift) - 1u);
  const std::uint32_t halfway = 1u << (shift - 1u);
  const std::uint32_t round_up = remainder > halfway || (remainder == halfway && (half_mantissa & 1u));
  return static_cast<std::uint16_t>(sign | (half_mantissa + round_up));
}

}  // namespace glovepose::io
