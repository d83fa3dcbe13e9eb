#include <glovepose/nn/linear.hpp>
#include <glovepose/train/linear_fit.hpp>

#include <doctest/doctest.h>

#include <Eigen/Dense>

#include <cfloat>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "alloc_counter.hpp"

using namespace glovepose;

namespace {

// Row-major float data of a linear problem, with its double view for the reference computations.
struct Problem {
  long frames;
  int inputs;
  int outputs;
  std::vector<float> x;  // frames x inputs
  std::vector<float> y;  // frames x outputs

  Eigen::MatrixXd design() const {  // [x 1], frames x (inputs + 1), the data exactly as stored
    Eigen::MatrixXd a(frames, inputs + 1);
    for (long f = 0; f < frames; ++f) {
      for (int i = 0; i < inputs; ++i) a(f, i) = x[static_cast<std::size_t>(f * inputs + i)];
      a(f, inputs) = 1.0;
    }
    return a;
  }
  Eigen::MatrixXd targets() const {
    Eigen::MatrixXd t(frames, outputs);
    for (long f = 0; f < frames; ++f)
      for (int o = 0; o < outputs; ++o) t(f, o) = y[static_cast<std::size_t>(f * outputs + o)];
    return t;
  }
  train::LinearFit fit(double ridge) const { return train::fit_linear(x.data(), frames, inputs, y.data(), outputs, ridge); }
};

// Noise-free data that float holds exactly: small integer inputs (plus an offset, as capacitances
// have), weights in eighths, biases in quarters, so y = W x + b is exact in float and the fit must
// recover W and b to double rounding.
Problem exact_problem(long frames, int inputs, int outputs, double offset, Eigen::MatrixXd& weight, Eigen::VectorXd& bias) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> small(-8, 8);
  weight.resize(outputs, inputs);
  bias.resize(outputs);
  for (int o = 0; o < outputs; ++o) {
    for (int i = 0; i < inputs; ++i) weight(o, i) = small(rng) / 8.0;
    bias(o) = small(rng) / 4.0;
  }
  Problem p{frames, inputs, outputs, {}, {}};
  bool exact = true;
  for (long f = 0; f < frames; ++f) {
    Eigen::VectorXd xf(inputs);
    for (int i = 0; i < inputs; ++i) {
      xf(i) = offset + small(rng);
      p.x.push_back(static_cast<float>(xf(i)));
    }
    const Eigen::VectorXd yf = weight * xf + bias;
    for (int o = 0; o < outputs; ++o) {
      exact = exact && static_cast<double>(static_cast<float>(yf(o))) == yf(o);
      p.y.push_back(static_cast<float>(yf(o)));
    }
  }
  REQUIRE(exact);  // every target is exact in float
  return p;
}

// Correlated Gaussian inputs around an offset, y = W x + b + noise.
Problem noisy_problem(long frames, int inputs, int outputs, double noise, unsigned seed = 11) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd mix = Eigen::MatrixXd::Identity(inputs, inputs);
  for (int i = 1; i < inputs; ++i) mix(i, i - 1) = 0.6;  // neighbouring cells stretch together
  Eigen::MatrixXd weight(outputs, inputs);
  Eigen::VectorXd bias(outputs);
  for (int o = 0; o < outputs; ++o) {
    for (int i = 0; i < inputs; ++i) weight(o, i) = normal(rng);
    bias(o) = normal(rng);
  }
  Problem p{frames, inputs, outputs, {}, {}};
  for (long f = 0; f < frames; ++f) {
    Eigen::VectorXd z(inputs);
    for (int i = 0; i < inputs; ++i) z(i) = normal(rng);
    const Eigen::VectorXd xf = (50.0 + (mix * z).array() * 3.0).matrix();
    for (int i = 0; i < inputs; ++i) p.x.push_back(static_cast<float>(xf(i)));
    const Eigen::VectorXd yf = weight * xf + bias;
    for (int o = 0; o < outputs; ++o) p.y.push_back(static_cast<float>(yf(o) + noise * normal(rng)));
  }
  return p;
}

double max_relative_difference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

}  // namespace

