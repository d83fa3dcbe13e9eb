/// @file config.hpp
/// @brief Version, the real-time marker, the set-up error type and enum names from tables (name_of),
/// shared by every module.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

/// @brief Major version of glovepose.
#define GLOVEPOSE_VERSION_MAJOR 0
/// @brief Minor version of glovepose.
#define GLOVEPOSE_VERSION_MINOR 1
/// @brief Patch version of glovepose.
#define GLOVEPOSE_VERSION_PATCH 0

/// @brief Marks a per-frame entry point: it is `noexcept`, never allocates, never locks, and reports
/// bad input through a status value. Functions without the marker are set-up code: they may allocate
/// and throw glovepose::Error. The marker expands to nothing; it is there for readers and for grep.
/// What it promises is what tests/test_realtime.cpp (C++) and capi/tests/test_capi_allocations.c
/// (the C ABI) count over 10,000 per-frame calls: no heap allocation, no pthread lock, no system
/// call (one documented exception: EstimatorConfig::network_threads above 1 takes a lock).
#define GLOVEPOSE_REALTIME

/// @brief How the narrow fronts' members (PoseModel, GlovePoseEstimator) are defined: inline in
/// header-only use; out of line, once, in the compiled library (glovepose::compiled defines
/// GLOVEPOSE_COMPILED_LIB for itself and for every unit that links it).
#ifdef GLOVEPOSE_COMPILED_LIB
#define GLOVEPOSE_INLINE
#else
#define GLOVEPOSE_INLINE inline
#endif

namespace glovepose {

#define GLOVEPOSE_VERSION_TEXT_(major, minor, patch) #major "." #minor "." #patch
#define GLOVEPOSE_VERSION_TEXT(major, minor, patch) GLOVEPOSE_VERSION_TEXT_(major, minor, patch)

/// @brief The library version as "major.minor.patch", from the three macros above (the version's
/// one home: CMakeLists.txt reads them, python/pyproject.toml is checked against them).
inline constexpr const char* kVersion = GLOVEPOSE_VERSION_TEXT(GLOVEPOSE_VERSION_MAJOR, GLOVEPOSE_VERSION_MINOR, GLOVEPOSE_VERSION_PATCH);

/// @brief The one exception type of set-up code (loading, configuring, training).
///
/// Its message names what is wrong and what was expected, e.g.
/// "TraceLayout: cell 7 uses bottom trace 15, expected an index below 15".
class Error : public std::runtime_error {
 public:
  /// @brief Creates an error with a message that names the problem and the expectation.
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

/// @brief The name of an enum value numbered 0 .. N - 1 from its table of names (in the enum's
/// order); `unknown` for a value outside it.
template <typename Enum, std::size_t N>
constexpr const char* name_of(Enum value, const char* const (&names)[N], const char* unknown) noexcept {
  const auto index = static_cast<std::size_t>(value);
  return index < N ? names[index] : unknown;
}

}  // namespace glovepose
