// sensor::FloatingCells (sensor/floating_cells.hpp): a cell that falls below a quarter of its
// calibrated minimum is stood in for by the regression on the other cells, checked against a
// ridge regression solved in the test another way (an augmented least-squares problem by QR).
#include <doctest/doctest.h>

#include <glovepose/core/random.hpp>
#include <glovepose/sensor/floating_cells.hpp>

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/QR>

using namespace glovepose;

namespace {

constexpr int kCells = 6;
constexpr double kRate = 60.0;

// Cells of a sheet driven by two motions: each cell a positive baseline plus its own mix of the
// two and a little noise of its own, so every cell is largely predictable from the others.
Eigen::MatrixXd sheet_frames(int frames, std::uint64_t seed) {
  core::Rng rng(seed);
  Eigen::MatrixXd x(frames, kCells);
  for (int f = 0; f < frames; ++f) {
    const double t = f / kRate;
    const double a = std::sin(2.0 * 3.14159265358979 * 0.31 * t), b = std::cos(2.0 * 3.14159265358979 * 0.17 * t + 0.4);
    for (int c = 0; c < kCells; ++c) x(f, c) = 30.0 + 2.0 * c + (3.0 + c) * a + (5.0 - c) * b + rng.normal(0.0, 0.3);
  }
  return x;
}

sensor::CalibrationRange range_of(const Eigen::MatrixXd& x) {
  std::vector<std::string> names;
  for (int c = 0; c < kCells; ++c) names.push_back("c" + std::to_string(c));
  return sensor::CalibrationRange(x.colwise().minCoeff().transpose(), x.colwise().maxCoeff().transpose(), names);
}

}  // namespace

TEST_CASE("floating cells: a cell that drops out is its ridge regression on the others, fitted on the frames before") {
  const int seen = 3000;  // 50 s: within the memory, so every frame weighs the same
  const Eigen::MatrixXd x = sheet_frames(seen + 600, 5);
  sensor::FloatingCells stand_in(kCells, {});
  stand_in.set_range(range_of(x.topRows(seen)));
  Eigen::VectorXd cells(kCells);
  for (int f = 0; f < seen; ++f) {
    cells = x.row(f).transpose();
    REQUIRE(stand_in.apply(cells, f / kRate) == 0);
    REQUIRE(cells == x.row(f).transpose());  // an intact frame passes unchanged
  }

  // The reference: cell 2 from the others, centred, with the stand-in's ridge (1e-3 of the others'
  // mean variance), as the least-squares solution of [X; sqrt(n lambda) I] w = [y; 0].
  const int floating = 2;
  const Eigen::MatrixXd fit = x.topRows(seen);
  const Eigen::RowVectorXd mean = fit.colwise().mean();
  Eigen::MatrixXd centred = fit.rowwise() - mean;
  Eigen::MatrixXd others(seen, kCells - 1);
  for (int c = 0, k = 0; c < kCells; ++c)
    if (c != floating) others.col(k++) = centred.col(c);
  const double lambda = 1e-3 * others.colwise().squaredNorm().sum() / seen / (kCells - 1);
  Eigen::MatrixXd augmented(seen + kCells - 1, kCells - 1);
  augmented << others, std::sqrt(seen * lambda) * Eigen::MatrixXd::Identity(kCells - 1, kCells - 1);
  Eigen::VectorXd target = Eigen::VectorXd::Zero(seen + kCells - 1);
  target.head(seen) = centred.col(floating);
  const Eigen::VectorXd w = augmented.colPivHouseholderQr().solve(target);

  double worst = 0.0, error = 0.0, spread = 0.0;
  for (int f = seen; f < seen + 600; ++f) {
    cells = x.row(f).transpose();
    const double truth = cells(floating);
    cells(floating) = 0.05;  // floating: stray capacitance only
    REQUIRE(stand_in.apply(cells, f / kRate) == 1);
    double expected = mean(floating);
    for (int c = 0, k = 0; c < kCells; ++c)
      if (c != floating) expected += w(k++) * (x(f, c) - mean(c));
    worst = std::max(worst, std::abs(cells(floating) - expected));
    error += std::abs(cells(floating) - truth);
    spread += std::abs(truth - mean(floating));
    for (int c = 0; c < kCells; ++c)
      if (c != floating) REQUIRE(cells(c) == x(f, c));  // the connected cells are left as they are
  }
  MESSAGE("largest difference from the reference regression " << worst << " pF; mean error against the truth " << error / 600
                                                              << " pF, against the mean " << spread / 600 << " pF");
  CHECK(worst < 1e-9 * 30.0);
  CHECK(stand_in.floating() == std::vector<int>{floating});
  CHECK(error < 0.2 * spread);  // the others carry most of what it measured
}

