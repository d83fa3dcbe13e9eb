/// @file weight_load.hpp
/// @brief Reading stored weights as float: F32 as is, F16 (binary16 bits) widened by the hardware
/// conversion (F16C / AVX-512F) when the compiler targets it, BF16 widened by integer operations.
///
/// BF16 is the top half of a float, so widening is a 16-bit shift. Matrix weights in BF16 are
/// stored in *pair layout*: each group of 2 x lanes output columns is stored as `lanes` 32-bit
/// words, word j holding column j in its low half and column lanes + j in its high half. One load
/// then gives two vectors of weights by a shift and a mask (two plain integer operations that run
/// beside the FMAs), where `vcvtph2ps` and `vpmovzxwd` cost this core twice an FMA's issue slot
/// (docs/performance.md). Fixed16 codes (../fixed16.hpp) use the same pair layout.
#pragma once

#include <cstdint>
#include <type_traits>

#include <xsimd/xsimd.hpp>

#include "../fixed16.hpp"
#include "../../io/half.hpp"

#if defined(__F16C__) || defined(__AVX512F__) || defined(__SSE2__)
#  include <immintrin.h>
#endif

namespace glovepose::nn::kernels {

/// @brief A stored bfloat16 weight: its own type, so that overloads pick the bfloat16 widening.
enum class BFloat16 : std::uint16_t {};

/// @brief A stored Fixed16 code (../fixed16.hpp): its own type, so that overloads pick its widening.
enum class Fixed16 : std::uint16_t {};

/// @brief Whether matrices of this weight type are stored in pair layout.
template <typename W>
inline constexpr bool kPairLayout = std::is_same_v<W, BFloat16> || std::is_same_v<W, Fixed16>;

/// @brief One stored weight as float.
inline float weight_value(float w) noexcept { return w; }
/// @brief One stored F16 weight as float.
inline float weight_value(std::uint16_t w) noexcept { return io::f16_to_float(w); }
/// @brief One stored BF16 weight as float.
inline float weight_value(BFloat16 w) noexcept { return io::bf16_to_float(static_cast<std::uint16_t>(w)); }

/// @brief Stored weight `i` of an array as float (the scalar kernels' read). For Fixed16 this is
/// the code's level, which depends on the other half of its 32-bit word: `w` must start a word.
template <typename W>
inline float weight_at(const W* w, long i) noexcept {
  return weight_value(w[i]);
}
/// @brief Fixed16: the level of code `i` (../fixed16.hpp); codes 2j and 2j + 1 share a word.
inline float weight_at(const Fixed16* w, long i) noexcept {
  const long first = i & ~1L;
  const std::uint32_t word = static_cast<std::uint32_t>(w[first]) | static_cast<std::uint32_t>(w[first + 1]) << 16;
  return i == first ? fixed16_low_level(word) : fixed16_high_level(word);
}

/// @brief The slot, within its row of a pair-layout matrix, that holds column `col`: groups of
/// 2 x `lanes` columns, column lanes * h + j of a group in half h of 32-bit word j. With lanes = 1
/// this is the identity.
constexpr int paired_slot(int col, int lanes) noexcept {
  const int group = col / (2 * lanes) * (2 * lanes), j = col - group;
  return group + (j < lanes ? 2 * j : 2 * (j - lanes) + 1);
}

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
  if constexpr (n == 16) return xsimd::batch<float, Arch>(_mm512_cvtph_ps(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p))));
#endif
#if defined(__F16C__)
  if constexpr (n == 8) return xsimd::batch<float, Arch>(_mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p))));
  if constexpr (n == 4) return xsimd::batch<float, Arch>(_mm_cvtph_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
#endif
  alignas(64) float wide[n];
  for (std::size_t i = 0; i < n; ++i) wide[i] = io::f16_to_float(p[i]);
  return xsimd::batch<float, Arch>::load_aligned(wide);
}

