// Google Benchmark cases for the U-Net forward (run: build/bench/glovepose_bench --benchmark_filter=UNet).
// BM_UNetForwardTeam/<width>/members:<n>: batch 1 by a Team of n threads (UNet::forward with a Team).
// Names: BM_UNetForward[F32|Fixed16|F16|BF16]/<width>/<batch>[/threads:N]: BM_UNetForward is the
// real-time path, realtime_storage() (the fastest 16-bit storage within 0.1 degree of F32 with this
// instruction set: Fixed16 with AVX-512 VBMI2, F16 with AVX2 and F16C; its label names it); F32 the
// exact one; Fixed16 and F16 the two within that bound; BF16, whose rounding exceeds it on the
// shipped model. Random weights with BN statistics and random inputs in [-1, 1]: with up to 32
// frames per forward (batch 1, and the batches' chunks of 32) the time depends on how many
// activations are zero (about half after each ReLU, as with the trained model; docs/performance.md).
#include <glovepose/nn/unet_diagnostics.hpp>
#include <glovepose/nn/unet.hpp>
#include <glovepose/core/team.hpp>

#include "random_unet.hpp"

#include <benchmark/benchmark.h>

#include <map>
#include <mutex>
#include <numeric>
#include <random>
#include <vector>

using namespace glovepose::nn;

namespace {

// Networks are built once per (width, storage) and shared by the benchmark threads.
const UNet<>& network(int width, WeightStorage storage) {
  static std::map<std::pair<int, int>, UNet<>> cache;
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  const auto key = std::make_pair(width, static_cast<int>(storage));
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, UNet<>::from_tensors(random_unet_tensors(width), width, 1e-5, storage)).first;
  return it->second;
}

void run(benchmark::State& state, WeightStorage storage) {
  const int width = static_cast<int>(state.range(0));
  const int batch = static_cast<int>(state.range(1));
  const UNet<>& net = network(width, storage);
  // Frames of a batch go through in chunks that keep the activations in cache.
  const int chunk = std::min(batch, kSparseMaxFrames);
  auto ws = net.make_workspace(chunk);
  std::mt19937 rng(static_cast<unsigned>(state.thread_index()) + 5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> in(static_cast<std::size_t>(batch) * kUNetInputs), out(static_cast<std::size_t>(batch) * kUNetOutputs);
  for (float& v : in) v = u(rng);
  for (auto _ : state) {
    for (int f = 0; f < batch; f += chunk)
      benchmark::DoNotOptimize(net.forward(in.data() + static_cast<long>(f) * kUNetInputs, out.data() + static_cast<long>(f) * kUNetOutputs,
                                           std::min(chunk, batch - f), ws));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * batch);
  state.counters["weight_MB"] = static_cast<double>(net.weight_bytes()) / 1e6;
  // Share of the hidden activations that are exactly zero (mean over the 7 layers, last chunk):
  // up to 32 frames per forward the products skip them, so the time depends on it.
  const int last_chunk = batch - (batch - 1) / chunk * chunk;
  const auto zeros = zero_fractions(net, ws, last_chunk);
  state.counters["zero_share"] = std::accumulate(zeros.begin(), zeros.end(), 0.0) / static_cast<double>(zeros.size());
  // At batch 1: the bytes of weights the frame reads (the rows that meet a nonzero activation),
  // which come from the L3 every frame; with BM_StreamRows' rate, the forward's floor.
  if (batch == 1) state.counters["read_MB"] = static_cast<double>(weight_bytes_read(net, ws)) / 1e6;
  state.SetLabel(storage_name(storage));
}

// One frame by a Team of `team` members (the caller and team - 1 workers) sharing each large
// layer's products (UNet::forward with a Team); compare with BM_UNetForward/<width>/1 in the same run.
void run_team(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int members = static_cast<int>(state.range(1));
  const UNet<>& net = network(width, realtime_storage());
  glovepose::core::Team team(members);
  auto ws = net.make_workspace(1, members);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> in(kUNetInputs), out(kUNetOutputs);
  for (float& v : in) v = u(rng);
  for (auto _ : state) {
    benchmark::DoNotOptimize(net.forward(in.data(), out.data(), 1, ws, team));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(storage_name(realtime_storage()));
}
}  // namespace

static void BM_UNetForwardTeam(benchmark::State& state) { run_team(state); }

static void BM_UNetForward(benchmark::State& state) { run(state, realtime_storage()); }
static void BM_UNetForwardF32(benchmark::State& state) { run(state, WeightStorage::F32); }
static void BM_UNetForwardFixed16(benchmark::State& state) { run(state, WeightStorage::Fixed16); }
static void BM_UNetForwardF16(benchmark::State& state) { run(state, WeightStorage::F16); }
static void BM_UNetForwardBF16(benchmark::State& state) { run(state, WeightStorage::BF16); }

BENCHMARK(BM_UNetForward)->Args({48, 1})->Args({64, 1})->Args({100, 1})->Args({196, 1})->Args({64, 1024})->UseRealTime();
BENCHMARK(BM_UNetForward)->Args({64, 1024})->Threads(2)->UseRealTime();
BENCHMARK(BM_UNetForwardTeam)->ArgNames({"", "members"})->Args({64, 2})->Args({100, 2})->Args({64, 1})->UseRealTime();
BENCHMARK(BM_UNetForwardF32)->Args({48, 1})->Args({64, 1})->Args({100, 1})->Args({196, 1})->Args({64, 1024})->UseRealTime();
BENCHMARK(BM_UNetForwardF32)->Args({64, 1024})->Threads(2)->UseRealTime();
BENCHMARK(BM_UNetForwardFixed16)->Args({48, 1})->Args({64, 1})->Args({100, 1})->Args({64, 1024})->UseRealTime();
BENCHMARK(BM_UNetForwardFixed16)->Args({64, 1024})->Threads(2)->UseRealTime();
BENCHMARK(BM_UNetForwardF16)->Args({48, 1})->Args({64, 1})->Args({100, 1})->Args({64, 1024})->UseRealTime();
BENCHMARK(BM_UNetForwardF16)->Args({64, 1024})->Threads(2)->UseRealTime();
BENCHMARK(BM_UNetForwardBF16)->Args({48, 1})->Args({64, 1})->Args({100, 1})->Args({64, 1024})->UseRealTime();
BENCHMARK(BM_UNetForwardBF16)->Args({64, 1024})->Threads(2)->UseRealTime();
