/// @file simd.hpp
/// @brief The xsimd kernels, for the instruction set the including code is compiled for
/// (SimdBackend, xsimd::default_arch: AVX-512 or AVX2 with GLOVEPOSE_NATIVE, depending on the
/// machine; SSE2 on baseline x86-64; each of the compiled library's variant units, isa.hpp). Same contracts as ScalarBackend, which is their reference.
///
/// The product y[r] += x[r] W is blocked as R rows x V SIMD vectors of output channels, the
/// R * V accumulators held in registers while k runs: each weight vector is loaded once per block
/// and used R times. R * V is kept >= 8 so that enough independent FMA chains hide the FMA latency
/// (4 cycles, 2 per cycle) even when a tap joins a single row, as in the 4x4 layers at batch 1.
/// The blocks fit the register file: AVX-512 has 32 vector registers, AVX2 and SSE 16, where 8
/// accumulators leave room for the weights being widened and their constants only if each group
/// of weight vectors is widened just before its FMAs (with_weight_vectors()).
#pragma once

#include <algorithm>
#include <array>
#include <bitset>
#include <cstdint>
#include <type_traits>
#include <utility>

#include <xsimd/xsimd.hpp>

#include "../../config.hpp"
#include "sparse_row.hpp"
#include "weight_load.hpp"

#if defined(__AVX512F__) || defined(__AVX2__)
#  include <immintrin.h>
#endif

namespace glovepose::nn::kernels {

/// @brief For each 8-bit mask, the positions of its set bits in ascending order, one per 4-bit
/// nibble (nibble 0 the lowest set bit; unused nibbles 0): AVX2 has no compress instruction, so
/// compact() permutes by this table instead.
constexpr std::array<std::uint32_t, 256> compress_order_table() noexcept {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t mask = 0; mask < 256; ++mask) {
    std::uint32_t order = 0, slot = 0;
    for (std::uint32_t bit = 0; bit < 8; ++bit)
      if (mask >> bit & 1u) order |= bit << (4 * slot++);
    table[mask] = order;
  }
  return table;
}

/// @brief compress_order_table(), computed at compile time.
inline constexpr std::array<std::uint32_t, 256> kCompressOrder = compress_order_table();

/// @brief xsimd kernels for the architecture `ArchT`, which the including code must be compiled for.
/// `Variant` only tells apart copies compiled with different flags: the compiled library's variant
/// units (model/network_variants.hpp) pass a type of their own, so that no function of theirs is
/// shared with, or replaced by, a copy compiled for another instruction set.
template <typename ArchT, typename Variant = void>
struct SimdBackendFor {
  /// @brief The SIMD architecture compiled for.
  using Arch = ArchT;
  /// @brief A vector of floats.
  using Batch = xsimd::batch<float, Arch>;
  /// @brief Name for reports.
  static constexpr const char* name = "simd";
  /// @brief Floats per vector; output channels are padded to a multiple of it.
  static constexpr int lanes = static_cast<int>(Batch::size);

  /// @brief Width of the column panels weights are packed in: 8 vectors.
  static constexpr int panel = 8 * lanes;
  /// @brief Vector registers of the architecture: 32 with AVX-512, 16 with AVX2 and SSE.
  static constexpr int registers = lanes >= 16 ? 32 : 16;
  /// @brief Rows a dense block holds at most: 12 (of 2 vectors) with 32 registers, 4 with 16.
  static constexpr int max_block_rows = registers == 32 ? 12 : 4;
  /// @brief Rows per block when a product has more than max_block_rows (batches): 6 (of 4
  /// vectors) with 32 registers, 4 (of 2) with 16.
  static constexpr int batch_block_rows = registers == 32 ? 6 : 4;

  /// @brief See ScalarBackend::gemm_rows. Requires n to be a multiple of `lanes`.
  template <typename W>
  GLOVEPOSE_REALTIME static void gemm_rows(const float* const* x, float* const* y, int rows, const W* w, int k, int n) noexcept {
    // Few rows (batch 1): wide column blocks for enough accumulators. Many rows (batches):
    // batch_block_rows, whose column blocks vectors_for() sizes.
    const int max_rows = rows <= max_block_rows ? rows : batch_block_rows;
    for (int p0 = 0; p0 < n; p0 += panel) {
      const int width = std::min(panel, n - p0);  // this panel's row length
      const W* wp = w + static_cast<long>(k) * p0;
      for (int j = 0; j < width;) {
        const int v = vectors_for(max_rows, (width - j) / lanes);  // the same column block for all rows
        for (int r = 0; r < rows; r += max_rows) dispatch(std::min(max_rows, rows - r), v, x + r, y + r, wp + j, k, width, p0 + j);
        j += v * lanes;
      }
    }
  }

