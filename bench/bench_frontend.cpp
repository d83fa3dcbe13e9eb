// Google Benchmark cases for the sensor front end (run: build/bench/glovepose_bench).
#include <glovepose/glovepose.hpp>

#include <benchmark/benchmark.h>

#include <memory>

using namespace glovepose;

namespace {
std::shared_ptr<const sensor::CapacitanceSolver> solver() {
  static const auto s = std::make_shared<const sensor::CapacitanceSolver>(sensor::TraceLayout::glauser2019());
  return s;
}
sensor::CapacitanceSolver::Measurements measurements() {
  return solver()->measurement_matrix() * sensor::CapacitanceSolver::Capacitances::LinSpaced(44, 10.0, 20.0);
}
}  // namespace

// One least-squares solve of the paper's glove (44 x 180 operator times C_m).
static void BM_CapacitanceSolve(benchmark::State& state) {
  const auto cm = measurements();
  sensor::CapacitanceSolver::Capacitances cc(44);
  for (auto _ : state) {
    benchmark::DoNotOptimize(solver()->solve(cm, cc));
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_CapacitanceSolve);

// One frame's worth of row readings (180), with the solves every 16 rows they trigger.
static void BM_ReadoutFrameOfRows(benchmark::State& state) {
  sensor::Readout readout(solver());
  const auto cm = measurements();
  double t = 0.0;
  for (auto _ : state) {
    for (int r = 0; r < 180; ++r) benchmark::DoNotOptimize(readout.push_row(r, cm(r), t += 1e-4));
  }
  state.SetItemsProcessed(state.iterations() * 180);
}
BENCHMARK(BM_ReadoutFrameOfRows);

// Calibrate + grid-map one frame of 44 cells.
static void BM_NormalizeAndMap(benchmark::State& state) {
  const auto layout = sensor::TraceLayout::glauser2019();
  Eigen::VectorXd lo = Eigen::VectorXd::Constant(44, 5.0), hi = Eigen::VectorXd::Constant(44, 25.0);
  const sensor::CalibrationRange range(lo, hi, layout.cell_names());
  const grid::GridMap map = grid::GridMap::glauser2019();
  const Eigen::VectorXd cells = Eigen::VectorXd::LinSpaced(44, 10.0, 20.0);
  Eigen::VectorXd normalized(44);
  std::array<float, grid::kStretchValues> maps{};
  for (auto _ : state) {
    benchmark::DoNotOptimize(range.normalize(cells, normalized));
    benchmark::DoNotOptimize(map.to_stretch_maps(normalized.data(), maps));
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_NormalizeAndMap);

// 1-euro filtering of the 25 angles.
static void BM_OneEuro25(benchmark::State& state) {
  filter::OneEuroFilter<hand::kDofCount> f({60.0, 1.0, 0.1, 1.0});
  hand::Angles in{}, out{};
  double t = 0.0;
  for (auto _ : state) benchmark::DoNotOptimize(f.filter(in, t += 1.0 / 60, out));
}
BENCHMARK(BM_OneEuro25);

// Forward kinematics of the 18 frames.
static void BM_Kinematics(benchmark::State& state) {
  const hand::Kinematics fk;
  hand::Angles a{};
  a.fill(0.3);
  hand::Skeleton s;
  for (auto _ : state) {
    fk.pose(a, s);
    benchmark::DoNotOptimize(s);
  }
}
BENCHMARK(BM_Kinematics);
