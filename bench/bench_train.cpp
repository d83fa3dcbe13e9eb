// Google Benchmark cases for training: one optimiser step (forward in training mode, L2 loss,
// backward, Adam) of a batch. Names: BM_TrainStep/<arch>/<width>/<batch>/<threads> with arch 0 =
// U-Net, 1 = FCN; items/s = training samples per second. The threads are the trainer's own pool
// (Google Benchmark's thread count stays 1), so the time is the wall time of a whole step: UseRealTime.
#include <glovepose/grid/grid_map.hpp>
#include <glovepose/train/optimizer.hpp>
#include <glovepose/train/trainable_fcn.hpp>
#include <glovepose/train/trainable_unet.hpp>

#include <benchmark/benchmark.h>

#include <memory>
#include <vector>

using namespace glovepose;

namespace {
void BM_TrainStep(benchmark::State& state) {
  const bool unet = state.range(0) == 0;
  const int width = static_cast<int>(state.range(1)), batch = static_cast<int>(state.range(2)), threads = static_cast<int>(state.range(3));
  std::unique_ptr<train::TrainableNetwork> net;
  if (unet) {
    auto u = std::make_unique<train::TrainableUNet>(width, grid::GridMap::glauser2019(), batch);
    u->initialize(1);
    net = std::move(u);
  } else {
    auto f = std::make_unique<train::TrainableFcn>(44, width, batch);
    f->initialize(1);
    net = std::move(f);
  }
  core::ThreadPool pool(threads);
  train::Optimizer adam(net->parameters(), {});
  core::Rng rng(2);
  std::vector<float> x(static_cast<std::size_t>(batch) * 44), t(static_cast<std::size_t>(batch) * train::kTargets), g(t.size());
  for (float& v : x) v = static_cast<float>(rng.uniform(-1.0, 1.0));
  for (float& v : t) v = static_cast<float>(rng.uniform(-0.9, 0.9));
  for (auto _ : state) {
    net->forward(x.data(), batch, true, pool);
    benchmark::DoNotOptimize(train::mse_loss(net->output(), t.data(), static_cast<long>(t.size()), g.data()));
    net->backward(g.data(), pool);
    adam.step(net->parameters(), pool);
  }
  state.SetItemsProcessed(state.iterations() * batch);
  state.counters["parameters"] = static_cast<double>(net->parameters().trainable_count());
}
}  // namespace

BENCHMARK(BM_TrainStep)
    ->Args({0, 64, 1024, 1})
    ->Args({0, 64, 1024, 2})
    ->Args({0, 100, 1024, 2})
    ->Args({0, 64, 256, 2})
    ->Args({0, 64, 64, 2})
    ->Args({1, 2048, 1024, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
