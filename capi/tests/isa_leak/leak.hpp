// The isolation check's negative control: one inline function, kept once by the linker.
#pragma once

__attribute__((noinline)) inline float leak_sum(const float* x, int n) {
  float sum = 0.0f;
  for (int i = 0; i < n; ++i) sum += x[i] * x[i];
  return sum;
}