  /// @brief See ScalarBackend::compact. Writes up to k entries of index[] and value[] (beyond the
  /// returned count too); AVX-512 compresses 16 at a time, AVX2 permutes 8 at a time.
  GLOVEPOSE_REALTIME static int compact(const float* x, int k, int* index, float* value) noexcept {
    int count = 0, i = 0;
#if defined(__AVX512F__)
    if constexpr (lanes == 16) {
      __m512i positions = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
      const __m512i step = _mm512_set1_epi32(16);
      for (; i + 16 <= k; i += 16) {  // count <= i: the 16 stores stay below i + 16 <= k
        const __m512 v = _mm512_loadu_ps(x + i);
        const __mmask16 nonzero = _mm512_cmp_ps_mask(v, _mm512_setzero_ps(), _CMP_NEQ_UQ);  // NaN: nonzero
        _mm512_storeu_ps(value + count, _mm512_maskz_compress_ps(nonzero, v));
        _mm512_storeu_si512(index + count, _mm512_maskz_compress_epi32(nonzero, positions));
        count += static_cast<int>(std::bitset<16>(nonzero).count());
        positions = _mm512_add_epi32(positions, step);
      }
    }
#endif
#if defined(__AVX2__)
    if constexpr (lanes == 8) {
      __m256i positions = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
      const __m256i step = _mm256_set1_epi32(8), nibble_shifts = _mm256_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28);
      for (; i + 8 <= k; i += 8) {  // count <= i: the 8 stores stay below i + 8 <= k
        const __m256 v = _mm256_loadu_ps(x + i);
        const int nonzero = _mm256_movemask_ps(_mm256_cmp_ps(v, _mm256_setzero_ps(), _CMP_NEQ_UQ));  // NaN: nonzero
        const __m256i order = _mm256_and_si256(
            _mm256_srlv_epi32(_mm256_set1_epi32(static_cast<int>(kCompressOrder[static_cast<std::size_t>(nonzero)])), nibble_shifts),
            _mm256_set1_epi32(7));
        _mm256_storeu_ps(value + count, _mm256_permutevar8x32_ps(v, order));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(index + count), _mm256_permutevar8x32_epi32(positions, order));
        count += static_cast<int>(std::bitset<8>(static_cast<unsigned>(nonzero)).count());
        positions = _mm256_add_epi32(positions, step);
      }
    }
