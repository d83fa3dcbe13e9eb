/// @file fuzz_check.hpp
/// @brief The invariant check of the fuzz targets: a violated invariant aborts, so libFuzzer keeps
/// the input as a crash (a sanitizer finding does the same by itself).
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>

/// @brief Aborts with the failed condition and its line when `condition` is false.
#define GLOVEPOSE_FUZZ_REQUIRE(condition)                                                           \
  do {                                                                                              \
    if (!(condition)) {                                                                             \
      std::fprintf(stderr, "%s:%d: fuzz invariant violated: %s\n", __FILE__, __LINE__, #condition); \
      std::abort();                                                                                 \
    }                                                                                               \
  } while (0)

namespace glovepose::fuzz {

/// @brief Whether every value of a container of numbers is finite.
template <typename Values>
bool all_finite(const Values& values) {
  for (const auto v : values)
    if (!std::isfinite(static_cast<double>(v))) return false;
  return true;
}

}  // namespace glovepose::fuzz
