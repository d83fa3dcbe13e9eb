#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang (ASan + UBSan) and runs each, one after another,
# on its corpus fuzz/corpus/<target>/ for SECONDS seconds (default 60). See fuzz/README.md.
#
# Usage: tools/fuzz.sh [SECONDS] [TARGET ...]
#   BUILD_DIR   build directory (default: build-fuzz beside the sources)
#   FUZZ_JOBS   build jobs (default 2)
#   FUZZ_MERGE=1  afterwards, fold new inputs that add coverage back into fuzz/corpus/<target>/ (-merge=1)
# New inputs of a run go to BUILD_DIR/corpus-new/<target>/, crashes to BUILD_DIR/findings/<target>/;
# the script exits non-zero if any target found a crash, a leak, undefined behaviour or a broken invariant.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seconds="${1:-60}"
shift || true
build="${BUILD_DIR:-$here/build-fuzz}"
jobs="${FUZZ_JOBS:-2}"
all_targets=(tensor_file_fuzz glove_description_fuzz csv_import_fuzz recording_import_fuzz estimator_stream_fuzz calibration_files_fuzz keypoint_file_fuzz glove_lines_fuzz checkpoint_file_fuzz http_request_fuzz wire_stream_fuzz engine_stream_fuzz)
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=("${all_targets[@]}")

# clang and its libFuzzer + sanitizer runtimes (Debian: libclang-rt-dev), ensured through the
# project's set-up script as extra packages (a no-op when they are installed).
"$here/tools/setup.sh" clang libclang-rt-dev

CC=clang CXX=clang++ cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DGLOVEPOSE_BUILD_FUZZERS=ON -DGLOVEPOSE_BUILD_TESTS=OFF -DGLOVEPOSE_BUILD_BENCHMARKS=OFF \
  -DGLOVEPOSE_BUILD_EXAMPLES=OFF -DGLOVEPOSE_BUILD_TOOLS=OFF -DGLOVEPOSE_BUILD_CAPI=OFF -DGLOVEPOSE_NATIVE=OFF >/dev/null
cmake --build "$build" -j "$jobs" --target "${targets[@]}"

status=0
for target in "${targets[@]}"; do
  seeds="$here/fuzz/corpus/$target"
  fresh="$build/corpus-new/$target"
  findings="$build/findings/$target"
  rm -rf "$findings"  # this run's findings only
  mkdir -p "$fresh" "$findings"
  echo "== $target: ${seconds} s on $(ls "$seeds" | wc -l) seeds"
  # New inputs go to $fresh only: a run never changes the seeds in the repository.
  set +e
  ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
    "$build/fuzz/$target" -max_total_time="$seconds" -timeout=30 -rss_limit_mb=4096 -print_final_stats=1 \
    -artifact_prefix="$findings/" "$fresh" "$seeds" >"$build/$target.log" 2>&1
  rc=$?
  set -e
  grep -E "^#[0-9]+[[:space:]]+(INITED|DONE)|^stat::(number_of_executed_units|peak_rss_mb|new_units_added)|ERROR:|SUMMARY|fuzz invariant" \
    "$build/$target.log" || true
  if [ $rc -ne 0 ] || ls "$findings" | grep -q .; then
    echo "== $target: FINDINGS (exit $rc) in $findings, log $build/$target.log"
    status=1
  fi
  if [ "${FUZZ_MERGE:-0}" = 1 ]; then
    "$build/fuzz/$target" -merge=1 "$seeds" "$fresh" >/dev/null 2>&1
    echo "== $target: corpus now $(ls "$seeds" | wc -l) files, $(du -sk "$seeds" | cut -f1) KB"
  fi
done
exit $status
