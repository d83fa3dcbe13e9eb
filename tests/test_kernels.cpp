#include <glovepose/nn/kernels/scalar.hpp>
#include <glovepose/nn/kernels/simd.hpp>
#include <glovepose/nn/tensor.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <vector>

using namespace glovepose::nn;
using glovepose::nn::kernels::ScalarBackend;
using glovepose::nn::kernels::SimdBackend;
namespace kernels = glovepose::nn::kernels;

namespace {
template <typename W>
void check_gemm(int rows, int k, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> x(static_cast<std::size_t>(rows * k));
  for (float& v : x) v = u(rng);
  std::vector<W> w(static_cast<std::size_t>(k * n));  // any values: both read the same panel layout
  for (W& v : w) {
    if constexpr (std::is_same_v<W, float>) v = u(rng);
    else v = float_to_f16(u(rng));
  }
  std::vector<float> y_scalar(static_cast<std::size_t>(rows * n)), y_simd;
  for (float& v : y_scalar) v = u(rng);
  y_simd = y_scalar;
  std::vector<const float*> xr;
  std::vector<float*> ys, yv;
  // Rows in a scrambled order, as a tap's (output, input) pairs are.
  for (int r = 0; r < rows; ++r) {
    const int src = rows - 1 - r;  // reversed: rows need not be in memory order
    xr.push_back(x.data() + src * k);
    ys.push_back(y_scalar.data() + r * n);
    yv.push_back(y_simd.data() + r * n);
  }
  // The scalar kernel is told the SIMD panel width so that both read the same packing.
  for (int r = 0; r < rows; ++r)
    for (int kk = 0; kk < k; ++kk)
      for (int j = 0; j < n; ++j)
        ys[static_cast<std::size_t>(r)][j] += xr[static_cast<std::size_t>(r)][kk] *
            kernels::weight_value(w[static_cast<std::size_t>(kernels::panel_index(kk, j, k, n, SimdBackend::panel))]);
  SimdBackend::gemm_rows(xr.data(), yv.data(), rows, w.data(), k, n);
  for (std::size_t i = 0; i < y_scalar.size(); ++i) REQUIRE(y_simd[i] == doctest::Approx(y_scalar[i]).epsilon(1e-5).scale(1.0));
  // Sums of dot products over several terms (one output channel gathered over taps and sources),
  // for several frames whose rows lie `stride` floats apart.
  const int frames = 1 + rows % 11, stride = k + 3;
  std::vector<float> xf(static_cast<std::size_t>(rows * frames * stride));
  for (float& v : xf) v = u(rng);
  std::vector<const float*> xt;
  std::vector<const W*> wt;
  std::vector<int> kt;
  for (int r = 0; r < rows; ++r) {
    xt.push_back(xf.data() + static_cast<std::size_t>(r * frames * stride));
    wt.push_back(w.data() + (r * 3) % n);
    kt.push_back(k - (r % 3 == 0 ? 0 : std::min(k - 1, r % 5)));  // lengths that differ between terms
  }
  std::vector<float> scalar_sums(static_cast<std::size_t>(frames)), simd_sums(static_cast<std::size_t>(frames));
  ScalarBackend::dot_terms(xt.data(), stride, wt.data(), kt.data(), rows, frames, scalar_sums.data());
  SimdBackend::dot_terms(xt.data(), stride, wt.data(), kt.data(), rows, frames, simd_sums.data());
  // Both against the exact (double) sum, within float rounding of the sum of magnitudes.
  for (int f = 0; f < frames; ++f) {
    double exact = 0.0, magnitude = 0.0;
    for (int i = 0; i < rows; ++i)
      for (int kk = 0; kk < kt[static_cast<std::size_t>(i)]; ++kk) {
        const double term = static_cast<double>(xt[static_cast<std::size_t>(i)][f * stride + kk]) *
                            kernels::weight_value(wt[static_cast<std::size_t>(i)][kk]);
        exact += term;
        magnitude += std::abs(term);
      }
    const double bound = 1e-6 * magnitude + 1e-7;
    REQUIRE(std::abs(scalar_sums[static_cast<std::size_t>(f)] - exact) <= bound);
    REQUIRE(std::abs(simd_sums[static_cast<std::size_t>(f)] - exact) <= bound);
  }
}
}  // namespace

TEST_CASE("kernels: the SIMD row-gathered product equals the scalar reference (all blockings, F32 and F16 weights)") {
  const int lanes = SimdBackend::lanes;
  MESSAGE("SIMD backend: " << lanes << " floats per vector");
  unsigned seed = 1;
  for (int rows : {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 25, 64, 100})
    for (int n : {lanes, 2 * lanes, 3 * lanes, 5 * lanes, 8 * lanes, 13 * lanes})
      for (int k : {1, 2, 7, 64, 130}) {
        CAPTURE(rows);
        CAPTURE(n);
        CAPTURE(k);
        check_gemm<float>(rows, k, n, seed++);
        check_gemm<std::uint16_t>(rows, k, n, seed++);
      }
}

TEST_CASE("kernels: the scalar reference product follows the panel layout's definition") {
  // 3 x 20 matrix in panels of 8: panels of widths 8, 8, 4 at offsets 0, 24, 48.
  CHECK(kernels::panel_index(0, 0, 3, 20, 8) == 0);
  CHECK(kernels::panel_index(2, 7, 3, 20, 8) == 23);
  CHECK(kernels::panel_index(0, 8, 3, 20, 8) == 24);
  CHECK(kernels::panel_index(1, 17, 3, 20, 8) == 48 + 4 + 1);
  std::vector<float> w(60);
  for (int i = 0; i < 60; ++i) w[static_cast<std::size_t>(i)] = static_cast<float>(i);
  const float x[3] = {1.0f, 10.0f, 100.0f};
  const float* xr[1] = {x};
  float y[20] = {};
  float* yr[1] = {y};
  ScalarBackend::gemm_rows(xr, yr, 1, w.data(), 3, 20);
  for (int j = 0; j < 20; ++j) {
    float expected = 0.0f;
    for (int kk = 0; kk < 3; ++kk) expected += x[kk] * w[static_cast<std::size_t>(kernels::panel_index(kk, j, 3, 20, 8))];
    CHECK(y[j] == expected);
  }
  CHECK(y[0] == 1.0f * 0 + 10.0f * 8 + 100.0f * 16);
}

TEST_CASE("kernels: ReLU") {
  AlignedVector<float> a(64), b;
  for (int i = 0; i < 64; ++i) a[static_cast<std::size_t>(i)] = static_cast<float>(i % 7) - 3.0f;
  b = a;
  ScalarBackend::relu(a.data(), 64);
  SimdBackend::relu(b.data(), 64);
  CHECK(a == b);
  for (float v : a) CHECK(v >= 0.0f);
}