TEST_CASE("floating cells: before enough frames the middle of the range, rejoins after the hold, off leaves cells alone") {
  const Eigen::MatrixXd x = sheet_frames(400, 7);
  const sensor::CalibrationRange range = range_of(x);
  sensor::FloatingCellsConfig config;
  sensor::FloatingCells stand_in(kCells, config);
  stand_in.set_range(range);
  Eigen::VectorXd cells(kCells);
  for (int f = 0; f < 60; ++f) {
    cells = x.row(f).transpose();
    (void)stand_in.apply(cells, f / kRate);
  }
  // 1 s of statistics, less than min_seconds (2 s): the middle of the calibrated range.
  cells = x.row(60).transpose();
  cells(4) = 0.25 * range.min()(4) - 0.01;  // just below the bound
  CHECK(stand_in.apply(cells, 1.0) == 1);
  CHECK(cells(4) == doctest::Approx(0.5 * (range.min()(4) + range.max()(4))));
  // Back above the bound: still stood in for until it read so for hold_seconds (0.5 s).
  double t = 1.0;
  for (int f = 61; f < 90; ++f) {
    t = f / kRate;
    cells = x.row(f).transpose();
    CHECK(stand_in.apply(cells, t) == 1);
  }
  cells = x.row(91).transpose();
  CHECK(stand_in.apply(cells, t + 0.5) == 0);
  CHECK(cells == x.row(91).transpose());
  CHECK(stand_in.floating().empty());

  // A cell whose calibrated minimum is not positive never floats.
  std::vector<std::string> names;
  for (int c = 0; c < kCells; ++c) names.push_back("c" + std::to_string(c));
  Eigen::VectorXd low = range.min(), high = range.max();
  low(1) = -1.0;
  stand_in.set_range(sensor::CalibrationRange(low, high, names));
  cells = x.row(100).transpose();
  cells(1) = -0.5;
  CHECK(stand_in.apply(cells, 3.0) == 0);
  CHECK(cells(1) == -0.5);

  config.enabled = false;
  sensor::FloatingCells off(kCells, config);
  off.set_range(range);
  cells = x.row(100).transpose();
  cells(3) = 0.0;
  CHECK(off.apply(cells, 3.0) == 0);
  CHECK(cells(3) == 0.0);

  config = {};
  config.below_share = 1.5;
  CHECK_THROWS_WITH_AS(sensor::FloatingCells(kCells, config), doctest::Contains("below_share 1.5"), Error);
}

TEST_CASE("floating cells: a frame the solve did not fit floats no cell and teaches nothing") {
  const Eigen::MatrixXd x = sheet_frames(300, 9);
  sensor::FloatingCells stand_in(kCells, {});
  stand_in.set_range(range_of(x));
  Eigen::VectorXd cells(kCells);
  for (int f = 0; f < 200; ++f) {
    cells = x.row(f).transpose();
    REQUIRE(stand_in.apply(cells, f / kRate) == 0);
  }
  const long frames = stand_in.frames_seen();
  const Eigen::VectorXd mean = stand_in.mean();
  // A frame the solve did not fit, every cell in range: passed on, and not learnt from.
  cells = x.row(199).transpose();
  CHECK(stand_in.apply(cells, 199.5 / kRate, false) == 0);
  CHECK(stand_in.frames_seen() == frames);
  CHECK(stand_in.mean() == mean);
  // A spike's frame (outlier rows): the low cell passes through as solved, the statistics stay.
  cells = x.row(200).transpose();
  cells(2) = 0.0;
  CHECK(stand_in.apply(cells, 200 / kRate, false) == 0);
  CHECK(cells(2) == 0.0);
  CHECK(stand_in.floating().empty());
  CHECK(stand_in.frames_seen() == frames);
  CHECK(stand_in.mean() == mean);
  // Still low on the next consistent frame: now it floats (a torn trace, its rows all read since).
  cells = x.row(201).transpose();
  cells(2) = 0.0;
  CHECK(stand_in.apply(cells, 201 / kRate, true) == 1);
  CHECK(stand_in.floating() == std::vector<int>{2});
  CHECK(cells(2) > 0.25 * range_of(x).min()(2));
  // Once floating, an inconsistent frame keeps standing in for it.
  cells = x.row(202).transpose();
  cells(2) = 0.0;
  CHECK(stand_in.apply(cells, 202 / kRate, false) == 1);

  // A cell low on frames that never fit again (a row that stays an outlier) floats once it has
  // read low for confirm_seconds (0.25 s): not at 0.2 s, at 0.25 s.
  sensor::FloatingCells persistent(kCells, {});
  persistent.set_range(range_of(x));
  for (int f = 0; f < 200; ++f) {
    cells = x.row(f).transpose();
    REQUIRE(persistent.apply(cells, f / kRate) == 0);
  }
  for (int f = 200; f <= 215; ++f) {
    cells = x.row(f).transpose();
    cells(5) = 0.0;
    const int stood_in = persistent.apply(cells, f / kRate, false);
    CAPTURE(f);
    CHECK(stood_in == (f - 200 >= 15 ? 1 : 0));  // 15 frames at 60 Hz: 0.25 s
  }
  CHECK(persistent.floating() == std::vector<int>{5});
}
