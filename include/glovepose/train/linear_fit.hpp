/// @file linear_fit.hpp
/// @brief Least-squares fit of an affine map y = W x + b (the classic data-glove calibration
/// baseline, evaluated by nn::LinearMap), with an optional ridge term.
///
/// The fit centres the data (means first, then the scatter matrices of the centred data, all in
/// double), so inputs with a large common offset (capacitances of hundreds of pF varying by a few)
/// lose no accuracy to the intercept. With means mx, my and centred scatters
/// S = sum (x - mx)(x - mx)^T, C = sum (x - mx)(y - my)^T it solves
///   (S + lambda I) W^T = C,  b = my - W mx,   lambda = ridge * trace(S) / inputs
/// so `ridge` is relative to the mean diagonal of S: the same `ridge` shrinks equally whatever the
/// units of x. The intercept is not shrunk. Set-up code: allocates, throws glovepose::Error.
#pragma once

#include <algorithm>
#include <charconv>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "../config.hpp"
#include "../nn/linear.hpp"

namespace glovepose::train {

/// @brief Result of fit_linear(), in double.
struct LinearFit {
  Eigen::MatrixXd weight;  ///< outputs x inputs: weight(o, i) multiplies input i in output o.
  Eigen::VectorXd bias;    ///< One per output.
  double lambda = 0.0;     ///< The ridge term added to the diagonal of S (absolute: ridge * trace(S) / inputs).

  /// @brief The fit as a float nn::LinearMap; throws glovepose::Error if a coefficient overflows float.
  nn::LinearMap to_map() const {
    const int outputs = static_cast<int>(weight.rows());
    const int inputs = static_cast<int>(weight.cols());
    std::vector<float> w(static_cast<std::size_t>(outputs) * static_cast<std::size_t>(inputs));
    std::vector<float> b(static_cast<std::size_t>(outputs));
    for (int o = 0; o < outputs; ++o) {
      for (int i = 0; i < inputs; ++i)
        w[static_cast<std::size_t>(o) * static_cast<std::size_t>(inputs) + static_cast<std::size_t>(i)] = static_cast<float>(weight(o, i));
      b[static_cast<std::size_t>(o)] = static_cast<float>(bias(o));
    }
    return nn::LinearMap(inputs, outputs, std::move(w), std::move(b));
  }
};

/// @brief Below this reciprocal condition number (LDLT's estimate, of S + lambda I) the system is
/// called singular: the coefficients would keep fewer than ~4 of double's ~16 significant digits.
inline constexpr double kLinearFitMinRcond = 1e-12;

namespace detail {
/// @brief A number for a message, 3 significant digits, locale-independent (e.g. "1e-06", "3.2e-17").
inline std::string short_number(double v) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::general, 3);
  return std::string(buffer, result.ptr);
}
}  // namespace detail

