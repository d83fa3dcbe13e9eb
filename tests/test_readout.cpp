#include <glovepose/sensor/readout.hpp>

#include <doctest/doctest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <limits>
#include <numeric>
#include <random>
#include <vector>

#include "alloc_counter.hpp"

using namespace glovepose;
using namespace glovepose::sensor;

namespace {
std::shared_ptr<const CapacitanceSolver> glove_solver() {
  static const auto solver = std::make_shared<const CapacitanceSolver>(TraceLayout::glauser2019());
  return solver;
}
constexpr double kRowPeriod = 1.0 / (60.0 * 180.0);  // 180 rows per frame, 60 frames per second

// Measurements of frame f: M times cells that drift linearly with f.
CapacitanceSolver::Measurements frame_measurements(int f) {
  const CapacitanceSolver::Capacitances cells = CapacitanceSolver::Capacitances::LinSpaced(44, 10.0, 20.0).array() + 0.1 * f;
  return glove_solver()->measurement_matrix() * cells;
}
}  // namespace

TEST_CASE("readout: a whole frame is solved at once") {
  Readout readout(glove_solver());
  CHECK(readout.push_frame(frame_measurements(0), 0.0) == Status::Solved);
  const CapacitanceSolver::Capacitances truth = CapacitanceSolver::Capacitances::LinSpaced(44, 10.0, 20.0);
  CHECK((readout.frame().cells - truth).cwiseAbs().maxCoeff() < 1e-10);
  CHECK(readout.frame().sequence == 1);
  CHECK(readout.frame().oldest_age == 0.0);
}

TEST_CASE("readout: rows one at a time, NotReady until every row was read, solved at once, then a solve every 16 updates") {
  Readout readout(glove_solver());
  int solves = 0, not_ready = 0;
  std::vector<int> solve_positions;
  for (int f = 0; f < 3; ++f) {
    const auto cm = frame_measurements(f);
    for (int r = 0; r < 180; ++r) {
      const int k = f * 180 + r;
      const Status s = readout.push_row(r, cm(r), k * kRowPeriod);
      if (s == Status::NotReady) ++not_ready;
      if (s == Status::Solved) {
        ++solves;
        solve_positions.push_back(k);
      }
    }
  }
  CHECK(not_ready == 179);  // the first 179 rows: some row still unread
  REQUIRE(solves >= 2);
  // The first complete picture (index 179) is solved at once; then every 16th reading from the
  // start (indices 15, 31, ...): 191, 207, ..., 527 (the extra solve leaves the cadence as it was).
  CHECK(solve_positions.front() == 179);
  CHECK(solve_positions[1] == 191);
  for (std::size_t i = 2; i < solve_positions.size(); ++i) CHECK(solve_positions[i] - solve_positions[i - 1] == 16);
  CHECK(solves == 23);
}

TEST_CASE("readout: the solve uses the mean of each row's last 5 readings, and reports the oldest reading's age") {
  ReadoutConfig config;
  config.mean_window = 5;
  config.solve_every = 16;
  Readout readout(glove_solver(), config);
  // Stream 12 frames row by row; stop right after a solve in the last frame.
  Status last = Status::Ok;
  int stop_f = -1, stop_r = -1;
  for (int f = 0; f < 12 && stop_f < 0; ++f) {
    const auto cm = frame_measurements(f);
    for (int r = 0; r < 180; ++r) {
      last = readout.push_row(r, cm(r), (f * 180 + r) * kRowPeriod);
      if (f == 11 && last == Status::Solved) {
        stop_f = f;
        stop_r = r;
        break;
      }
    }
  }
  REQUIRE(stop_f == 11);
  // Row q <= stop_r holds frames f-4..f, row q > stop_r holds frames f-5..f-1.
  CapacitanceSolver::Measurements expected_mean(180);
  for (int q = 0; q < 180; ++q) {
    const int newest = q <= stop_r ? stop_f : stop_f - 1;
    double sum = 0.0;
    for (int k = 0; k < 5; ++k) sum += frame_measurements(newest - k)(q);
    expected_mean(q) = sum / 5.0;
  }
  CHECK((readout.filtered_measurements() - expected_mean).cwiseAbs().maxCoeff() < 1e-9);
  CapacitanceSolver::Capacitances expected_cells(44);
  REQUIRE(glove_solver()->solve(expected_mean, expected_cells) == Status::Ok);
  CHECK((readout.frame().cells - expected_cells).cwiseAbs().maxCoeff() < 1e-9);
  // The oldest reading used is row stop_r + 1 of frame stop_f - 5.
  const double newest_time = (stop_f * 180 + stop_r) * kRowPeriod;
  const double oldest_time = ((stop_f - 5) * 180 + stop_r + 1) * kRowPeriod;
  CHECK(readout.frame().timestamp == doctest::Approx(newest_time));
  CHECK(readout.frame().oldest_age == doctest::Approx(newest_time - oldest_time));
  CHECK(readout.frame().oldest_age == doctest::Approx((5 * 180 - 1) * kRowPeriod));  // ~83 ms at 60 Hz
}

