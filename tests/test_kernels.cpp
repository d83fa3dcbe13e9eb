#include <glovepose/nn/kernels/scalar.hpp>
#include <glovepose/nn/kernels/simd.hpp>
#include <glovepose/nn/tensor.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

using namespace glovepose::nn;
using glovepose::nn::kernels::ScalarBackend;
using glovepose::nn::kernels::SimdBackend;
namespace kernels = glovepose::nn::kernels;

namespace {
template <typename W>
W to_weight(float v) {
  if constexpr (std::is_same_v<W, float>)
    return v;
  else if constexpr (std::is_same_v<W, std::uint16_t>)
    return glovepose::io::float_to_f16(v);
  else if constexpr (std::is_same_v<W, kernels::Fixed16>)
    return static_cast<W>(std::lround((v - 1.0f) * 65536.0f));  // levels below
  else
    return static_cast<W>(glovepose::io::float_to_bf16(v));
}

// A value exact in W. Fixed16: a level 1 + u / 2^16 with u < 512, so that the low code's top 7 bits,
// which a high level carries, are zero and the level is the same whichever column it is paired with.
template <typename W>
float exact_weight(std::mt19937& rng, std::uniform_real_distribution<float>& u) {
  if constexpr (std::is_same_v<W, kernels::Fixed16>)
    return 1.0f + static_cast<float>(rng() % 512) / 65536.0f;
  else
    return kernels::weight_value(to_weight<W>(u(rng)));
}

// A k x n matrix (row-major, values exact in W) in the layout a backend reads: its column panels,
// BF16 in pair layout (kernels/weight_load.hpp).
template <typename W>
std::vector<W> pack(const std::vector<float>& logical, int k, int n, int panel, int lanes) {
  std::vector<W> packed(logical.size());
  for (int kk = 0; kk < k; ++kk)
    for (int j = 0; j < n; ++j) {
      const int column = kernels::kPairLayout<W> ? kernels::paired_slot(j, lanes) : j;
      packed[static_cast<std::size_t>(kernels::panel_index(kk, column, k, n, panel))] =
          to_weight<W>(logical[static_cast<std::size_t>(kk * n + j)]);
    }
  return packed;
}

template <typename W>
void check_gemm(int rows, int k, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  // Activations as a ReLU leaves them: about 40% exact zeros (one -0 among them).
  std::vector<float> x(static_cast<std::size_t>(rows * k));
  for (float& v : x) v = rng() % 5 < 2 ? 0.0f : u(rng);
  if (!x.empty()) x[x.size() / 2] = -0.0f;
  std::vector<float> logical(static_cast<std::size_t>(k * n));  // exact in W: rounded through it
  for (float& v : logical) v = exact_weight<W>(rng, u);
  const std::vector<W> w = pack<W>(logical, k, n, SimdBackend::panel, SimdBackend::lanes);
  std::vector<float> y_reference(static_cast<std::size_t>(rows * n));
  for (float& v : y_reference) v = u(rng);
  std::vector<float> y_simd = y_reference, y_sparse = y_reference, y_scalar_sparse = y_reference;
  std::vector<const float*> xr;
  std::vector<float*> yv, ysp, yss;
  // Rows in a scrambled order, as a tap's (output, input) pairs are.
  for (int r = 0; r < rows; ++r) {
    const int src = rows - 1 - r;  // reversed: rows need not be in memory order
    xr.push_back(x.data() + src * k);
    yv.push_back(y_simd.data() + r * n);
    ysp.push_back(y_sparse.data() + r * n);
    yss.push_back(y_scalar_sparse.data() + r * n);
  }
  for (int r = 0; r < rows; ++r)
    for (int kk = 0; kk < k; ++kk)
      for (int j = 0; j < n; ++j)
        y_reference[static_cast<std::size_t>(r * n + j)] +=
            xr[static_cast<std::size_t>(r)][kk] * logical[static_cast<std::size_t>(kk * n + j)];
  SimdBackend::gemm_rows(xr.data(), yv.data(), rows, w.data(), k, n);
  for (std::size_t i = 0; i < y_reference.size(); ++i) REQUIRE(y_simd[i] == doctest::Approx(y_reference[i]).epsilon(1e-5).scale(1.0));
  // The same product from the rows' nonzero entries: SIMD and scalar compaction agree, and both
  // sparse products equal the dense one (the scalar kernel reads its own packing).
  std::vector<int> index(static_cast<std::size_t>(rows * k) + 1), scalar_index = index;
  std::vector<float> value(static_cast<std::size_t>(rows * k) + 1), scalar_value = value;
  std::vector<kernels::SparseRow> sparse, scalar_sparse;
  for (int r = 0; r < rows; ++r) {
    const std::size_t at = static_cast<std::size_t>(r * k);
    const int count = SimdBackend::compact(xr[static_cast<std::size_t>(r)], k, index.data() + at, value.data() + at);
    REQUIRE(ScalarBackend::compact(xr[static_cast<std::size_t>(r)], k, scalar_index.data() + at, scalar_value.data() + at) == count);
    int expected = 0;
    for (int kk = 0; kk < k; ++kk) expected += xr[static_cast<std::size_t>(r)][kk] != 0.0f;
    REQUIRE(count == expected);
    for (int i = 0; i < count; ++i) {
      REQUIRE(index[at + static_cast<std::size_t>(i)] == scalar_index[at + static_cast<std::size_t>(i)]);
      REQUIRE(value[at + static_cast<std::size_t>(i)] == xr[static_cast<std::size_t>(r)][index[at + static_cast<std::size_t>(i)]]);
      REQUIRE(value[at + static_cast<std::size_t>(i)] != 0.0f);
    }
    sparse.push_back({index.data() + at, value.data() + at, count});
    scalar_sparse.push_back({scalar_index.data() + at, scalar_value.data() + at, count});
  }
  SimdBackend::gemm_sparse_rows(sparse.data(), ysp.data(), rows, w.data(), k, n);
  const std::vector<W> w_scalar = pack<W>(logical, k, n, ScalarBackend::panel, ScalarBackend::lanes);
  ScalarBackend::gemm_sparse_rows(scalar_sparse.data(), yss.data(), rows, w_scalar.data(), k, n);
  for (std::size_t i = 0; i < y_reference.size(); ++i) {
    REQUIRE(y_sparse[i] == doctest::Approx(y_reference[i]).epsilon(1e-5).scale(1.0));
    REQUIRE(y_scalar_sparse[i] == doctest::Approx(y_reference[i]).epsilon(1e-5).scale(1.0));
  }
}

}  // namespace

