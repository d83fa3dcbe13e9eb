/// @file number_text.hpp
/// @brief A number as text, the one way the library writes numbers into files and messages:
/// shortest round-trip form, independent of the locale ("nan" and "inf" for non-finite values).
#pragma once

#include <charconv>
#include <string>
#include <type_traits>

namespace glovepose::io {

/// @brief `v` as text: integers in decimal, floating point in the shortest form that reads back to
/// the same value.
template <typename T>
std::string number_text(T v) {
  if constexpr (std::is_integral_v<T>) {
    return std::to_string(static_cast<long long>(v));
  } else {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
  }
}

}  // namespace glovepose::io
