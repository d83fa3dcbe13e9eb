// The two limits the U-Net forward races (run: build/bench/glovepose_bench --benchmark_filter=Peak|Stream):
//   BM_PeakFma          this core's F32 multiply-add rate (independent FMA chains, xsimd default arch)
//   BM_PeakDpwssd       the same for AVX-512 VNNI's 16-bit dot product (two multiply-adds per 32-bit
//                       lane and instruction): whether integer weights could raise the compute ceiling
//   BM_StreamBytes/N    the rate at which one core re-reads an N-byte buffer (the weights at batch 1)
//   BM_StreamRows/KiB:N/patterns:P  a random half of the 256-byte rows of an N KiB buffer, rows
//                       ascending, the half chosen from P patterns in turn (1: the same rows every
//                       pass, as a forward of one input over and over; 16: a different half each
//                       pass): the rate at which the batch-1 forward's weights, rows skipped where
//                       the activation is zero, can arrive at best
//   BM_SparseRowKernel* the batch-1 product kernel itself, per weight storage: its multiply-adds per
//                       second with the weights in the L1/L2 (KiB:32, what the widening of 16-bit
//                       weights costs) and streamed from the L3 (KiB:4224, what the forward sees)
#include <glovepose/nn/kernels/simd.hpp>
#include <glovepose/nn/tensor.hpp>

#include <benchmark/benchmark.h>
#include <xsimd/xsimd.hpp>

#if defined(__AVX512VNNI__)
#  include <immintrin.h>
#endif

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

using Batch = xsimd::batch<float>;