TEST_CASE("readout: window and solve interval are configurable") {
  ReadoutConfig config;
  config.mean_window = 1;
  config.solve_every = 180;
  Readout readout(glove_solver(), config);
  int solves = 0;
  for (int f = 0; f < 4; ++f) {
    const auto cm = frame_measurements(f);
    for (int r = 0; r < 180; ++r) solves += readout.push_row(r, cm(r), (f * 180 + r) * kRowPeriod) == Status::Solved;
  }
  CHECK(solves == 4);  // once at the end of every full cycle
  const CapacitanceSolver::Capacitances truth = CapacitanceSolver::Capacitances::LinSpaced(44, 10.0, 20.0).array() + 0.1 * 3;
  CHECK((readout.frame().cells - truth).cwiseAbs().maxCoeff() < 1e-9);  // window 1: no averaging
  config.mean_window = 0;
  CHECK_THROWS_WITH_AS(Readout(glove_solver(), config), doctest::Contains("mean_window 0, expected at least 1"), Error);
  config.mean_window = 5;
  config.solve_every = 0;
  CHECK_THROWS_WITH_AS(Readout(glove_solver(), config), doctest::Contains("solve_every 0, expected at least 1"), Error);
  CHECK_THROWS_WITH_AS(Readout(nullptr), doctest::Contains("no solver"), Error);
}

TEST_CASE("readout: streamed row by row, a static hand's cell estimates are the least-squares solve with its noise, w readings s^2/w") {
  // The streaming estimate: every row's latest w readings, a solve every 16 rows. On a static hand
  // each solve must be the least-squares solve of the rows' current means (computed here by the
  // normal equations, apart from the readout's QR), and the estimates' spread s^2 (M^T M)^-1 / w.
  const auto& m = glove_solver()->measurement_matrix();
  const Eigen::MatrixXd normal_inverse = (m.transpose() * m).ldlt().solve(Eigen::MatrixXd::Identity(44, 44));
  const CapacitanceSolver::Capacitances truth = CapacitanceSolver::Capacitances::LinSpaced(44, 10.0, 30.0);
  const CapacitanceSolver::Measurements clean = m * truth;
  const double sigma = 0.05;  // pF per reading
  for (int window : {1, 4}) {
    CAPTURE(window);
    ReadoutConfig config;
    config.mean_window = window;
    Readout readout(glove_solver(), config);
    std::mt19937 rng(17 + window);
    std::normal_distribution<double> noise(0.0, sigma);
    std::vector<std::vector<double>> held(180);  // each row's readings, newest last
    Eigen::VectorXd squared_error = Eigen::VectorXd::Zero(44);
    double worst_solve_gap = 0.0;
    int solves = 0;
    const int cycles = 1500;
    for (int f = 0; f < cycles; ++f)
      for (int r = 0; r < 180; ++r) {
        const double reading = clean(r) + noise(rng);
        held[static_cast<std::size_t>(r)].push_back(reading);
        if (static_cast<int>(held[static_cast<std::size_t>(r)].size()) > window)
          held[static_cast<std::size_t>(r)].erase(held[static_cast<std::size_t>(r)].begin());
        if (readout.push_row(r, reading, (f * 180 + r) * kRowPeriod) != Status::Solved || f < window) continue;
        Eigen::VectorXd means(180);
        for (int q = 0; q < 180; ++q) {
          const auto& h = held[static_cast<std::size_t>(q)];
          means(q) = std::accumulate(h.begin(), h.end(), 0.0) / static_cast<double>(h.size());
        }
        const Eigen::VectorXd batch = normal_inverse * (m.transpose() * means);
        worst_solve_gap = std::max(worst_solve_gap, (readout.frame().cells - batch).cwiseAbs().maxCoeff());
        squared_error += (readout.frame().cells - truth).cwiseAbs2();
        ++solves;
      }
    squared_error /= solves;
    CHECK(worst_solve_gap < 1e-9);
    const double expected_total = sigma * sigma * normal_inverse.trace() / window;
    MESSAGE("window " << window << ", " << solves << " solves: mean squared error of C_c " << squared_error.sum() << ", theory "
                      << expected_total);
    // Consecutive solves share most readings, so the spread is estimated from fewer independent
    // samples than solves: the cells' total within 10%, each cell within 35%.
    CHECK(squared_error.sum() == doctest::Approx(expected_total).epsilon(0.10));
    for (int c = 0; c < 44; ++c) {
      INFO("cell " << c);
      CHECK(squared_error(c) == doctest::Approx(sigma * sigma * normal_inverse(c, c) / window).epsilon(0.35));
    }
  }
}

