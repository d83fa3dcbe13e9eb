#!/usr/bin/env bash
# Where one frame's time goes, layer by layer, on one thread and on a team of 2 (docs/performance.md,
# "Where a team's frame goes"):
#
#   tools/experiments/team_layers.sh [WIDTH ...]     (default: 64 100)
#
# Builds team_layers.cpp, whose layer probe (include/glovepose/nn/layer_probe.hpp) reads the
# time-stamp counter at the U-Net runner's events (x86-64, GCC), -O3 -march=native, and prints per
# width a table per setting. Needs Eigen/xsimd as the library does; writes only to a temporary directory.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
g++ -std=c++17 -O3 -DNDEBUG -march=native -I"$repo/include" -isystem /usr/include/eigen3 "$here/team_layers.cpp" -o "$work/team_layers" -lpthread
widths=("$@")
[ "${#widths[@]}" -gt 0 ] || widths=(64 100)
for width in "${widths[@]}"; do
  "$work/team_layers" "$width"
  echo
done
