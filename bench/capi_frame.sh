#!/usr/bin/env bash
# An engine's frame through the C ABI (BM_CapiFrame, bench/bench_estimator.cpp): the shipped library
# (glovepose_c as tools/package.sh builds it: Release, no -march, networks per instruction set chosen
# at run time) beside the same source built header-only for this machine (-march=native), for AVX2
# (-mavx2 -mfma -mf16c) and for baseline x86-64, loaded side by side in one process. Three runs: the
# shipped library's own choice, then GLOVEPOSE_ISA=avx2 and sse2 (each beside its own peer).
# Medians of REPETITIONS (default 5) repetitions of each.
# Usage: bench/capi_frame.sh [REPETITIONS]   (Linux x86-64; builds into build-capi-bench/)
set -euo pipefail
cd "$(dirname "$0")/.."
repetitions="${1:-5}"
tree=build-capi-bench
cmake -S . -B "$tree" -DCMAKE_BUILD_TYPE=Release -DGLOVEPOSE_BUILD_TESTS=OFF -DGLOVEPOSE_BUILD_EXAMPLES=OFF -DGLOVEPOSE_BUILD_TOOLS=OFF \
  -DGLOVEPOSE_BENCH_CAPI_PEERS=ON >/dev/null
cmake --build "$tree" -j"$(nproc)" --target glovepose_bench glovepose_c glovepose_c_native glovepose_c_avx2 glovepose_c_baseline
lib() { echo "$PWD/$tree/$1"; }
shipped=$(lib capi/libglovepose_c.so)
run() {  # GLOVEPOSE_ISA value ("" for the library's choice), then label=path items
  local isa=$1; shift
  local IFS=,
  echo "== GLOVEPOSE_ISA=${isa:-(unset)}"
  GLOVEPOSE_ISA="$isa" GLOVEPOSE_BENCH_CAPI="$*" "$tree/bench/glovepose_bench" --benchmark_filter='BM_CapiFrame' \
    --benchmark_repetitions="$repetitions" --benchmark_report_aggregates_only=true --benchmark_enable_random_interleaving=true \
    2>&1 | grep -E '_median|^Run on|^CPU|error' || true
}
run "" "shipped=$shipped" "native=$(lib bench/libglovepose_c_native.so)"
run avx2 "shipped=$shipped" "avx2=$(lib bench/libglovepose_c_avx2.so)"
run sse2 "shipped=$shipped" "baseline=$(lib bench/libglovepose_c_baseline.so)"