TEST_CASE("readout: a row is an outlier when its residual exceeds max_reading_residual / sqrt(readings it holds)") {
  // A constant error d on row q of a static hand leaves the residual (1 - h_qq) d on that row, with
  // h the least-squares hat matrix M (M^T M)^-1 M^T (computed here, apart from the solver's QR).
  const auto& m = glove_solver()->measurement_matrix();
  const Eigen::MatrixXd hat = m * (m.transpose() * m).inverse() * m.transpose();
  constexpr int q = 37;
  const double leverage_left = 1.0 - hat(q, q);
  REQUIRE(leverage_left > 0.1);
  ReadoutConfig config;
  config.mean_window = 4;
  const double bound = config.max_reading_residual;
  const auto stream = [&](double residual, int frames) {
    Readout readout(glove_solver(), config);
    CapacitanceSolver::Measurements cm = frame_measurements(0);
    cm(q) += residual / leverage_left;
    for (int f = 0; f < frames; ++f) REQUIRE(readout.push_frame(cm, f * 180 * kRowPeriod) == Status::Solved);
    CHECK(readout.frame().health.max_residual == doctest::Approx(residual).epsilon(1e-6));
    CHECK(readout.frame().health.filling_rows == (frames < 4 ? 180 : 0));
    return readout.frame().health.outlier_rows;
  };
  // Full rows (4 readings): the bound is bound / 2.
  CHECK(stream(0.9 * bound / 2.0, 4) == 0);
  CHECK(stream(1.1 * bound / 2.0, 4) == 1);
  // The same disagreement backed by one reading is within that reading's noise; by four, it is not.
  CHECK(stream(0.7 * bound, 1) == 0);
  CHECK(stream(0.7 * bound, 4) == 1);
  CHECK(stream(1.1 * bound, 1) == 1);
  config.max_reading_residual = 0.0;
  CHECK_THROWS_WITH_AS(Readout(glove_solver(), config), doctest::Contains("max_reading_residual > 0"), Error);
}