/// @brief A SIMD batch of consecutive stored BF16 weights (natural layout, not pair layout) as floats.
template <typename Arch>
inline xsimd::batch<float, Arch> load_weights(const BFloat16* p) noexcept {
  using Batch = xsimd::batch<float, Arch>;
  using Words = xsimd::batch<std::uint32_t, Arch>;
  constexpr std::size_t n = Batch::size;
#if defined(__AVX512F__)
  if constexpr (n == 16)
    return Batch(
        _mm512_castsi512_ps(_mm512_slli_epi32(_mm512_cvtepu16_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p))), 16)));
#endif
#if defined(__AVX2__)
  if constexpr (n == 8)
    return Batch(_mm256_castsi256_ps(_mm256_slli_epi32(_mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p))), 16)));
#endif
#if defined(__SSE2__)
  if constexpr (n == 4)  // interleave zeros below each bfloat16: the float with those top bits
    return Batch(_mm_castsi128_ps(_mm_unpacklo_epi16(_mm_setzero_si128(), _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)))));
#endif
  alignas(64) std::uint32_t words[n];
  for (std::size_t i = 0; i < n; ++i) words[i] = static_cast<std::uint32_t>(p[i]);
  return xsimd::bitwise_cast<Batch>(Words::load_aligned(words) << 16);
}

/// @brief Two SIMD batches of floats from 2 x lanes BF16 weights in pair layout: `low` the
/// group's first `lanes` columns, `high` the next `lanes`.
template <typename Arch>
inline void load_weight_pair(const BFloat16* p, xsimd::batch<float, Arch>& low, xsimd::batch<float, Arch>& high) noexcept {
  using Batch = xsimd::batch<float, Arch>;
  using Words = xsimd::batch<std::uint32_t, Arch>;
  static_assert(sizeof(BFloat16) == 2, "two bfloat16 per 32-bit word");
  const Words words = Words::load_unaligned(reinterpret_cast<const std::uint32_t*>(p));
  low = xsimd::bitwise_cast<Batch>(words << 16);
  high = xsimd::bitwise_cast<Batch>(words & Words(0xFFFF0000u));
}

/// @brief Two SIMD batches of Fixed16 levels from 2 x lanes codes in pair layout: `low` the
/// group's first `lanes` columns, `high` the next `lanes`. With AVX-512 VBMI2 the high levels are
/// one double shift (the constant supplies the exponent), the low ones a plain shift and a ternary
/// logic operation: three operations per 32 weights, the fewest we found (a double shift for the
/// low half too, also three, is slower on Zen 4: docs/performance.md).
template <typename Arch>
inline void load_weight_pair(const Fixed16* p, xsimd::batch<float, Arch>& low, xsimd::batch<float, Arch>& high) noexcept {
  using Batch = xsimd::batch<float, Arch>;
  using Words = xsimd::batch<std::uint32_t, Arch>;
  static_assert(sizeof(Fixed16) == 2, "two codes per 32-bit word");
  const Words words = Words::load_unaligned(reinterpret_cast<const std::uint32_t*>(p));
#if defined(__AVX512VBMI2__)
  if constexpr (Batch::size == 16) {
    const __m512i w = words;
    high = Batch(_mm512_castsi512_ps(_mm512_shrdi_epi32(w, _mm512_set1_epi32(0x7F), 9)));
    // (w << 7) & 0x7FFFFF | 0x3F800000: ternary logic 0xEA is (a & b) | c. The shift is spelled
    // with an all-ones zeroing mask: GCC 12's _mm512_slli_epi32 trips -Wuninitialized inside its
    // own header (an undefined pass-through operand); this form compiles to the same plain vpslld.
    const __m512i shifted = _mm512_maskz_slli_epi32(static_cast<__mmask16>(0xFFFF), w, 7);
    low =
        Batch(_mm512_castsi512_ps(_mm512_ternarylogic_epi32(shifted, _mm512_set1_epi32(0x007FFFFF), _mm512_set1_epi32(0x3F800000), 0xEA)));
    return;
  }
#endif
  const Words one(0x3F800000u);
  high = xsimd::bitwise_cast<Batch>((words >> 9) | one);
  low = xsimd::bitwise_cast<Batch>(((words << 7) & Words(0x007FFFFFu)) | one);
}

}  // namespace glovepose::nn::kernels
