// Google Benchmark cases for the FCN forward (run: build/bench/glovepose_bench --benchmark_filter=Fcn).
// Names: BM_FcnForward[F32]/<hidden>/<batch>: BM_FcnForward is the real-time path,
// realtime_storage() (its label names it), F32 the exact one. 44 inputs; random weights scaled
// like a trained network's (He-uniform) and random inputs in [0, 1] (calibrated cells): about half
// of each hidden layer is zero after its ReLU, and up to 32 frames per forward the products skip
// those entries, so the time depends on that share as with the trained model.
#include <glovepose/nn/fcn.hpp>

#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <random>
#include <vector>

using namespace glovepose::nn;

namespace {
constexpr int kInputs = 44;

const Fcn<>& network(int hidden, WeightStorage storage) {
  static std::map<std::pair<int, int>, Fcn<>> cache;  // benchmarks run on one thread
  const auto key = std::make_pair(hidden, static_cast<int>(storage));
  auto it = cache.find(key);
  if (it == cache.end()) {
    std::mt19937 rng(1);
    TensorMap tensors;
    for (const auto& [name, shape] : fcn_tensor_shapes(kInputs, hidden)) {
      Tensor t{shape, {}};
      t.values.resize(static_cast<std::size_t>(t.element_count()));
      const float a = shape.size() == 2 ? std::sqrt(6.0f / static_cast<float>(shape[1])) : 0.05f;
      std::uniform_real_distribution<float> u(-a, a);
      for (float& v : t.values) v = u(rng);
      tensors[name] = std::move(t);
    }
    it = cache.emplace(key, Fcn<>::from_tensors(tensors, kInputs, hidden, storage)).first;
  }
  return it->second;
}

void run(benchmark::State& state, WeightStorage storage) {
  const int hidden = static_cast<int>(state.range(0)), batch = static_cast<int>(state.range(1));
  const Fcn<>& net = network(hidden, storage);
  const int chunk = std::min(batch, kSparseMaxFrames);
  auto ws = net.make_workspace(chunk);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> in(static_cast<std::size_t>(batch) * kInputs), out(static_cast<std::size_t>(batch) * kFcnOutputs);
  for (float& v : in) v = u(rng);
  for (auto _ : state) {
    for (int f = 0; f < batch; f += chunk)
      benchmark::DoNotOptimize(net.forward(in.data() + static_cast<long>(f) * kInputs, out.data() + static_cast<long>(f) * kFcnOutputs,
                                           std::min(chunk, batch - f), ws));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * batch);
  state.counters["weight_MB"] = static_cast<double>(net.weight_bytes()) / 1e6;
  state.SetLabel(storage_name(storage));
}
}  // namespace

static void BM_FcnForward(benchmark::State& state) { run(state, realtime_storage()); }
static void BM_FcnForwardF32(benchmark::State& state) { run(state, WeightStorage::F32); }

BENCHMARK(BM_FcnForward)->Args({512, 1})->Args({1024, 1})->Args({2048, 1})->Args({512, 1024})->UseRealTime();
BENCHMARK(BM_FcnForwardF32)->Args({512, 1})->Args({1024, 1})->Args({2048, 1})->Args({512, 1024})->UseRealTime();