TEST_CASE("linear fit: noise-free linear data is recovered exactly") {
  for (double offset : {0.0, 1000.0}) {  // 1000: a large common offset, handled by centring
    INFO("offset " << offset);
    Eigen::MatrixXd weight;
    Eigen::VectorXd bias;
    // 10007 frames: more than two 4096-frame blocks, the last one partial.
    const Problem p = exact_problem(10007, 7, 4, offset, weight, bias);
    const train::LinearFit fit = p.fit(0.0);
    CHECK(fit.lambda == 0.0);
    CHECK(max_relative_difference(fit.weight, weight) < 1e-9);
    CHECK(max_relative_difference(fit.bias, bias) < 1e-9);

    // As floats the map reproduces every target to float precision.
    const nn::LinearMap map = fit.to_map();
    CHECK(map.inputs() == 7);
    CHECK(map.outputs() == 4);
    std::vector<float> out(p.y.size());
    REQUIRE(map.predict(p.x.data(), out.data(), p.frames) == Status::Ok);
    double worst = 0.0;
    for (std::size_t k = 0; k < out.size(); ++k)
      worst = std::max(worst, std::fabs(static_cast<double>(out[k]) - p.y[k]) / std::max(1.0, std::fabs(static_cast<double>(p.y[k]))));
    CHECK(worst < 1e-5);

    // The default ridge (1e-6 relative) moves the solution only by about that much.
    const train::LinearFit ridged = p.fit(1e-6);
    CHECK(ridged.lambda > 0.0);
    CHECK(max_relative_difference(ridged.weight, weight) < 1e-5);
    CHECK(max_relative_difference(ridged.bias, bias) < 1e-5 * (1.0 + offset));
  }
}

TEST_CASE("linear fit: on noisy data the solution satisfies the normal equations and equals QR") {
  const Problem p = noisy_problem(20000, 12, 5, 0.3);
  const train::LinearFit fit = p.fit(0.0);
  const Eigen::MatrixXd a = p.design();
  const Eigen::MatrixXd t = p.targets();

  // Residuals of the double solution on the stored data: orthogonal to every input column and
  // summing to zero (the intercept column), relative to the size of the terms involved.
  Eigen::MatrixXd coefficients(p.inputs + 1, p.outputs);
  coefficients.topRows(p.inputs) = fit.weight.transpose();
  coefficients.row(p.inputs) = fit.bias.transpose();
  const Eigen::MatrixXd residual = t - a * coefficients;
  const Eigen::MatrixXd normal = a.transpose() * residual;  // (inputs + 1) x outputs, ~0
  const Eigen::MatrixXd scale = a.cwiseAbs().transpose() * residual.cwiseAbs();
  CHECK((normal.cwiseAbs().array() / scale.array()).maxCoeff() < 1e-10);
  CHECK(residual.cwiseAbs().maxCoeff() > 0.1);  // the noise is really there

  // The same coefficients as a rank-revealing QR of the augmented design matrix.
  const Eigen::MatrixXd qr = a.colPivHouseholderQr().solve(t);
  CHECK(max_relative_difference(coefficients, qr) < 1e-9);

  // Any other coefficients leave a larger residual.
  Eigen::MatrixXd nudged = coefficients;
  nudged(3, 2) += 1e-3;
  CHECK((t - a * nudged).squaredNorm() > residual.squaredNorm());
}

TEST_CASE("linear fit: the ridge shrinks the weights, is relative to the input scale and spares the intercept") {
  const Problem p = noisy_problem(3000, 6, 3, 0.5);
  double previous = std::numeric_limits<double>::infinity();
  for (double ridge : {0.0, 0.01, 0.1, 1.0, 10.0}) {
    INFO("ridge " << ridge);
    const train::LinearFit fit = p.fit(ridge);
    CHECK(fit.weight.norm() < previous);
    previous = fit.weight.norm();

    // The closed form: centred data, (S + lambda I) W^T = C, lambda = ridge * trace(S) / inputs.
    const Eigen::MatrixXd a = p.design().leftCols(p.inputs);
    const Eigen::MatrixXd t = p.targets();
    const Eigen::RowVectorXd mx = a.colwise().mean();
    const Eigen::RowVectorXd my = t.colwise().mean();
    const Eigen::MatrixXd ac = a.rowwise() - mx;
    const Eigen::MatrixXd tc = t.rowwise() - my;
    Eigen::MatrixXd s = ac.transpose() * ac;
    const double lambda = ridge * s.trace() / p.inputs;
    CHECK(fit.lambda == doctest::Approx(lambda).epsilon(1e-12));
    s.diagonal().array() += lambda;
    const Eigen::MatrixXd w = s.ldlt().solve(ac.transpose() * tc).transpose();
    CHECK(max_relative_difference(fit.weight, w) < 1e-9);
    // Not shrunk: the intercept puts the fit through the centroid of the data.
    CHECK(max_relative_difference(fit.bias, (my.transpose() - fit.weight * mx.transpose()).eval()) < 1e-12);
  }

  // Inputs in other units (x 1000) give the same predictions for the same relative ridge.
  Problem scaled = p;
  for (float& v : scaled.x) v *= 1000.0f;
  const train::LinearFit a = p.fit(1.0);
  const train::LinearFit b = scaled.fit(1.0);
  CHECK(max_relative_difference(b.weight * 1000.0, a.weight) < 1e-6);
  CHECK(max_relative_difference(b.bias, a.bias) < 1e-6);
}

