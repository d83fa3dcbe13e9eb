#!/usr/bin/env bash
# The README's first command: a simulated new user puts the glove on, calibrates, and performs a
# session of poses; glovepose estimates the hand row by row and prints how well and how fast.
# Installs what is missing (tools/setup.sh, via apt), builds only the glovepose tool into ./build of
# the repository, then runs `build/tools/glovepose demo "$@"` in the current directory.
# Usage: tools/demo.sh [--out DIR] [--seed S] [--minutes M] [--weights f32|f16|bf16|fixed16] [--model FILE]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/tools/setup.sh"
# The same configuration as tools/test.sh, so the two share ./build.
cmake -S "$root" -B "$root/build" -DCMAKE_BUILD_TYPE=Release
cmake --build "$root/build" --target glovepose_cli -j"$(nproc)"
exec "$root/build/tools/glovepose" demo "$@"
