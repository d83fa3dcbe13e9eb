#include <glovepose/io/half.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <limits>

using namespace glovepose::io;

TEST_CASE("half: every binary16 value survives f16 -> float -> f16, and known values decode exactly") {
  for (std::uint32_t h = 0; h < 65536; ++h) {
    const auto bits = static_cast<std::uint16_t>(h);
    const float f = f16_to_float(bits);
    if (std::isnan(f)) {
      CHECK(std::isnan(f16_to_float(float_to_f16(f))));
      continue;
    }
    REQUIRE(float_to_f16(f) == bits);
  }
  CHECK(f16_to_float(0x3c00) == 1.0f);
  CHECK(f16_to_float(0xc000) == -2.0f);
  CHECK(f16_to_float(0x7bff) == 65504.0f);
  CHECK(f16_to_float(0x0001) == std::ldexp(1.0f, -24));  // smallest subnormal
  CHECK(f16_to_float(0x0400) == std::ldexp(1.0f, -14));  // smallest normal
  CHECK(std::isinf(f16_to_float(0x7c00)));
}

TEST_CASE("half: float -> f16 rounds to nearest even, overflows to infinity, underflows to zero") {
  CHECK(float_to_f16(1.0f + std::ldexp(1.0f, -11)) == 0x3c00);      // halfway: ties to even (down)
  CHECK(float_to_f16(1.0f + 3 * std::ldexp(1.0f, -11)) == 0x3c02);  // halfway: ties to even (up)
  CHECK(float_to_f16(1.0f + std::ldexp(1.0f, -11) + std::ldexp(1.0f, -20)) == 0x3c01);
  CHECK(float_to_f16(65520.0f) == 0x7c00);
  CHECK(float_to_f16(65519.0f) == 0x7bff);
  CHECK(float_to_f16(std::ldexp(1.0f, -26)) == 0x0000);
  CHECK(float_to_f16(std::ldexp(1.5f, -25)) == 0x0001);
  CHECK(float_to_f16(-0.0f) == 0x8000);
}

TEST_CASE("half: bfloat16 is the top half of a float, rounded to nearest even") {
  for (std::uint32_t h = 0; h < 65536; h += 7) {
    const float f = bf16_to_float(static_cast<std::uint16_t>(h));
    if (!std::isnan(f)) CHECK(float_to_bf16(f) == h);
  }
  CHECK(bf16_to_float(0x3f80) == 1.0f);
  CHECK(float_to_bf16(1.0f + std::ldexp(1.0f, -8)) == 0x3f80);  // tie -> even
  CHECK(float_to_bf16(1.0f + 3 * std::ldexp(1.0f, -8)) == 0x3f82);
  CHECK(std::isnan(bf16_to_float(float_to_bf16(std::numeric_limits<float>::quiet_NaN()))));
}