static void BM_PeakFma(benchmark::State& state) {
  // Latency 4 x 2 FMA units = 8 chains needed; more for slack, but all in registers with the two
  // operands: 16 with AVX-512's 32 registers, 12 with 16 (16 chains spilled 3 of them to the stack
  // on AVX2, which made this loop latency-bound at about half the peak).
  constexpr int kChains = glovepose::nn::kernels::SimdBackend::registers == 32 ? 16 : 12;
  Batch acc[kChains];
  for (int i = 0; i < kChains; ++i) acc[i] = Batch(0.001f * static_cast<float>(i));
  const Batch a(0.9999f), b(1e-5f);
  constexpr long kRounds = 1 << 16;
  for (auto _ : state) {
    for (long n = 0; n < kRounds; ++n)
#pragma GCC unroll 16
      for (int i = 0; i < kChains; ++i) acc[i] = xsimd::fma(acc[i], a, b);
    benchmark::DoNotOptimize(acc);
  }
  const double macs = static_cast<double>(state.iterations()) * kRounds * kChains * Batch::size;
  state.counters["MAC_per_s"] = benchmark::Counter(macs, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_PeakFma);

#if defined(__AVX512VNNI__)
// vpdpwssd: per 32-bit lane, two int16 x int16 products added to an int32 sum; 32 multiply-adds
// per 512-bit instruction against the FMA's 16. Same chain count as BM_PeakFma.
static void BM_PeakDpwssd(benchmark::State& state) {
  constexpr int kChains = 16;
  __m512i acc[kChains];
  for (int i = 0; i < kChains; ++i) acc[i] = _mm512_set1_epi32(i);
  const __m512i a = _mm512_set1_epi32(0x00030001), b = _mm512_set1_epi32(0x00010002);
  constexpr long kRounds = 1 << 16;
  for (auto _ : state) {
    for (long n = 0; n < kRounds; ++n)
#  pragma GCC unroll 16
      for (int i = 0; i < kChains; ++i) acc[i] = _mm512_dpwssd_epi32(acc[i], a, b);
    benchmark::DoNotOptimize(acc);
  }
  const double macs = static_cast<double>(state.iterations()) * kRounds * kChains * 32;
  state.counters["MAC_per_s"] = benchmark::Counter(macs, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_PeakDpwssd);
#endif

static void BM_StreamBytes(benchmark::State& state) {
  const auto bytes = static_cast<std::size_t>(state.range(0));
  glovepose::nn::AlignedVector<float> buffer(bytes / sizeof(float), 1.0f);
  for (auto _ : state) {
    Batch s0(0.0f), s1(0.0f), s2(0.0f), s3(0.0f);
    for (std::size_t i = 0; i + 4 * Batch::size <= buffer.size(); i += 4 * Batch::size) {
      s0 += Batch::load_aligned(&buffer[i]);
      s1 += Batch::load_aligned(&buffer[i + Batch::size]);
      s2 += Batch::load_aligned(&buffer[i + 2 * Batch::size]);
      s3 += Batch::load_aligned(&buffer[i + 3 * Batch::size]);
    }
    benchmark::DoNotOptimize((s0 + s1) + (s2 + s3));
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes));
}
static void BM_StreamRows(benchmark::State& state) {
  constexpr std::size_t kRowBytes = 256;  // a row of one 128-column panel of 16-bit weights
  const std::size_t rows = static_cast<std::size_t>(state.range(0)) * 1024 / kRowBytes;
  const auto pattern_count = static_cast<std::size_t>(state.range(1));
  constexpr std::size_t floats_per_row = kRowBytes / sizeof(float);
  glovepose::nn::AlignedVector<float> buffer(rows * floats_per_row, 1.0f);
  std::mt19937 rng(1);
  std::vector<std::vector<std::size_t>> patterns(pattern_count);
  std::size_t chosen = 0;
  for (auto& pattern : patterns)
    for (std::size_t r = 0; r < rows; ++r)
      if (rng() & 1u) pattern.push_back(r);
  for (const auto& pattern : patterns) chosen += pattern.size();
  std::size_t pass = 0;
  for (auto _ : state) {
    Batch sum(0.0f);
    for (std::size_t r : patterns[pass++ % pattern_count]) {
      const float* row = &buffer[r * floats_per_row];
      Batch s0(0.0f), s1(0.0f);
      for (std::size_t i = 0; i < floats_per_row; i += 2 * Batch::size) {
        s0 += Batch::load_aligned(row + i);
        s1 += Batch::load_aligned(row + i + Batch::size);
      }
      sum += s0 + s1;
    }
    benchmark::DoNotOptimize(sum);
  }
  // Bytes of the rows read, averaged over the patterns.
  state.SetBytesProcessed(static_cast<std::int64_t>(static_cast<double>(state.iterations()) * static_cast<double>(chosen * kRowBytes) /
                                                    static_cast<double>(pattern_count)));
}
BENCHMARK(BM_StreamRows)->ArgNames({"KiB", "patterns"})->Args({4224, 1})->Args({4224, 16});

// The packed weights of w = 64 (4.3 MB F16, 8.6 MB F32) and w = 100 (10.8 MB F16, 21.5 MB F32).
BENCHMARK(BM_StreamBytes)->Arg(4321792)->Arg(8643584)->Arg(10757200)->Arg(21514400);

// One row with one entry of each pair of its 128 nonzero (the share of zeros ReLU leaves) times
// 128 x 128 weight blocks, gemm_sparse_rows as the batch-1 forward calls it. The argument is the
// weights' footprint in KiB: 32 is a single block re-read from the L1/L2, so that only the
// kernel's own instructions count; 4224 is as many blocks as the packed F16 weights of w = 64
// (4.3 MB), run one after another, so that the weights come from the L3 as in the forward.
template <typename W>
static void sparse_row_kernel(benchmark::State& state, W (*code)(std::mt19937&)) {
  using glovepose::nn::kernels::SimdBackend;
  constexpr int k = 128, n = 128, nonzero = 64;
  constexpr long block_bytes = static_cast<long>(k) * n * static_cast<long>(sizeof(W));
  const long blocks = std::max(1L, state.range(0) * 1024 / block_bytes);
  std::mt19937 rng(1);
  // Cache-line aligned as the forward's weights: with std::vector's 16-byte alignment every 256-byte
  // F16 row spanned five cache lines instead of four (Xeon: 117.5 against 88.1 us streamed, Fixed16).
  glovepose::nn::AlignedVector<W> weights(static_cast<std::size_t>(blocks * k * n));
  for (W& w : weights) w = code(rng);
  std::vector<int> index(nonzero);
  std::vector<float> value(nonzero, 0.5f);
  for (int i = 0; i < nonzero; ++i) index[static_cast<std::size_t>(i)] = 2 * i + static_cast<int>(rng() & 1u);
  const glovepose::nn::kernels::SparseRow row{index.data(), value.data(), nonzero};
  std::vector<float> y(n, 0.0f);
  float* out = y.data();
  for (auto _ : state) {
    for (long b = 0; b < blocks; ++b) SimdBackend::gemm_sparse_rows(&row, &out, 1, weights.data() + b * k * n, k, n);
    benchmark::ClobberMemory();
  }
  benchmark::DoNotOptimize(y.data());
  const double macs = static_cast<double>(state.iterations()) * static_cast<double>(blocks) * nonzero * n;
  state.counters["MAC_per_s"] = benchmark::Counter(macs, benchmark::Counter::kIsRate);
}
static void BM_SparseRowKernelF32(benchmark::State& state) {
  sparse_row_kernel<float>(state, [](std::mt19937& rng) { return std::uniform_real_distribution<float>(-0.05f, 0.05f)(rng); });
}
static void BM_SparseRowKernelFixed16(benchmark::State& state) {
  sparse_row_kernel<glovepose::nn::kernels::Fixed16>(
      state, [](std::mt19937& rng) { return static_cast<glovepose::nn::kernels::Fixed16>(static_cast<std::uint16_t>(rng())); });
}
static void BM_SparseRowKernelF16(benchmark::State& state) {
  // Finite binary16 codes of magnitude below 2 (exponent field below 16).
  sparse_row_kernel<std::uint16_t>(state, [](std::mt19937& rng) { return static_cast<std::uint16_t>(rng() & 0xBFFFu); });
}
static void BM_SparseRowKernelBF16(benchmark::State& state) {
  sparse_row_kernel<glovepose::nn::kernels::BFloat16>(
      // Normal magnitudes in [2^-15, 2), exponent field 112..127: a zero exponent field would make a
      // subnormal float, which Intel cores multiply through a microcode assist (ten times slower
      // here), a cost the shipped weights do not have.
      state, [](std::mt19937& rng) {
        return static_cast<glovepose::nn::kernels::BFloat16>(static_cast<std::uint16_t>((rng() & 0x807Fu) | (112u + rng() % 16u) << 7));
      });
}
BENCHMARK(BM_SparseRowKernelF32)->ArgName("KiB")->Arg(32)->Arg(4224);
BENCHMARK(BM_SparseRowKernelFixed16)->ArgName("KiB")->Arg(32)->Arg(4224);
BENCHMARK(BM_SparseRowKernelF16)->ArgName("KiB")->Arg(32)->Arg(4224);
BENCHMARK(BM_SparseRowKernelBF16)->ArgName("KiB")->Arg(32)->Arg(4224);
