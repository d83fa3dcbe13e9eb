/// @file isa.hpp
/// @brief The instruction sets the networks' kernels are built for, what the running CPU can
/// execute, and which set a process runs.
///
/// Header-only use runs the kernels the including code is compiled for (compiled_isa()). The
/// compiled library (CMake target glovepose::compiled, and the C ABI library built on it) holds the
/// networks once per instruction set of the platform and loads each model's network in the best
/// set this CPU executes, or the one the environment variable GLOVEPOSE_ISA names (for tests and
/// bug reports): model/network_variants.hpp.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <optional>
#include <string>
#include <string_view>

#include "../config.hpp"

#if (defined(__GNUC__) || defined(__clang__)) && (defined(__x86_64__) || defined(_M_X64))
#  include <cpuid.h>
#  define GLOVEPOSE_ISA_X86_64 1
#endif

namespace glovepose::nn {

/// @brief An instruction set a variant of the kernels is built for.
enum class Isa : unsigned char {
  Sse2,    ///< x86-64's baseline: every x86-64 CPU.
  Avx2,    ///< AVX2 with FMA and F16C (Intel Haswell, AMD Zen and later).
  Avx512,  ///< AVX-512 F, BW, DQ, VL and VBMI2, with AVX2's (Intel Ice Lake, AMD Zen 4 and later).
  Neon,    ///< 64-bit ARM's Advanced SIMD: every ARM64 CPU.
};

/// @brief Each set's word, in Isa's order: what GLOVEPOSE_ISA, reports and the C ABI spell.
inline constexpr const char* kIsaWords[] = {"sse2", "avx2", "avx512", "neon"};
/// @brief The number of instruction sets (Isa's values are 0 .. kIsaCount - 1).
inline constexpr int kIsaCount = static_cast<int>(sizeof kIsaWords / sizeof kIsaWords[0]);
static_assert(kIsaCount == static_cast<int>(Isa::Neon) + 1, "one word per instruction set");

/// @brief "sse2", "avx2", "avx512" or "neon".
constexpr const char* isa_word(Isa isa) noexcept { return name_of(isa, kIsaWords, "unknown"); }

/// @brief The set `word` names (isa_word), if any.
constexpr std::optional<Isa> isa_of_word(std::string_view word) noexcept {
  for (int i = 0; i < kIsaCount; ++i)
    if (word == kIsaWords[i]) return static_cast<Isa>(i);
  return std::nullopt;
}

/// @brief The set the including code is compiled for: the kernels header-only use runs.
constexpr Isa compiled_isa() noexcept {
#if defined(__aarch64__) || defined(_M_ARM64)
  return Isa::Neon;
#elif defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512DQ__) && defined(__AVX512VL__) && defined(__AVX512VBMI2__)
  return Isa::Avx512;
#elif defined(__AVX2__) && defined(__FMA__) && defined(__F16C__)
  return Isa::Avx2;
#else
  return Isa::Sse2;
#endif
}

/// @brief Whether this CPU, and the operating system's saving of its registers, execute `isa`'s
/// instructions (set-up code: CPUID and XGETBV; bits from Intel's Software Developer's Manual,
/// vol. 2A, CPUID leaves 1 and 7). Only the platform's own sets can be true.
inline bool cpu_supports(Isa isa) noexcept {
#if defined(GLOVEPOSE_ISA_X86_64)
  if (isa == Isa::Sse2) return true;
  unsigned a = 0, b = 0, c = 0, d = 0;
  if (!__get_cpuid(1, &a, &b, &c, &d)) return false;
  const bool fma = c >> 12 & 1u, osxsave = c >> 27 & 1u, avx = c >> 28 & 1u, f16c = c >> 29 & 1u;
  if (!(osxsave && avx && fma && f16c)) return false;
  std::uint32_t xcr0_low = 0, xcr0_high = 0;
  __asm__ volatile("xgetbv" : "=a"(xcr0_low), "=d"(xcr0_high) : "c"(0));
  (void)xcr0_high;
  if ((xcr0_low & 0x6u) != 0x6u) return false;  // the OS saves XMM and YMM state
  if (!__get_cpuid_count(7, 0, &a, &b, &c, &d)) return false;
  const bool avx2 = b >> 5 & 1u;
  if (isa == Isa::Avx2) return avx2;
  if (isa != Isa::Avx512) return false;
  const bool f = b >> 16 & 1u, dq = b >> 17 & 1u, bw = b >> 30 & 1u, vl = b >> 31 & 1u, vbmi2 = c >> 6 & 1u;
  return avx2 && f && dq && bw && vl && vbmi2 && (xcr0_low & 0xE0u) == 0xE0u;  // and opmask, ZMM state
#else
  return isa == compiled_isa();
#endif
}

/// @brief The set a process asks for: GLOVEPOSE_ISA's word if the variable is set (set-up code).
/// Throws glovepose::Error for a word that names no set, or a set this CPU cannot execute.
inline std::optional<Isa> isa_from_environment() {
  const char* value = std::getenv("GLOVEPOSE_ISA");
  if (value == nullptr || *value == '\0') return std::nullopt;
  const std::optional<Isa> isa = isa_of_word(value);
  if (!isa) throw Error(std::string("GLOVEPOSE_ISA is '") + value + "', expected sse2, avx2, avx512 or neon");
  if (!cpu_supports(*isa)) throw Error(std::string("GLOVEPOSE_ISA is '") + value + "', which this CPU does not execute");
  return isa;
}

}  // namespace glovepose::nn
