/// @file statistics.hpp
/// @brief Order statistics, one definition for every report of the library and its tools: the
/// nearest rank. The q-quantile of n values is the ceil(q n)-th smallest (the smallest for q = 0):
/// always one of the values, never interpolated, and the definition of the percentiles the
/// evaluation publishes (train/metrics.hpp, docs/results.md).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace glovepose::core {

/// @brief The nearest rank of the q-quantile of n >= 1 values: ceil(q n) clamped to 1..n (1 = the
/// smallest). q outside [0, 1] is clamped.
inline std::uint64_t nearest_rank(std::uint64_t n, double q) noexcept {
  if (n == 0) return 0;
  const double position = std::clamp(q, 0.0, 1.0) * static_cast<double>(n);
  // q n may land a rounding error above a whole number (0.95 * 20 = 19.000...04): not a rank more.
  const auto rank = static_cast<std::uint64_t>(std::ceil(position - 4.0 * std::numeric_limits<double>::epsilon() * position));
  return std::clamp<std::uint64_t>(rank, 1, n);
}

/// @brief The q-quantile (q in [0, 1]) of `values` by nearest rank; 0 when empty. Copies and
/// partially sorts: set-up and report code.
inline double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const auto nth = values.begin() + static_cast<std::ptrdiff_t>(nearest_rank(values.size(), q) - 1);
  std::nth_element(values.begin(), nth, values.end());
  return *nth;
}

/// @brief The bin that holds the value of rank `rank` (1 = the smallest) of a histogram of counts:
/// the first bin where the running count reaches the rank; the last bin when the counts total less.
template <typename Counts>
std::size_t bin_of_rank(const Counts& counts, std::uint64_t rank) noexcept {
  std::uint64_t seen = 0;
  for (std::size_t b = 0; b < counts.size(); ++b)
    if ((seen += counts[b]) >= rank) return b;
  return counts.empty() ? 0 : counts.size() - 1;
}

}  // namespace glovepose::core
