// The two limits the U-Net forward races (run: build/bench/glovepose_bench --benchmark_filter=Peak|Stream):
//   BM_PeakFma          this core's F32 multiply-add rate (independent FMA chains, xsimd default arch)
//   BM_StreamBytes/N    the rate at which one core re-reads an N-byte buffer (the weights at batch 1)
#include <glovepose/nn/tensor.hpp>

#include <benchmark/benchmark.h>
#include <xsimd/xsimd.hpp>

using Batch = xsimd::batch<float>;

static void BM_PeakFma(benchmark::State& state) {
  constexpr int kChains = 16;  // latency 4 x 2 FMA units x 2 of slack
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
// The packed weights of w = 64 (4.3 MB F16, 8.6 MB F32) and w = 100 (10.8 MB F16, 21.5 MB F32).
BENCHMARK(BM_StreamBytes)->Arg(4321792)->Arg(8643584)->Arg(10757200)->Arg(21514400);
