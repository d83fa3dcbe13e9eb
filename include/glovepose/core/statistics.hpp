/// @file statistics.hpp
/// @brief Order statistics of a sample, for set-up code and reports (they copy and sort).
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace glovepose::core {

/// @brief The p-quantile (p in [0, 1]) of `values`: the floor(p (n - 1))-th smallest; 0 when empty.
inline double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(std::clamp(p, 0.0, 1.0) * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace glovepose::core
