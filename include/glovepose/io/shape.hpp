/// @file shape.hpp
/// @brief A tensor shape as text, for messages.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace glovepose::io {

/// @brief "[a, b, c]" for messages.
inline std::string shape_string(const std::vector<std::int64_t>& shape) {
  std::string s = "[";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + "]";
}

}  // namespace glovepose::io