TEST_CASE("linear fit: bad input is refused with a message naming the problem") {
  Problem p = noisy_problem(100, 4, 2, 0.1);
  const auto refused = [](auto&& call, const char* expected) { CHECK_THROWS_WITH_AS(call(), doctest::Contains(expected), Error); };
  refused([&] { return train::fit_linear(p.x.data(), 0, 4, p.y.data(), 2); }, "0 frames, expected at least 1");
  refused([&] { return train::fit_linear(p.x.data(), 100, 0, p.y.data(), 2); }, "0 inputs and 2 outputs, expected at least 1 of each");
  refused([&] { return train::fit_linear(p.x.data(), 100, 4, p.y.data(), 0); }, "expected at least 1 of each");
  refused([&] { return train::fit_linear(nullptr, 100, 4, p.y.data(), 2); }, "null data pointer");
  refused([&] { return p.fit(-1.0); }, "ridge -1, expected a finite number >= 0");
  refused([&] { return p.fit(std::numeric_limits<double>::quiet_NaN()); }, "ridge nan");

  Problem nan = p;
  nan.x[7 * 4 + 2] = std::numeric_limits<float>::quiet_NaN();
  refused([&] { return nan.fit(1e-6); }, "frame 7, input 2 is nan, expected a finite number");
  Problem inf = p;
  inf.y[42 * 2 + 1] = std::numeric_limits<float>::infinity();
  refused([&] { return inf.fit(1e-6); }, "frame 42, output 1 is inf, expected a finite number");

  // Singular systems without a ridge: a repeated input, a constant input, fewer frames than unknowns.
  Problem repeated = p;
  for (long f = 0; f < p.frames; ++f)
    repeated.x[static_cast<std::size_t>(f * 4 + 3)] = 2.0f * repeated.x[static_cast<std::size_t>(f * 4 + 1)];
  refused([&] { return repeated.fit(0.0); }, "singular system");
  refused([&] { return repeated.fit(0.0); }, "linearly dependent, expected independent inputs or a larger ridge");
  CHECK(repeated.fit(1e-6).weight.allFinite());  // the ridge makes it solvable

  Problem constant = p;
  for (long f = 0; f < p.frames; ++f) constant.x[static_cast<std::size_t>(f * 4 + 2)] = 3.25f;
  refused([&] { return constant.fit(0.0); }, "1 input(s) never change (input 2), expected inputs that vary or a ridge > 0");
  const train::LinearFit with_ridge = constant.fit(1e-6);
  CHECK(with_ridge.weight.col(2).cwiseAbs().maxCoeff() == 0.0);  // a constant input gets no weight

  refused([&] { return train::fit_linear(p.x.data(), 3, 4, p.y.data(), 2, 0.0); }, "singular system");
  refused([&] { return train::fit_linear(p.x.data(), 1, 4, p.y.data(), 2); },
          "every input is constant over the 1 frame(s), expected inputs that vary");
}

TEST_CASE("linear map: predicts W x + b, refuses non-finite input and overflow, never allocates") {
  // y0 = 1 x0 - 2 x1 + 0.5, y1 = 3 x1 - 1, y2 = x0 + x1
  const nn::LinearMap map(2, 3, {1.0f, -2.0f, 0.0f, 3.0f, 1.0f, 1.0f}, {0.5f, -1.0f, 0.0f});
  const float x[2] = {2.0f, 0.25f};
  float y[3] = {9.0f, 9.0f, 9.0f};
  REQUIRE(map.predict(x, y) == Status::Ok);
  CHECK(y[0] == 2.0f);
  CHECK(y[1] == -0.25f);
  CHECK(y[2] == 2.25f);

  const float bad[2] = {1.0f, std::numeric_limits<float>::quiet_NaN()};
  float untouched[3] = {9.0f, 9.0f, 9.0f};
  CHECK(map.predict(bad, untouched) == Status::NonFinite);
  CHECK(untouched[0] == 9.0f);
  // Finite input, but the result does not fit in a float.
  const float huge[2] = {FLT_MAX, -FLT_MAX};
  CHECK(map.predict(huge, untouched) == Status::NonFinite);
  CHECK(untouched[0] == 9.0f);
  CHECK(untouched[2] == 9.0f);
  // Large but representable: the slow path computes it.
  const float large[2] = {FLT_MAX / 4, 0.0f};
  REQUIRE(map.predict(large, untouched) == Status::Ok);
  CHECK(untouched[0] == doctest::Approx(FLT_MAX / 4));

  // Batch: all frames or none.
  const std::vector<float> frames = {2.0f, 0.25f, 1.0f, 1.0f, 0.0f, std::numeric_limits<float>::infinity(), 4.0f, 4.0f};
  std::vector<float> out(12, 9.0f);
  long rejected = -1;
  CHECK(map.predict(frames.data(), out.data(), 4, &rejected) == Status::NonFinite);
  CHECK(rejected == 2);
  for (float v : out) CHECK(v == 9.0f);
  REQUIRE(map.predict(frames.data(), out.data(), 2) == Status::Ok);
  CHECK(out[0] == 2.0f);
  CHECK(out[3] == -0.5f);  // 1 - 2 + 0.5
  CHECK(out[5] == 2.0f);   // 1 + 1
  CHECK(out[6] == 9.0f);   // frame 2 not requested
  CHECK(map.predict(frames.data(), out.data(), -1) == Status::SizeMismatch);
  CHECK(map.predict(frames.data(), out.data(), 0) == Status::Ok);

  CHECK(test::allocations_during([&] {
          (void)map.predict(x, y);
          (void)map.predict(frames.data(), out.data(), 2);
        }) == 0);
}

