/// @file one_euro_config.hpp
/// @brief The 1-euro filter's settings (one_euro.hpp), apart from the filter.
#pragma once

namespace glovepose::filter {

/// @brief Settings of the 1-euro filter.
struct OneEuroConfig {
  double frequency = 60.0;  ///< Initial sampling rate, Hz; replaced by the observed rate once timestamps arrive.
  double min_cutoff = 1.0;  ///< Cutoff at rest, Hz: lower means less jitter, more lag when slow.
  double beta = 0.0;        ///< Speed coefficient: higher means less lag when fast.
  double d_cutoff = 1.0;    ///< Cutoff of the derivative's low-pass, Hz.
};

}  // namespace glovepose::filter
