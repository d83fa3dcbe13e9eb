#!/usr/bin/env bash
# Peer benchmark: glovepose's U-Net forward vs ONNX Runtime (CPU) and PyTorch, measured back to back
# in one run on this machine, printed as a markdown table with ratios to glovepose.
#
# Usage: bench/peers/run.sh [WIDTH]          (default 64; run bench/peers/setup.sh once first)
# Environment:
#   GLOVEPOSE_BENCH   the benchmark binary (default: build/bench/glovepose_bench of the repository)
#   PEERS_OUT         where model files and raw JSON go (default: bench/peers/out, git-ignored)
#   PEERS_REPS        repetitions per case (default 10), PEERS_MIN_TIME seconds per repetition for
#                     ORT and PyTorch (default 0.5, Google Benchmark's default min time)
#
# Cases: batch 1 and 1024, one thread everywhere (glovepose BM_UNetForwardF32/W/B and, if present,
# BM_UNetForwardFixed16/W/B, BM_UNetForwardF16/W/B and BM_UNetForwardBF16/W/B, with whatever /real_time or /threads:N suffixes the binary registers; ORT
# intraOpNumThreads = 1; torch.set_num_threads(1), OpenBLAS/OpenMP pinned to one thread), plus ORT
# with 2 intra-op threads at batch 1024, compared with glovepose's threads:2 case if there is one. Each engine reports
# the median over repetitions of the mean time per run. Nothing is downloaded.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
width="${1:-64}"
seed=1
bench="${GLOVEPOSE_BENCH:-$root/build/bench/glovepose_bench}"
out="${PEERS_OUT:-$here/out}"
reps="${PEERS_REPS:-10}"
min_time="${PEERS_MIN_TIME:-0.5}"
py=/usr/bin/python3
[[ "$width" =~ ^[0-9]+$ ]] || { echo "run.sh: WIDTH must be a positive integer, got '$width'" >&2; exit 2; }

# --- prerequisites, all checked before anything is timed -------------------------------------------
fail() { echo "run.sh: $*" >&2; exit 1; }
[ -x "$bench" ] || fail "glovepose benchmark binary '$bench' not found; build it with: cmake --build build -j2 (or set GLOVEPOSE_BENCH)"
cases="$("$bench" --benchmark_list_tests)" || fail "'$bench' --benchmark_list_tests failed"
for b in 1 1024; do
  grep -Eq "^BM_UNetForwardF32/$width/$b(/|\$)" <<<"$cases" \
    || fail "'$bench' has no case BM_UNetForwardF32/$width/$b (UNet cases: $(grep UNet <<<"$cases" | tr '\n' ' ')); does it register width $width?"
done
$py -c "import torch, numpy" 2>/dev/null || fail "/usr/bin/python3 cannot import torch and numpy; run bench/peers/setup.sh"
[ -d "$here/node_modules/onnxruntime-node" ] || fail "onnxruntime-node is not installed; run bench/peers/setup.sh"
mkdir -p "$out"

export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
# Busy share of all CPUs over one second (the load average lags by a minute): warn if others are working.
cpu_busy() {
  local a b
  a=($(head -1 /proc/stat)); sleep 1; b=($(head -1 /proc/stat))
  local idle=$(( b[4] + b[5] - a[4] - a[5] )) total=0 i
  for i in 1 2 3 4 5 6 7 8; do total=$(( total + b[i] - a[i] )); done
  echo $(( total > 0 ? 100 * (total - idle) / total : 0 ))
}
busy=$(cpu_busy)
echo "machine: $(nproc --all) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), ${busy}% busy before the run" >&2
if [ "$busy" -gt 10 ]; then
  echo "run.sh: warning: the CPUs were ${busy}% busy; other work on the machine skews the timings" >&2
fi

# --- the model: one random model (seed 1), as glovepose file and as ONNX ----------------------------
model="$out/unet_w$width.safetensors"
onnx="$out/unet_w$width.onnx"
$py "$root/tools/python/export.py" --width "$width" --seed "$seed" --out "$model" --onnx "$onnx" >&2

# --- timings, back to back ----------------------------------------------------------------------------
# CPU time of the whole machine and of this script's children, to tell afterwards how much of the
# CPUs other processes took during the timings.
read -r -a stat0 < <(head -1 /proc/stat)
read -r -a self0 < /proc/$$/stat
echo "timing glovepose ..." >&2
"$bench" --benchmark_filter="^BM_UNetForward(F32|Fixed16|F16|BF16)/$width/(1|1024)(/|\$)" --benchmark_repetitions="$reps" \
  --benchmark_report_aggregates_only=true --benchmark_format=json > "$out/glovepose.json"
echo "timing ONNX Runtime ..." >&2
$py "$here/torch_bench.py" --model "$model" --batches 1 --reps 1 --min-time 0.001 --warmup 0 --no-jit \
  --write-check "$out/check.json" > /dev/null
node "$here/ort_bench.js" --model "$onnx" --check "$out/check.json" --batches 1,1024 --threads 1 --extra 1024:2 \
  --reps "$reps" --min-time "$min_time" > "$out/ort.json"
echo "timing PyTorch ..." >&2
$py "$here/torch_bench.py" --model "$model" --batches 1,1024 --threads 1 --reps "$reps" --min-time "$min_time" \
  > "$out/torch.json"

read -r -a stat1 < <(head -1 /proc/stat)
read -r -a self1 < /proc/$$/stat
busy_ticks=0
for i in 1 2 3 6 7 8; do busy_ticks=$(( busy_ticks + stat1[i] - stat0[i] )); done
all_ticks=$(( busy_ticks + stat1[4] + stat1[5] - stat0[4] - stat0[5] ))
ours=$(( self1[15] + self1[16] - self0[15] - self0[16] ))  # cutime + cstime (fields 16, 17)
others=$(( all_ticks > 0 ? 100 * (busy_ticks - ours) / all_ticks : 0 ))
[ "$others" -lt 0 ] && others=0
echo "other processes used ${others}% of the CPUs during the timings" >&2
if [ "$others" -gt 5 ]; then
  echo "run.sh: warning: the timings shared the machine with other work (${others}% of the CPUs); rerun on an idle machine" >&2
fi

echo
echo "U-Net w = $width, $(nproc --all)-CPU machine, median of $reps repetitions (raw JSON in $out)"
echo
$py "$here/report.py" --width "$width" --glovepose "$out/glovepose.json" --ort "$out/ort.json" --torch "$out/torch.json"