/// @brief Least squares y ~ W x + b over `frames` frames; x is frames x inputs, y frames x outputs,
/// both row-major float. `ridge` >= 0 (relative, see the file comment; 0 = plain least squares).
/// Single-threaded, two passes over the data; the second accumulates blocks of 4096 frames with
/// Eigen's blocked rank updates, so the cost is that of about frames x inputs x (inputs / 2 + outputs)
/// multiply-adds at matrix-product speed.
/// Throws glovepose::Error for counts below 1, null data, a negative or non-finite ridge, a NaN or
/// infinite value (naming the frame and column), or a singular system (naming constant inputs).
inline LinearFit fit_linear(const float* x, long frames, int inputs, const float* y, int outputs, double ridge = 1e-6) {
  if (frames < 1) throw Error("fit_linear: " + std::to_string(frames) + " frames, expected at least 1");
  if (inputs < 1 || outputs < 1)
    throw Error("fit_linear: " + std::to_string(inputs) + " inputs and " + std::to_string(outputs) +
                " outputs, expected at least 1 of each");
  if (!x || !y) throw Error("fit_linear: null data pointer, expected frames x inputs and frames x outputs values");
  if (!std::isfinite(ridge) || ridge < 0.0)
    throw Error("fit_linear: ridge " + detail::short_number(ridge) + ", expected a finite number >= 0");

  // Rows per block: large enough for Eigen's blocked products, small enough to stay in cache.
  constexpr long kBlock = 4096;

  // Pass 1: means (block sums added to the total, so rounding stays that of ~frames/4096 terms) and
  // finiteness.
  const auto column_means = [&](const float* data, int columns, const char* what) {
    Eigen::VectorXd total = Eigen::VectorXd::Zero(columns);
    Eigen::VectorXd block = Eigen::VectorXd::Zero(columns);
    for (long f = 0; f < frames; ++f) {
      const float* row = data + f * columns;
      for (int c = 0; c < columns; ++c) {
        if (!std::isfinite(row[c]))
          throw Error(std::string("fit_linear: frame ") + std::to_string(f) + ", " + what + " " + std::to_string(c) + " is " +
                      std::to_string(row[c]) + ", expected a finite number");
        block(c) += static_cast<double>(row[c]);
      }
      if ((f + 1) % kBlock == 0 || f + 1 == frames) {
        total += block;
        block.setZero();
      }
    }
    return Eigen::VectorXd(total / static_cast<double>(frames));
  };
  const Eigen::VectorXd mean_x = column_means(x, inputs, "input");
  const Eigen::VectorXd mean_y = column_means(y, outputs, "output");

  // Pass 2: centred scatters, a block of frames at a time (one column per frame, so the transposes
  // are free): S += Xb Xb^T (lower triangle only), C += Xb Yb^T.
  Eigen::MatrixXd scatter = Eigen::MatrixXd::Zero(inputs, inputs);
  Eigen::MatrixXd cross = Eigen::MatrixXd::Zero(inputs, outputs);
  Eigen::MatrixXd xb(inputs, std::min(frames, kBlock));
  Eigen::MatrixXd yb(outputs, std::min(frames, kBlock));
  for (long start = 0; start < frames; start += kBlock) {
    const long n = std::min(kBlock, frames - start);
    for (long r = 0; r < n; ++r) {
      const float* xr = x + (start + r) * inputs;
      const float* yr = y + (start + r) * outputs;
      for (int i = 0; i < inputs; ++i) xb(i, r) = static_cast<double>(xr[i]) - mean_x(i);
      for (int o = 0; o < outputs; ++o) yb(o, r) = static_cast<double>(yr[o]) - mean_y(o);
    }
    scatter.selfadjointView<Eigen::Lower>().rankUpdate(xb.leftCols(n));
    cross.noalias() += xb.leftCols(n) * yb.leftCols(n).transpose();
  }

  LinearFit fit;
  const Eigen::VectorXd spread = scatter.diagonal();  // 0 exactly for an input that never changes
  fit.lambda = ridge * scatter.trace() / static_cast<double>(inputs);
  scatter.diagonal().array() += fit.lambda;
  const Eigen::LDLT<Eigen::MatrixXd, Eigen::Lower> ldlt(scatter);
  // LDLT's solve skips zero pivots (a pseudo-inverse), so its rcond() misses an exactly singular
  // matrix: the pivots are checked too.
  double rcond = 0.0;
  if (ldlt.info() == Eigen::Success && ldlt.isPositive()) {
    const Eigen::VectorXd pivots = ldlt.vectorD();
    rcond = std::min(ldlt.rcond(), pivots.minCoeff() / pivots.maxCoeff());
  }
  if (!(rcond >= kLinearFitMinRcond)) {
    std::string constant;
    int constant_count = 0;
    for (int i = 0; i < inputs; ++i)
      if (spread(i) <= 0.0) {
        if (++constant_count <= 8) constant += (constant.empty() ? "" : ", ") + std::to_string(i);
      }
    std::string why;
    if (constant_count == inputs)
      why = "every input is constant over the " + std::to_string(frames) + " frame(s), expected inputs that vary";
    else if (constant_count > 0)
      why = std::to_string(constant_count) + " input(s) never change (input " + constant + (constant_count > 8 ? ", ..." : "") +
            "), expected inputs that vary or a ridge > 0";
    else
      why = "the inputs are (nearly) linearly dependent, expected independent inputs or a larger ridge (e.g. 1e-6)";
    throw Error("fit_linear: singular system (reciprocal condition number " + detail::short_number(rcond) + " of the " +
                std::to_string(inputs) + " x " + std::to_string(inputs) + " normal matrix, ridge " + detail::short_number(ridge) +
                "): " + why);
  }
  fit.weight = ldlt.solve(cross).transpose();
  fit.bias = mean_y - fit.weight * mean_x;
  if (!fit.weight.allFinite() || !fit.bias.allFinite())
    throw Error("fit_linear: the solution is not finite, expected a well-conditioned system (try a larger ridge)");
  return fit;
}

}  // namespace glovepose::train
