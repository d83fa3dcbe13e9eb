// The isolation check's negative control (capi/CMakeLists.txt): an inline function compiled with
// AVX2 in this unit and with baseline flags in base_unit.cpp. This unit is linked first, so the
// library keeps its AVX copy, which base_unit.cpp's baseline code then calls: the leak
// tests/check_isa_isolation.py must report.
#include "leak.hpp"

extern "C" float make_network_avx2(const float* x, int n) { return leak_sum(x, n) * x[0]; }