TEST_CASE("readout: bad readings get a status, are not mixed in, and the next good rows are used normally") {
  Readout clean(glove_solver());
  Readout dirty(glove_solver());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  std::uint32_t injected = 0;
  for (int f = 0; f < 6; ++f) {
    const auto cm = frame_measurements(f);
    for (int r = 0; r < 180; ++r) {
      const double t = (f * 180 + r) * kRowPeriod;
      const Status expected = clean.push_row(r, cm(r), t);
      if (f >= 2 && r % 20 == 7) {  // inject every bad kind between good rows
        CHECK(dirty.push_row(r, nan, t) == Status::NonFinite);
        CHECK(dirty.push_row(r, inf, t) == Status::NonFinite);
        CHECK(dirty.push_row(r, cm(r), nan) == Status::NonFinite);
        CHECK(dirty.push_row(r, -1.0, t) == Status::Negative);
        CHECK(dirty.push_row(-1, cm(r), t) == Status::UnknownIndex);
        CHECK(dirty.push_row(180, cm(r), t) == Status::UnknownIndex);
        CHECK(dirty.push_row(r, 1e6, t - 1.0) == Status::TimestampBackwards);
        injected += 7;
      }
      CHECK(dirty.push_row(r, cm(r), t) == expected);
    }
  }
  CHECK(dirty.frame().sequence == clean.frame().sequence);
  CHECK(dirty.frame().cells == clean.frame().cells);  // bit-identical: nothing bad was mixed in
  CHECK(dirty.frame().oldest_age == clean.frame().oldest_age);
  CHECK(injected > 0);

  // A whole frame: bad rows are skipped and counted, the rest is solved.
  Readout framed(glove_solver());
  REQUIRE(framed.push_frame(frame_measurements(0), 0.0) == Status::Solved);
  auto cm = frame_measurements(1);
  cm(3) = nan;
  cm(4) = -2.0;
  CHECK(framed.push_frame(cm, 1.0 / 60) == Status::Solved);
  CHECK(framed.frame().rejected == 2);
  CHECK(std::isfinite(framed.frame().cells.sum()));
  CHECK(framed.push_frame(cm, 0.0) == Status::TimestampBackwards);
  CHECK(framed.push_frame(cm, inf) == Status::NonFinite);
  CHECK(framed.frame().sequence == 2);
}

TEST_CASE("readout: reset forgets all readings") {
  Readout readout(glove_solver());
  REQUIRE(readout.push_frame(frame_measurements(0), 5.0) == Status::Solved);
  readout.reset();
  CHECK(readout.push_row(0, 1.0, 0.0) == Status::NotReady);  // earlier timestamp accepted after reset
}

TEST_CASE("readout: per-reading calls allocate nothing") {
  Readout readout(glove_solver());
  const auto cm = frame_measurements(0);
  const std::size_t allocations = test::allocations_during([&] {
    for (int f = 0; f < 3; ++f)
      for (int r = 0; r < 180; ++r) (void)readout.push_row(r, cm(r), (f * 180 + r) * kRowPeriod);
    (void)readout.push_frame(cm, 1.0);
    (void)readout.push_row(-5, std::numeric_limits<double>::quiet_NaN(), 0.0);
  });
  CHECK(allocations == 0);
}

