#!/usr/bin/env bash
# Peer benchmark of training: one optimiser step (forward in training mode + L2 loss + backward +
# Adam, the paper's settings) of glovepose's trainer vs PyTorch CPU on the same model, batch and
# thread count, measured back to back in one run; prints a markdown table with samples/s and ratios.
#
# Usage: bench/peers/train_run.sh [WIDTH] [BATCH] [THREADS]     (defaults 64 1024 2)
# Environment: GLOVEPOSE_BENCH (default build/bench/glovepose_bench), PEERS_OUT (default
# bench/peers/out), PEERS_REPS (default 5), FCN_HIDDEN (default 2048: also times the paper's FCN;
# 0 skips it). Needs /usr/bin/python3 with torch (bench/peers/setup.sh).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
width="${1:-64}" batch="${2:-1024}" threads="${3:-2}"
bench="${GLOVEPOSE_BENCH:-$root/build/bench/glovepose_bench}"
out="${PEERS_OUT:-$here/out}"
reps="${PEERS_REPS:-5}"
fcn="${FCN_HIDDEN:-2048}"
py=/usr/bin/python3
fail() { echo "train_run.sh: $*" >&2; exit 1; }
[ -x "$bench" ] || fail "benchmark binary '$bench' not found; build it with: cmake --build build -j2"
$py -c "import torch" 2>/dev/null || fail "/usr/bin/python3 cannot import torch; run bench/peers/setup.sh"
mkdir -p "$out"
cases="0/$width/$batch/$threads"
[ "$fcn" != 0 ] && cases="$cases|1/$fcn/$batch/$threads"
"$bench" --benchmark_list_tests | grep -Eq "^BM_TrainStep/($cases)/real_time\$" \
  || fail "'$bench' does not register BM_TrainStep/{$cases}; add the case in bench/bench_train.cpp"

echo "timing glovepose ..." >&2
"$bench" --benchmark_filter="^BM_TrainStep/($cases)/real_time\$" --benchmark_repetitions="$reps" \
  --benchmark_report_aggregates_only=true --benchmark_format=json > "$out/train_glovepose.json"
echo "timing PyTorch ..." >&2
# PyTorch twice per model: OpenBLAS with as many threads as OpenMP (the default) and with one (on a
# 2-CPU machine the two pools can oversubscribe the cores); the faster one is compared.
for arch in unet fcn; do
  [ "$arch" = fcn ] && [ "$fcn" = 0 ] && continue
  spec="unet:$width"; [ "$arch" = fcn ] && spec="fcn:$fcn:44"
  $py "$here/torch_train_bench.py" --arch "$spec" --batch "$batch" --threads "$threads" --reps "$reps" --no-profile > "$out/train_torch_${arch}.json"
  $py "$here/torch_train_bench.py" --arch "$spec" --batch "$batch" --threads "$threads" --blas-threads 1 --reps "$reps" --no-profile \
    > "$out/train_torch_${arch}_blas1.json"
done

$py - "$out" "$width" "$fcn" "$batch" "$threads" <<'PY'
import json, sys
out, width, fcn, batch, threads = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5]
ours = {}
for b in json.load(open(f"{out}/train_glovepose.json"))["benchmarks"]:
    if b.get("aggregate_name") == "median":
        ours[b["run_name"].split("/")[1]] = b["items_per_second"]
rows = [("U-Net w=" + width, ours.get("0"), "unet")]
if fcn != "0":
    rows.append(("FCN h=" + fcn, ours.get("1"), "fcn"))
print(f"\nTraining step (forward + L2 loss + backward + Adam), batch {batch}, {threads} threads, median samples/s\n")
print("| model | glovepose | PyTorch (BLAS threads = threads) | PyTorch (BLAS 1 thread) | glovepose / best PyTorch |")
print("|---|---:|---:|---:|---:|")
for name, g, arch in rows:
    rates = []
    for suffix in ("", "_blas1"):
        t = json.load(open(f"{out}/train_torch_{arch}{suffix}.json"))
        share = t.get("others_cpu_share")
        if share is not None and share > 0.05:
            print(f"warning: other processes used {share:.0%} of the CPUs while PyTorch ({arch}{suffix}) was timed", file=sys.stderr)
        rates.append(t["results"][0]["samples_per_s"])
    print(f"| {name} | {g:,.0f} | {rates[0]:,.0f} | {rates[1]:,.0f} | {g / max(rates):.1f}x |")
PY
