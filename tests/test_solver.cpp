#include <glovepose/sensor/solver.hpp>

#include <doctest/doctest.h>

#include <random>

#include "alloc_counter.hpp"

using namespace glovepose;
using namespace glovepose::sensor;

TEST_CASE("solver: exact recovery of the cell capacitances from noise-free readings") {
  const CapacitanceSolver solver(TraceLayout::glauser2019());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> capacitance(5.0, 50.0);  // pF-scale, positive
  for (int trial = 0; trial < 20; ++trial) {
    CapacitanceSolver::Capacitances truth(44);
    for (int c = 0; c < 44; ++c) truth(c) = capacitance(rng);
    const CapacitanceSolver::Measurements measured = solver.measurement_matrix() * truth;
    CapacitanceSolver::Capacitances solved(44);
    REQUIRE(solver.solve(measured, solved) == Status::Ok);
    CHECK((solved - truth).cwiseAbs().maxCoeff() < 1e-10);
  }
}

TEST_CASE("solver: with Gaussian noise on C_m the error of C_c matches least-squares theory") {
  // Theory: with noise of variance s^2 on every measurement, the least-squares estimate has
  // covariance s^2 (M^T M)^-1, so E|C_c - truth|^2 = s^2 trace((M^T M)^-1), cell c's variance
  // s^2 [(M^T M)^-1]_cc. Computed here independently of the solver (normal equations, LDLT).
  const CapacitanceSolver solver(TraceLayout::glauser2019());
  const Eigen::MatrixXd& m = solver.measurement_matrix();
  const Eigen::MatrixXd covariance = (m.transpose() * m).ldlt().solve(Eigen::MatrixXd::Identity(44, 44));
  const double sigma = 0.05;
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, sigma);
  CapacitanceSolver::Capacitances truth = CapacitanceSolver::Capacitances::LinSpaced(44, 10.0, 30.0);
  const CapacitanceSolver::Measurements clean = m * truth;
  const int trials = 6000;
  Eigen::VectorXd squared_error = Eigen::VectorXd::Zero(44);
  for (int t = 0; t < trials; ++t) {
    CapacitanceSolver::Measurements noisy = clean;
    for (int r = 0; r < 180; ++r) noisy(r) += noise(rng);
    CapacitanceSolver::Capacitances solved(44);
    REQUIRE(solver.solve(noisy, solved) == Status::Ok);
    squared_error += (solved - truth).cwiseAbs2();
  }
  squared_error /= trials;
  const double expected_total = sigma * sigma * covariance.trace();
  const double measured_total = squared_error.sum();
  MESSAGE("mean squared error of C_c: measured " << measured_total << ", theory " << expected_total);
  CHECK(measured_total == doctest::Approx(expected_total).epsilon(0.10));
  for (int c = 0; c < 44; ++c) {
    INFO("cell " << c);
    CHECK(squared_error(c) == doctest::Approx(sigma * sigma * covariance(c, c)).epsilon(0.10));
  }
}

TEST_CASE("solver: the condition number of M is exposed and equals its singular-value ratio") {
  const CapacitanceSolver solver(TraceLayout::glauser2019());
  const Eigen::BDCSVD<Eigen::MatrixXd> svd(solver.measurement_matrix());
  const auto& s = svd.singularValues();
  CHECK(solver.condition_number() == doctest::Approx(s(0) / s(s.size() - 1)).epsilon(1e-9));
  MESSAGE("cond(M) of the paper's glove: " << solver.condition_number());
  CHECK(solver.condition_number() < 100.0);  // well-posed: noise is not blown up
  // P is a left inverse of M.
  CHECK((solver.solution_operator() * solver.measurement_matrix() - Eigen::MatrixXd::Identity(44, 44)).cwiseAbs().maxCoeff() < 1e-10);
}

TEST_CASE("solver: a rank-deficient layout is rejected, naming the cells that cannot be told apart") {
  // Two bottom x two top traces with all four cells: measurement (i, j) sees the two cells that share
  // exactly one trace with the source, so (0,0) and (1,1) see the same pair: rank 2.
  std::vector<Cell> cells;
  for (int b = 0; b < 2; ++b)
    for (int t = 0; t < 2; ++t) cells.push_back({b, t, Finger::Index, Segment::Proximal, Direction::Along, Category::MainJoint});
  const TraceLayout square(2, 2, cells, "square");
  CHECK_THROWS_WITH_AS((CapacitanceSolver(square)),
                       doctest::Contains("has rank 2 but 4 cells, expected full column rank; these cells cannot be told apart: 0, 1, 2, 3"),
                       Error);
}

TEST_CASE("solver: other layouts work through dynamic sizes") {
  std::vector<Cell> cells;
  const int pairs[][2] = {{0, 0}, {0, 1}, {1, 2}, {2, 0}, {3, 1}, {3, 2}};
  for (const auto& p : pairs) cells.push_back({p[0], p[1], Finger::Index, Segment::Proximal, Direction::Along, Category::MainJoint});
  const TraceLayout small(4, 3, cells, "small");
  const CapacitanceSolver solver(small);
  const Eigen::VectorXd truth = Eigen::VectorXd::LinSpaced(6, 1.0, 6.0);
  const Eigen::VectorXd measured = small.measurement_matrix() * truth;
  Eigen::VectorXd solved(6);
  REQUIRE(solver.solve(measured, solved) == Status::Ok);
  CHECK((solved - truth).cwiseAbs().maxCoeff() < 1e-12);
  Eigen::VectorXd wrong(5);
  CHECK(solver.solve(measured, wrong) == Status::SizeMismatch);
}

TEST_CASE("solver: bad input gets a status, and a solve allocates nothing") {
  const CapacitanceSolver solver(TraceLayout::glauser2019());
  CapacitanceSolver::Measurements measured = CapacitanceSolver::Measurements::Constant(180, 100.0);
  CapacitanceSolver::Capacitances solved = CapacitanceSolver::Capacitances::Constant(44, -7.0);
  measured(17) = std::numeric_limits<double>::quiet_NaN();
  CHECK(solver.solve(measured, solved) == Status::NonFinite);
  CHECK(solved.isConstant(-7.0));  // untouched
  measured(17) = 100.0;
  CHECK(test::allocations_during([&] { (void)solver.solve(measured, solved); }) == 0);
  const CapacitanceSolver copy = solver;  // a copy shares nothing and solves the same
  CapacitanceSolver::Capacitances again(44);
  REQUIRE(copy.solve(measured, again) == Status::Ok);
  CHECK(again == solved);
}