TEST_CASE("readout: disconnected rows are left out, and the solve is least squares over the rest") {
  const Eigen::MatrixXd& m = glove_solver()->measurement_matrix();
  const TraceLayout& layout = glove_solver()->layout();
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.3);
  CapacitanceSolver::Measurements cm = frame_measurements(0);
  for (int r = 0; r < 180; ++r) cm(r) += noise(rng);
  // Top trace 4's 15 rows read stray capacitance only (a channel that no longer drives it).
  std::vector<int> kept;
  for (int r = 0; r < 180; ++r) {
    if (r % layout.top_traces() == 4)
      cm(r) = 0.05;
    else
      kept.push_back(r);
  }
  // The reference: a QR least-squares solve of the kept rows alone.
  Eigen::MatrixXd m_kept(static_cast<Eigen::Index>(kept.size()), 44);
  Eigen::VectorXd cm_kept(static_cast<Eigen::Index>(kept.size()));
  for (std::size_t k = 0; k < kept.size(); ++k) {
    m_kept.row(static_cast<Eigen::Index>(k)) = m.row(kept[k]);
    cm_kept(static_cast<Eigen::Index>(k)) = cm(kept[k]);
  }
  const Eigen::VectorXd reference = m_kept.colPivHouseholderQr().solve(cm_kept);

  Readout readout(glove_solver());
  std::size_t allocations = 0;
  allocations += test::allocations_during([&] { REQUIRE(readout.push_frame(cm, 0.0) == Status::Solved); });
  CHECK((readout.frame().cells - reference).cwiseAbs().maxCoeff() < 1e-9);
  CHECK(readout.frame().health.disconnected_rows == 15);
  CHECK(readout.frame().health.excluded_rows == 15);
  CHECK(readout.frame().health.outlier_rows == 0);  // left out: not counted as disagreeing
  const CapacitanceSolver::Capacitances truth = CapacitanceSolver::Capacitances::LinSpaced(44, 10.0, 20.0);
  MESSAGE("without top trace 4: largest cell error " << (readout.frame().cells - truth).cwiseAbs().maxCoeff() << " pF (reading noise 0.3)");

  // Connected again: all rows, the full solve.
  allocations += test::allocations_during([&] { REQUIRE(readout.push_frame(frame_measurements(0), 1.0) == Status::Solved); });
  CHECK(readout.frame().health.excluded_rows == 0);
  CHECK((readout.frame().cells - truth).cwiseAbs().maxCoeff() < 1e-9);
  CHECK(allocations == 0);

  // Rows whose loss leaves a cell undetermined stay in (flagged by the estimator): every row that
  // sees cell 0 (its bottom trace as source with another top, or its top with another bottom).
  const Cell& cell = layout.cells()[0];
  CapacitanceSolver::Measurements blind = frame_measurements(0);
  int lost = 0;
  for (int r = 0; r < 180; ++r)
    if ((r / layout.top_traces() == cell.bottom) != (r % layout.top_traces() == cell.top)) blind(r) = 0.05, ++lost;
  Readout guarded(glove_solver());
  REQUIRE(guarded.push_frame(blind, 0.0) == Status::Solved);
  CHECK(guarded.frame().health.disconnected_rows == lost);
  CHECK(guarded.frame().health.excluded_rows == 0);

  // More than max_excluded_share of the rows: they stay in.
  ReadoutConfig strict;
  strict.max_excluded_share = 0.05;  // 9 rows
  Readout capped(glove_solver(), strict);
  REQUIRE(capped.push_frame(cm, 0.0) == Status::Solved);
  CHECK(capped.frame().health.disconnected_rows == 15);
  CHECK(capped.frame().health.excluded_rows == 0);
}

TEST_CASE("readout: a row left out of the solve may stop delivering without going stale") {
  // Top trace 4's rows read about 0 pF (a torn trace: stray capacitance and noise): the readings
  // below 0 are rejected, so after a while these rows hold only old readings. They are not in the
  // solve, so they are not stale; a kept row that stops delivering still is.
  const TraceLayout& layout = glove_solver()->layout();
  const CapacitanceSolver::Measurements cm = frame_measurements(0);
  Readout readout(glove_solver());
  const auto cycle = [&](int k, bool torn_rows_negative, int silent_row) {
    Status last = Status::NotReady;
    for (int r = 0; r < 180; ++r) {
      if (r == silent_row) continue;
      const bool torn = r % layout.top_traces() == 4;
      const double value = torn ? (torn_rows_negative ? -0.02 : 0.05) : cm(r);
      const Status status = readout.push_row(r, value, (k * 180 + r) * kRowPeriod);
      if (status == Status::Solved) last = status;
    }
    return last;
  };
  for (int k = 0; k < 4; ++k) REQUIRE(cycle(k, false, -1) == Status::Solved);
  for (int k = 4; k < 12; ++k) REQUIRE(cycle(k, true, -1) == Status::Solved);
  CHECK(readout.frame().health.excluded_rows == 15);
  CHECK(readout.frame().health.stale_rows == 0);
  CHECK(readout.frame().health.outlier_rows == 0);
  // Row 0 (kept) silent for the same 8 cycles: stale.
  for (int k = 12; k < 20; ++k) REQUIRE(cycle(k, true, 0) == Status::Solved);
  CHECK(readout.frame().health.stale_rows == 1);
}