#endif
    for (; i < k; ++i) {  // branch-free: the slot is overwritten unless x[i] is nonzero
      index[count] = i;
      value[count] = x[i];
      count += x[i] != 0.0f;  // true for NaN
    }
    return count;
  }

  /// @brief See ScalarBackend::gemm_sparse_rows. Per column block, each row runs over its nonzero
  /// entries only, V accumulator vectors (U sets of them for narrow blocks) in registers.
  template <typename W>
  GLOVEPOSE_REALTIME static void gemm_sparse_rows(const SparseRow* x, float* const* y, int rows, const W* w, int k, int n) noexcept {
    for (int p0 = 0; p0 < n; p0 += panel) {
      const int width = std::min(panel, n - p0);
      const W* wp = w + static_cast<long>(k) * p0;
      for (int j = 0; j < width;) {
        const int v = vectors_for(1, (width - j) / lanes);
        for (int r = 0; r < rows; ++r) {
          if (x[r].count == 0) continue;
          float* out = y[r] + p0 + j;
          switch (v) {
            case 8:
              sparse_block<8>(x[r], out, wp + j, width, p0 + j);
              break;
            case 4:
              sparse_block<4>(x[r], out, wp + j, width, p0 + j);
              break;
            case 2:
              sparse_block<2>(x[r], out, wp + j, width, p0 + j);
              break;
            default:
              sparse_block<1>(x[r], out, wp + j, width, p0 + j);
              break;
          }
        }
        j += v * lanes;
      }
    }
  }

  /// @brief See ScalarBackend::sum (here in `lanes` partial sums, then across them).
  GLOVEPOSE_REALTIME static float sum(const float* x, int k) noexcept {
    Batch partial(0.0f);
    int i = 0;
    for (; i + lanes <= k; i += lanes) partial += Batch::load_unaligned(x + i);
    float total = xsimd::hadd(partial);
    for (; i < k; ++i) total += x[i];
    return total;
  }

  /// @brief In-place max(0, v); count must be a multiple of `lanes`.
  GLOVEPOSE_REALTIME static void relu(float* data, int count) noexcept {
    const Batch zero(0.0f);
    // max(zero, v), in this order, passes a NaN v through (as the scalar max does), so a numeric
    // failure is detected at the output instead of being hidden.
    for (int i = 0; i < count; i += lanes) xsimd::max(zero, Batch::load_unaligned(data + i)).store_unaligned(data + i);
  }

 private:
  // Column vectors per block: enough accumulators (R * V >= 8) within the register file. With 32
  // registers V = 8 for R = 1, V <= 4 for R <= 6, V <= 2 for R <= 12; with 16 registers 8
  // accumulators at most: V = 8 for R = 1, 4 for R = 2, 2 for R <= 4. dispatch() computes any
  // (R, V) correctly, splitting a column block it has no register budget for.
  static int vectors_for(int rows, int vectors_left) noexcept {
    const int wanted = registers == 32 ? (rows == 1 ? 8 : (rows <= 6 ? 4 : 2)) : (rows == 1 ? 8 : (rows == 2 ? 4 : 2));
    int v = wanted;
    while (v > vectors_left) v /= 2;
    return std::max(v, 1);
  }

  // One frame: four rotating accumulators hide the FMA latency.
  template <int V, typename W>
  static void sparse_block(const SparseRow& x, float* y, const W* w, int ldw, int col) noexcept {
    constexpr int U = V >= 8 ? 1 : 8 / V;  // >= 8 independent FMA chains, as in block()
    Batch acc[U][V];
#pragma GCC unroll 8
    for (int u = 0; u < U; ++u)
#pragma GCC unroll 8
      for (int v = 0; v < V; ++v) acc[u][v] = Batch(0.0f);
    int i = 0;
    for (; i + U <= x.count; i += U) {
      // The rows a skip leaves out break the hardware prefetcher's stride: fetch a few rows ahead.
      if (i + kPrefetchRows < x.count) prefetch_row<V>(w + static_cast<long>(x.index[i + kPrefetchRows]) * ldw);
#pragma GCC unroll 8
      for (int u = 0; u < U; ++u) sparse_step<V>(acc[u], x.value[i + u], w + static_cast<long>(x.index[i + u]) * ldw, col);
    }
    for (; i < x.count; ++i) sparse_step<V>(acc[0], x.value[i], w + static_cast<long>(x.index[i]) * ldw, col);
#pragma GCC unroll 8
    for (int v = 0; v < V; ++v) {
      Batch sum = acc[0][v];
      for (int u = 1; u < U; ++u) sum += acc[u][v];
      (Batch::load_unaligned(y + v * lanes) + sum).store_unaligned(y + v * lanes);
    }
  }

  static constexpr int kPrefetchRows = 4;

  template <int V, typename W>
  static void prefetch_row(const W* row) noexcept {
    constexpr int bytes = V * lanes * static_cast<int>(sizeof(W));
    const char* p = reinterpret_cast<const char*>(row);
#pragma GCC unroll 8
    for (int b = 0; b < bytes; b += 64) __builtin_prefetch(p + b);
  }

  template <int V, typename W>
  static void sparse_step(Batch (&acc)[V], float value, const W* wk, int col) noexcept {
    const Batch xb(value);
    with_weight_vectors<V>(wk, col, [&](int v, const Batch& wv) { acc[v] = xsimd::fma(xb, wv, acc[v]); });
  }

  template <int R, int V, typename W>
  static void block(const float* const* x, float* const* y, const W* w, int k, int ldw, int col) noexcept {
    // The R x V accumulators must live in registers: the loops over r and v are unrolled fully.
    // With fewer than 8 of them (a narrow panel remainder, a single row), U sets take turns over k
    // so that 8 independent FMA chains still hide the FMA latency.
    constexpr int U = R * V >= 8 ? 1 : (8 + R * V - 1) / (R * V);
    Batch acc[U][R][V];
#pragma GCC unroll 8
    for (int u = 0; u < U; ++u)
#pragma GCC unroll 16
      for (int r = 0; r < R; ++r)
#pragma GCC unroll 8
        for (int v = 0; v < V; ++v) acc[u][r][v] = Batch(0.0f);
    const float* xr[R];
#pragma GCC unroll 16
    for (int r = 0; r < R; ++r) xr[r] = x[r];
    int kk = 0;
    for (; kk + U <= k; kk += U)
#pragma GCC unroll 8
      for (int u = 0; u < U; ++u) step<R, V>(acc[u], xr, w, kk + u, ldw, col);
    for (; kk < k; ++kk) step<R, V>(acc[0], xr, w, kk, ldw, col);
    for (int r = 0; r < R; ++r)
      for (int v = 0; v < V; ++v) {
        Batch sum = acc[0][r][v];
        for (int u = 1; u < U; ++u) sum += acc[u][r][v];
        float* out = y[r] + col + v * lanes;
        (Batch::load_unaligned(out) + sum).store_unaligned(out);
      }
  }

  // Calls use(v, weights) for the V weight vectors at wk, whose first column is `col`, each group
  // widened just before its use: BF16 and Fixed16 come in pairs of vectors (pair layout,
  // weight_load.hpp), whose groups start at even multiples of `lanes`. Loading all V first would
  // hold V more registers, which with 16 of them spills the accumulators to the stack.
  template <int V, typename W, typename Use>
  static void with_weight_vectors(const W* wk, int col, Use&& use) noexcept {
    if constexpr (kPairLayout<W>) {
      static_assert(V == 1 || V % 2 == 0, "pair-layout blocks are whole pairs of vectors or a single vector");
      if constexpr (V == 1) {  // half a pair: only when a layer has an odd number of vectors (not with pair strides)
        Batch low, high;
        const bool second = (col / lanes) % 2 != 0;
        load_weight_pair<Arch>(second ? wk - lanes : wk, low, high);
        use(0, second ? high : low);
      } else {
#pragma GCC unroll 4
        for (int v = 0; v < V; v += 2) {
          Batch low, high;
          load_weight_pair<Arch>(wk + v * lanes, low, high);
          use(v, low);
          use(v + 1, high);
        }
      }
    } else {
      (void)col;
#pragma GCC unroll 8
      for (int v = 0; v < V; ++v) use(v, load_weights<Arch>(wk + v * lanes));
    }
  }

  // One k of a block: V weight vectors, each used by R rows.
  template <int R, int V, typename W>
  static void step(Batch (&acc)[R][V], const float* const (&xr)[R], const W* w, int kk, int ldw, int col) noexcept {
    const W* wk = w + static_cast<long>(kk) * ldw;
    if constexpr (registers == 32) {  // all V vectors, then the rows: the order measured on Zen 4
      Batch wv[V];
      with_weight_vectors<V>(wk, col, [&](int v, const Batch& widened) { wv[v] = widened; });
#pragma GCC unroll 16
      for (int r = 0; r < R; ++r) {
        const Batch xb(xr[r][kk]);
#pragma GCC unroll 8
        for (int v = 0; v < V; ++v) acc[r][v] = xsimd::fma(xb, wv[v], acc[r][v]);
      }
    } else {  // each group's FMAs right after its widening: only one group live
      with_weight_vectors<V>(wk, col, [&](int v, const Batch& wv) {
#pragma GCC unroll 16
        for (int r = 0; r < R; ++r) acc[r][v] = xsimd::fma(Batch(xr[r][kk]), wv, acc[r][v]);
      });
    }
  }

  template <int V, typename W>
  static void dispatch_rows(int rows, const float* const* x, float* const* y, const W* w, int k, int ldw, int col) noexcept {
    if (rows <= 6) {
      block_of_rows<V>(std::integer_sequence<int, 1, 2, 3, 4, 5, 6>{}, rows, x, y, w, k, ldw, col);
    } else if constexpr (V > 2) {  // 7..12 rows hold at most 2 vectors of accumulators each: two halves
      dispatch_many_rows<2>(rows, x, y, w, k, ldw, col);
      dispatch_many_rows<2>(rows, x, y, w + 2 * lanes, k, ldw, col + 2 * lanes);
    } else {
      dispatch_many_rows<V>(rows, x, y, w, k, ldw, col);
    }
  }

  template <int V, typename W>
  static void dispatch_many_rows(int rows, const float* const* x, float* const* y, const W* w, int k, int ldw, int col) noexcept {
    block_of_rows<V>(std::integer_sequence<int, 7, 8, 9, 10, 11, 12>{}, std::min(rows, 12), x, y, w, k, ldw, col);
  }

  // block<R, V> for the R among `Rs` that equals `rows` (a compile-time row count from a run-time one).
  template <int V, typename W, int... Rs>
  static void block_of_rows(std::integer_sequence<int, Rs...>, int rows, const float* const* x, float* const* y, const W* w, int k, int ldw,
                            int col) noexcept {
    (void)((rows == Rs && (block<Rs, V>(x, y, w, k, ldw, col), true)) || ...);
  }

  template <typename W>
  static void dispatch(int rows, int v, const float* const* x, float* const* y, const W* w, int k, int ldw, int col) noexcept {
    switch (v) {
      case 8:  // vectors_for() chooses 8 for single rows; any other row count as two halves of 4
        if (rows == 1) {
          block<1, 8>(x, y, w, k, ldw, col);
        } else {
          dispatch_rows<4>(rows, x, y, w, k, ldw, col);
          dispatch_rows<4>(rows, x, y, w + 4 * lanes, k, ldw, col + 4 * lanes);
        }
        break;
      case 4:
        dispatch_rows<4>(rows, x, y, w, k, ldw, col);
        break;
      case 2:
        dispatch_rows<2>(rows, x, y, w, k, ldw, col);
        break;
      default:
        dispatch_rows<1>(rows, x, y, w, k, ldw, col);
        break;
    }
  }
};

/// @brief The kernels for the instruction set the including code is compiled for (header-only use).
using SimdBackend = SimdBackendFor<xsimd::default_arch>;

}  // namespace glovepose::nn::kernels
