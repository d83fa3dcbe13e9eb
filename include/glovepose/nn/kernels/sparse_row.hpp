/// @file sparse_row.hpp
/// @brief A row of activations as its nonzero entries.
///
/// After a ReLU about half of the activations are exactly zero (the trained w = 64 model and random
/// weights alike; docs/performance.md). At batch 1 each weight row
/// of a product meets only a few activations, so skipping the zero ones skips their multiply-adds
/// and, where a weight row meets a single activation, the reading of that weight row. Skipping is
/// exact: a zero activation contributes an exact zero.
#pragma once

namespace glovepose::nn::kernels {

/// @brief The nonzero entries of one row x[0..k): x[index[i]] = value[i] for i < count, ascending
/// index, every other entry zero.
struct SparseRow {
  const int* index;    ///< Positions of the nonzero entries, ascending.
  const float* value;  ///< Their values (NaN and infinities count as nonzero).
  int count;           ///< Number of nonzero entries.
};

}  // namespace glovepose::nn::kernels