TEST_CASE(
    "kernels: the SIMD products (dense and sparse rows) equal the scalar reference (all blockings, F32, F16, BF16, Fixed16 weights)") {
  const int lanes = SimdBackend::lanes;
  MESSAGE("SIMD backend: " << lanes << " floats per vector");
  unsigned seed = 1;
  for (int rows : {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 25, 64, 100})
    for (int n : {lanes, 2 * lanes, 3 * lanes, 4 * lanes, 5 * lanes, 8 * lanes, 10 * lanes, 13 * lanes})
      for (int k : {1, 2, 7, 17, 64, 130}) {
        CAPTURE(rows);
        CAPTURE(n);
        CAPTURE(k);
        check_gemm<float>(rows, k, n, seed++);
        check_gemm<std::uint16_t>(rows, k, n, seed++);
        if (n % (2 * lanes) == 0) {  // pair layout: whole pairs of vectors
          check_gemm<kernels::BFloat16>(rows, k, n, seed++);
          check_gemm<kernels::Fixed16>(rows, k, n, seed++);
        }
      }
}

TEST_CASE("kernels: compaction keeps NaN and infinities, drops both zeros") {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  std::vector<float> x(37, 0.0f);
  x[0] = nan;
  x[5] = -0.0f;
  x[16] = -inf;
  x[17] = 2.5f;
  x[36] = 1e-30f;
  for (const bool simd : {false, true}) {
    std::vector<int> index(x.size());
    std::vector<float> value(x.size());
    const int count = simd ? SimdBackend::compact(x.data(), 37, index.data(), value.data())
                           : ScalarBackend::compact(x.data(), 37, index.data(), value.data());
    REQUIRE(count == 4);
    CHECK(index[0] == 0);
    CHECK(std::isnan(value[0]));
    CHECK(index[1] == 16);
    CHECK(value[1] == -inf);
    CHECK(index[2] == 17);
    CHECK(index[3] == 36);
    CHECK(value[3] == 1e-30f);
  }
}

