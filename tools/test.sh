#!/usr/bin/env bash
# The one command: installs what is missing, configures, builds, and runs every test.
# Usage: tools/test.sh   (from anywhere; builds into ./build of the repository)
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
# CI always has ../shared beside the repository: there a missing reference file is a failure.
# CI also always has PyTorch (installed above): there the PyTorch comparisons must run.
if [ "${CI:-}" = "true" ]; then export GLOVEPOSE_REQUIRE_REFERENCE=1 GLOVEPOSE_REQUIRE_TORCH=1; fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"
ctest --test-dir build --output-on-failure -j"$(nproc)"
