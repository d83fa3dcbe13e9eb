// The isolation check's negative control: baseline code calling the inline function (see avx_unit.cpp).
#include "leak.hpp"

extern "C" float baseline_caller(const float* x, int n) { return leak_sum(x, n) + 1.0f; }