TEST_CASE("kernels: BF16 pair layout") {
  // Groups of 2 x lanes columns: column j and lanes + j share 32-bit word j (low, high half).
  CHECK(kernels::paired_slot(0, 16) == 0);
  CHECK(kernels::paired_slot(1, 16) == 2);
  CHECK(kernels::paired_slot(16, 16) == 1);
  CHECK(kernels::paired_slot(31, 16) == 31);
  CHECK(kernels::paired_slot(32 + 17, 16) == 32 + 3);
  for (int c = 0; c < 8; ++c) CHECK(kernels::paired_slot(c, 1) == c);  // the scalar backend: identity
  // The widening itself: bfloat16 is the top half of the float.
  const std::uint16_t one = glovepose::io::float_to_bf16(1.0f);
  CHECK(one == 0x3F80);
  CHECK(kernels::weight_value(static_cast<kernels::BFloat16>(one)) == 1.0f);
}

TEST_CASE("kernels: Fixed16 levels: the SIMD widening equals the definition, and the encoder is within half a step") {
  const int lanes = SimdBackend::lanes;
  std::mt19937 rng(17);
  // Random words (every bit pattern): both halves of each SIMD pair against fixed16.hpp's definition.
  std::vector<kernels::Fixed16> codes(static_cast<std::size_t>(2 * lanes));
  for (int trial = 0; trial < 200; ++trial) {
    for (auto& c : codes) c = static_cast<kernels::Fixed16>(rng() & 0xFFFFu);
    SimdBackend::Batch low, high;
    kernels::load_weight_pair<SimdBackend::Arch>(codes.data(), low, high);
    alignas(64) float lv[64], hv[64];
    low.store_aligned(lv);
    high.store_aligned(hv);
    for (int j = 0; j < lanes; ++j) {
      const std::uint32_t word = static_cast<std::uint32_t>(codes[static_cast<std::size_t>(2 * j)]) |
                                 static_cast<std::uint32_t>(codes[static_cast<std::size_t>(2 * j + 1)]) << 16;
      REQUIRE(lv[j] == fixed16_low_level(word));
      REQUIRE(hv[j] == fixed16_high_level(word));
      REQUIRE(lv[j] == kernels::weight_at(codes.data(), 2 * j));  // the scalar kernels' read
      REQUIRE(hv[j] == kernels::weight_at(codes.data(), 2 * j + 1));
    }
  }
  CHECK(fixed16_low_level(0x0000u) == 1.0f);
  CHECK(fixed16_low_level(0xFFFF8000u) == 1.5f);  // the high half does not leak into the low level
  CHECK(fixed16_high_level(0x80000000u) == 1.5f);
  CHECK(fixed16_high_level(0x8000FE00u) == 1.5f + 127.0f / 8388608.0f);  // the low code's top 7 bits, below
  // Encoding: every level within 2^-17 of 1.5 + weight / scale, over the whole range and its ends.
  std::uniform_real_distribution<double> u(-kFixed16Range, kFixed16Range);
  double worst = 0.0;
  for (int trial = 0; trial < 100000; ++trial) {
    const double low = trial < 4 ? (trial % 2 ? kFixed16Range : -kFixed16Range) : u(rng);
    const double high = trial < 4 ? (trial / 2 ? kFixed16Range : -kFixed16Range) : u(rng);
    const std::uint32_t word = fixed16_encode_pair(low, high);
    worst = std::max(worst, std::abs(fixed16_low_level(word) - (1.5 + low)));
    worst = std::max(worst, std::abs(fixed16_high_level(word) - (1.5 + high)));
  }
  MESSAGE("Fixed16 encoding: largest level error " << worst * 131072.0 << " x 2^-17");
  CHECK(worst <= std::ldexp(1.0, -17) * (1.0 + 1e-9));
}

TEST_CASE("kernels: sum (SIMD, scalar) of rows of any length") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 2.0f);
  for (int k : {0, 1, 5, 16, 17, 64, 130, 513}) {
    std::vector<float> x(static_cast<std::size_t>(k));
    double exact = 0.0;
    for (float& v : x) exact += v = u(rng);
    CAPTURE(k);
    CHECK(SimdBackend::sum(x.data(), k) == doctest::Approx(exact).epsilon(1e-6));
    CHECK(ScalarBackend::sum(x.data(), k) == doctest::Approx(exact).epsilon(1e-6));
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
