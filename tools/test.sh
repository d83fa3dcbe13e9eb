#!/usr/bin/env bash
# The one command: installs what is missing, configures, builds, and runs every test in two trees:
#   build/        GCC, Release, this machine's instruction set (-march=native): every test but the
#                 header check
#   build-clang/  clang, Release, baseline x86-64 (the "must also pass without -march" run): the tests
#                 a compiler and an instruction set can change (GLOVEPOSE_TEST_SCOPE=isa, tests/CMakeLists.txt:
#                 kernels, storages, networks, solver, estimator, threads, gradients, the C ABI) and the
#                 header check, without the tool, examples and benchmarks
#   build-windows/, build-arm64/  Windows x64 (mingw-w64, under Wine) and 64-bit ARM Linux (under
#                 qemu-user): the same tests as build-clang/, cross-built with the tool (tools/cross.sh,
#                 docs/platforms.md)
# Usage: tools/test.sh   (from anywhere; builds into ./build and ./build-clang of the repository)
# With CI=true, warnings in our own code are errors in both (GLOVEPOSE_WERROR=ON).
# The sanitizer runs (ASan+UBSan, TSan) are a separate command: tools/sanitize.sh address|thread.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
# Every tree compiles through ccache (installed by setup), which keeps the objects between runs. CI
# tests a new clone each time: there the trees are built through one stable path (a link to the
# clone), so the compiler sees the same paths and a commit already built once is served from the cache.
export CMAKE_C_COMPILER_LAUNCHER=ccache CMAKE_CXX_COMPILER_LAUNCHER=ccache
if [ "${CI:-}" = "true" ]; then
  stable="${XDG_CACHE_HOME:-$HOME/.cache}/glovepose/ci-clone"
  mkdir -p "$(dirname "$stable")"
  ln -sfn "$(pwd -P)" "$stable"
  cd "$stable"
fi
werror=OFF
# CI always has PyTorch (installed above): there the PyTorch comparisons must run.
if [ "${CI:-}" = "true" ]; then
  export GLOVEPOSE_REQUIRE_TORCH=1
  werror=ON
fi
echo "== GCC, native (build/)"
# build/ may be the tree tools/demo.sh made (the tool alone, without the tests, the benchmarks, the
# view page and ccache, whose packages it leaves out): each is named here, so every test is built.
cmake -S "$PWD" -B "$PWD/build" -DCMAKE_BUILD_TYPE=Release -DGLOVEPOSE_WERROR=$werror -DGLOVEPOSE_TEST_BASELINE=OFF -DGLOVEPOSE_HEADER_CHECK=OFF -DGLOVEPOSE_UNITY_BUILD=ON \
  -DGLOVEPOSE_BUILD_TESTS=ON -DGLOVEPOSE_BUILD_BENCHMARKS=ON -DGLOVEPOSE_VIEW_PAGE=ON \
  -DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache
cmake --build build -j"$(nproc)"
ctest --test-dir build --output-on-failure -j"$(nproc)"
echo "== clang, baseline x86-64, the tests a compiler and an instruction set can change (build-clang/)"
cmake -S "$PWD" -B "$PWD/build-clang" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang \
  -DGLOVEPOSE_NATIVE=OFF -DGLOVEPOSE_WERROR=$werror -DGLOVEPOSE_TEST_SCOPE=isa -DGLOVEPOSE_UNITY_BUILD=ON \
  -DGLOVEPOSE_BUILD_TOOLS=OFF -DGLOVEPOSE_BUILD_EXAMPLES=OFF -DGLOVEPOSE_BUILD_BENCHMARKS=OFF
cmake --build build-clang -j"$(nproc)"
ctest --test-dir build-clang --output-on-failure -j"$(nproc)"
echo "== Windows x64 and 64-bit ARM, cross-built, under Wine and qemu-user (build-windows/, build-arm64/)"
GLOVEPOSE_WERROR=$werror bash tools/cross.sh windows
GLOVEPOSE_WERROR=$werror bash tools/cross.sh arm64