TEST_CASE("linear map: construction checks sizes and values") {
  CHECK_THROWS_WITH_AS(nn::LinearMap(0, 1, {}, {0.0f}), doctest::Contains("0 inputs and 1 outputs, expected at least 1 of each"), Error);
  CHECK_THROWS_WITH_AS(nn::LinearMap(2, 2, {1.0f, 2.0f, 3.0f}, {0.0f, 0.0f}),
                       doctest::Contains("3 weights, expected outputs x inputs = 2 x 2 = 4"), Error);
  CHECK_THROWS_WITH_AS(nn::LinearMap(2, 2, {1.0f, 2.0f, 3.0f, 4.0f}, {0.0f}), doctest::Contains("1 biases, expected one per output (2)"),
                       Error);
  CHECK_THROWS_WITH_AS(nn::LinearMap(2, 2, {1.0f, 2.0f, std::numeric_limits<float>::infinity(), 4.0f}, {0.0f, 0.0f}),
                       doctest::Contains("weight (output 1, input 0) is inf, expected a finite number"), Error);
  CHECK_THROWS_WITH_AS(nn::LinearMap(2, 2, {1.0f, 2.0f, 3.0f, 4.0f}, {0.0f, std::numeric_limits<float>::quiet_NaN()}),
                       doctest::Contains("bias of output 1 is nan"), Error);
  // A fit whose coefficients overflow float cannot become a map.
  train::LinearFit fit;
  fit.weight = Eigen::MatrixXd::Constant(1, 1, 1e300);
  fit.bias = Eigen::VectorXd::Zero(1);
  CHECK_THROWS_WITH_AS((void)fit.to_map(), doctest::Contains("weight (output 0, input 0) is inf"), Error);
}

TEST_CASE("linear fit: a glove-sized problem (44 inputs, 25 outputs) fits and predicts within float precision") {
  const Problem p = noisy_problem(50000, 44, 25, 0.05, 3);
  const train::LinearFit fit = p.fit(1e-6);
  const nn::LinearMap map = fit.to_map();
  std::vector<float> out(p.y.size());
  REQUIRE(map.predict(p.x.data(), out.data(), p.frames) == Status::Ok);
  // Float map vs double fit on the first frames.
  const Eigen::MatrixXd a = p.design().topRows(100);
  Eigen::MatrixXd coefficients(45, 25);
  coefficients.topRows(44) = fit.weight.transpose();
  coefficients.row(44) = fit.bias.transpose();
  const Eigen::MatrixXd expected = a * coefficients;
  double worst = 0.0;
  for (int f = 0; f < 100; ++f)
    for (int o = 0; o < 25; ++o)
      worst =
          std::max(worst, std::fabs(out[static_cast<std::size_t>(f * 25 + o)] - expected(f, o)) / std::max(1.0, std::fabs(expected(f, o))));
  CHECK(worst < 1e-5);
  // The residual is the noise: its RMS is close to 0.05.
  double squared = 0.0;
  for (std::size_t k = 0; k < out.size(); ++k) squared += (out[k] - p.y[k]) * static_cast<double>(out[k] - p.y[k]);
  CHECK(std::sqrt(squared / static_cast<double>(out.size())) == doctest::Approx(0.05).epsilon(0.05));
}
