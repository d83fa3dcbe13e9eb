/// @file scalar.hpp
/// @brief The scalar reference kernels: plain loops, the definition the SIMD kernels are tested
/// against (tests/test_kernels.cpp).
#pragma once

#include <algorithm>
#include <cmath>

#include "../../config.hpp"
#include "sparse_row.hpp"
#include "weight_load.hpp"

namespace glovepose::nn::kernels {

/// @brief Position of W(row, col) of a k x n matrix packed in column panels of `panel` columns:
/// panel p = col / panel starts at k * p * panel and holds k rows of min(panel, n - p * panel) values.
constexpr long panel_index(int row, int col, int k, int n, int panel) noexcept {
  const int p = col / panel;
  const int width = n - p * panel < panel ? n - p * panel : panel;
  return static_cast<long>(k) * p * panel + static_cast<long>(row) * width + (col - p * panel);
}

/// @brief Plain C++ kernels.
struct ScalarBackend {
  /// @brief Name for reports.
  static constexpr const char* name = "scalar";
  /// @brief Output channels are padded to a multiple of this (1: no padding needed).
  static constexpr int lanes = 1;
  /// @brief Width of the column panels weights are packed in (see panel_index()).
  static constexpr int panel = 8;

  /// @brief Row-gathered matrix product: for every row r, y[r][0..n) += x[r][0..k) * W, where the
  /// k x n matrix W is packed in column panels of `panel` columns (the last one narrower), each
  /// panel k rows of its width, row-major (panel_index()).
  template <typename W>
  GLOVEPOSE_REALTIME static void gemm_rows(const float* const* x, float* const* y, int rows, const W* w, int k, int n) noexcept {
    for (int r = 0; r < rows; ++r)
      for (int kk = 0; kk < k; ++kk) {
        const float xv = x[r][kk];
        for (int j = 0; j < n; ++j) y[r][j] += xv * weight_at(w, panel_index(kk, j, k, n, panel));
      }
  }

  /// @brief The nonzero entries of x[0..k) into index[] and value[] (room for k each); returns
  /// their count. A NaN is nonzero; -0 is zero.
  GLOVEPOSE_REALTIME static int compact(const float* x, int k, int* index, float* value) noexcept {
    int count = 0;
    for (int i = 0; i < k; ++i)
      if (x[i] != 0.0f) {  // true for NaN
        index[count] = i;
        value[count++] = x[i];
      }
    return count;
  }

  /// @brief gemm_rows() for rows given by their nonzero entries: for every row r,
  /// y[r][0..n) += sum over i of x[r].value[i] * W(x[r].index[i], 0..n), W packed as for gemm_rows().
  template <typename W>
  GLOVEPOSE_REALTIME static void gemm_sparse_rows(const SparseRow* x, float* const* y, int rows, const W* w, int k, int n) noexcept {
    for (int r = 0; r < rows; ++r)
      for (int i = 0; i < x[r].count; ++i) {
        const float xv = x[r].value[i];
        const int kk = x[r].index[i];
        for (int j = 0; j < n; ++j) y[r][j] += xv * weight_at(w, panel_index(kk, j, k, n, panel));
      }
  }

  /// @brief Sum of x[0..k), in order.
  GLOVEPOSE_REALTIME static float sum(const float* x, int k) noexcept {
    float total = 0.0f;
    for (int i = 0; i < k; ++i) total += x[i];
    return total;
  }

  /// @brief In-place max(0, v).
  GLOVEPOSE_REALTIME static void relu(float* data, int count) noexcept {
    for (int i = 0; i < count; ++i) data[i] = std::max(data[i], 0.0f);
  }
};

}  // namespace glovepose::nn::kernels
