#!/usr/bin/env bash
# The README's first command: a simulated new user puts the glove on, calibrates, and performs a
# session of poses; glovepose estimates the hand row by row and prints how well and how fast.
# Installs what is missing for the tool alone (tools/setup.sh --demo, via apt: no test-only package,
# no npm), builds only the glovepose tool into ./build of the repository, then runs
# `build/tools/glovepose demo "$@"` in the current directory.
# Usage: tools/demo.sh [--out DIR] [--seed S] [--minutes M] [--weights f32|f16|bf16|fixed16] [--model FILE]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/tools/setup.sh" --demo
# A new ./build leaves out what needs packages the demo does not install: the tests, the benchmarks and
# the view page (three.js from npm). tools/test.sh turns them back on in the same tree; a tree it (or
# anything else) configured keeps its settings here.
new_tree=()
[ -f "$root/build/CMakeCache.txt" ] || new_tree=(-DGLOVEPOSE_BUILD_TESTS=OFF -DGLOVEPOSE_BUILD_BENCHMARKS=OFF -DGLOVEPOSE_VIEW_PAGE=OFF)
cmake -S "$root" -B "$root/build" -DCMAKE_BUILD_TYPE=Release "${new_tree[@]}"
cmake --build "$root/build" --target glovepose_cli -j"$(nproc)"
exec "$root/build/tools/glovepose" demo "$@"
