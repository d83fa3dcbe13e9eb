/// @file weight_load.hpp
/// @brief Reading stored weights as float: F32 as is, F16 (binary16 bits) widened. The SIMD loads
/// use the hardware conversion (F16C / AVX-512F) when the compiler targets it.
#pragma once

#include <cstdint>

#include <xsimd/xsimd.hpp>

#include "../half.hpp"

#if defined(__F16C__) || defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace glovepose::nn::kernels {

/// @brief One stored weight as float.
inline float weight_value(float w) noexcept { return w; }
/// @brief One stored F16 weight as float.
inline float weight_value(std::uint16_t w) noexcept { return f16_to_float(w); }

/// @brief A SIMD batch of stored weights as floats (unaligned load).
template <typename Arch>
inline xsimd::batch<float, Arch> load_weights(const float* p) noexcept {
  return xsimd::batch<float, Arch>::load_unaligned(p);
}

/// @brief A SIMD batch of stored F16 weights as floats, converted in-register where possible.
template <typename Arch>
inline xsimd::batch<float, Arch> load_weights(const std::uint16_t* p) noexcept {
  constexpr std::size_t n = xsimd::batch<float, Arch>::size;
#if defined(__AVX512F__)
  if constexpr (n == 16)
    return xsimd::batch<float, Arch>(_mm512_cvtph_ps(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p))));
#endif
#if defined(__F16C__)
  if constexpr (n == 8)
    return xsimd::batch<float, Arch>(_mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p))));
  if constexpr (n == 4)
    return xsimd::batch<float, Arch>(_mm_cvtph_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
#endif
  alignas(64) float wide[n];
  for (std::size_t i = 0; i < n; ++i) wide[i] = f16_to_float(p[i]);
  return xsimd::batch<float, Arch>::load_aligned(wide);
}

}  // namespace glovepose::nn::kernels
