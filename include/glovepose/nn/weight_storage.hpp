/// @file weight_storage.hpp
/// @brief How a network's weights are kept in memory after loading, for every architecture.
#pragma once

#include <optional>
#include <string_view>

#include "isa.hpp"

namespace glovepose::nn {

/// @brief How the weights are kept in memory.
enum class WeightStorage : unsigned char {
  F32,      ///< Exact: the file's values (with BN folded) in float.
  F16,      ///< binary16: half the bytes; outputs differ from F32 by rounding (see README for the bound).
  BF16,     ///< bfloat16: half the bytes, widened by two integer operations (the fastest at batch 1);
            ///< 8 mantissa bits, so outputs differ from F32 more than with F16 (docs/performance.md).
  Fixed16,  ///< 16-bit codes with one scale per output channel (fixed16.hpp): half the bytes, widened
            ///< by 1.5 integer operations per vector; rounding at most 2^-16 of the channel's largest
            ///< weight. The U-Net's first and last layer (few weights, not row products) stay F32.
};

static_assert(static_cast<int>(WeightStorage::Fixed16) == 3, "the C ABI's GLOVEPOSE_WEIGHTS_* values are this order");
/// @brief Each storage's two spellings, in WeightStorage's order: the name for messages and reports
/// ("F32", "F16", "BF16", "Fixed16") and the word the tool's --weights, eval's report, the C ABI's
/// evaluation options and Python's weights= use ("f32", "f16", "bf16", "fixed16").
struct WeightStorageNames {
  const char* name;
  const char* word;
};
inline constexpr WeightStorageNames kWeightStorageNames[] = {{"F32", "f32"}, {"F16", "f16"}, {"BF16", "bf16"}, {"Fixed16", "fixed16"}};
/// @brief The number of storages (WeightStorage's values are 0 .. kWeightStorageCount - 1).
inline constexpr int kWeightStorageCount = static_cast<int>(sizeof kWeightStorageNames / sizeof kWeightStorageNames[0]);
static_assert(kWeightStorageCount == static_cast<int>(WeightStorage::Fixed16) + 1, "one name table entry per storage");

/// @brief Name of a weight storage for messages and reports: "F32", "F16", "BF16" or "Fixed16".
constexpr const char* storage_name(WeightStorage storage) noexcept {
  const auto s = static_cast<int>(storage);
  return s < kWeightStorageCount ? kWeightStorageNames[s].name : "unknown";
}

/// @brief The word of a weight storage: "f32", "f16", "bf16" or "fixed16".
constexpr const char* storage_word(WeightStorage storage) noexcept {
  const auto s = static_cast<int>(storage);
  return s < kWeightStorageCount ? kWeightStorageNames[s].word : "unknown";
}

/// @brief The storage `word` names (storage_word), if any.
constexpr std::optional<WeightStorage> storage_of_word(std::string_view word) noexcept {
  for (int s = 0; s < kWeightStorageCount; ++s)
    if (word == storage_word(static_cast<WeightStorage>(s))) return static_cast<WeightStorage>(s);
  return std::nullopt;
}

/// @brief The storage for the real-time path with `isa`'s kernels: the fastest of those within 0.1
/// degree of F32 (F32, Fixed16 and F16; test_estimator.cpp), measured per set (an engine's frame
/// through the C ABI, docs/performance.md, "The shipped library per instruction set"). AVX2: F16
/// (one hardware conversion per 8 weights, cheaper there than Fixed16's five integer operations per
/// 16). AVX-512 (with VBMI2): Fixed16 (three integer operations widen 32 weights). SSE2: F32
/// (binary16 is widened in software, one value at a time, and Fixed16's widening costs more than the
/// bytes it saves). NEON: Fixed16 (binary16 in software there too; unmeasured against F32).
constexpr WeightStorage realtime_storage(Isa isa) noexcept {
  switch (isa) {
    case Isa::Avx2:
      return WeightStorage::F16;
    case Isa::Sse2:
      return WeightStorage::F32;
    case Isa::Avx512:
    case Isa::Neon:
      break;
  }
  return WeightStorage::Fixed16;
}

/// @brief The real-time storage for the instruction set the including code is compiled for
/// (header-only use; the compiled library's is realtime_storage(model::process_isa())).
constexpr WeightStorage realtime_storage() noexcept { return realtime_storage(compiled_isa()); }

/// @brief Whether matrices kept as `storage` are in pair layout (kernels/weight_load.hpp), so that
/// output channels are padded to whole pairs of vectors.
constexpr bool paired_storage(WeightStorage storage) noexcept {
  return storage == WeightStorage::BF16 || storage == WeightStorage::Fixed16;
}

}  // namespace glovepose::nn
