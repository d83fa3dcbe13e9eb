#!/usr/bin/env bash
# New users, beyond the paper (docs/results.md, "Beyond the paper"): models x calibration x readout
# on simulated people that no model was trained, fitted or tuned on.
#
#   tools/experiments/beyond.sh MODEL [MODEL ...]
#
# For every model file: glovepose eval on TEST_SUBJECTS of a fresh seed (TEST_SEED) whose people
# follow the guided calibration sequence, rows replayed through the readout with the paper's
# 5-reading mean and with fewer readings (the default: 1), with min-max and (when the model carries one)
# pose-guided calibration. The classic data-glove baseline is trained first: a linear map on 10
# people x 2 sessions x 2 min of LINEAR_SEED (the default protocol, min-max on the fly).
# Prints a markdown table (mean, p95, share under 15 degrees, lag) and the ratio to the baseline,
# then each person's mean error and the worst ratio to the baseline over the people (does a model
# ever lose to the linear map for someone?).
#
# Knobs: GLOVEPOSE (build/tools/glovepose), OUT (beyond-out), TEST_SEED (2027), TEST_SUBJECTS (5),
#        TEST_MINUTES (2), LINEAR_SEED (11), WINDOWS ("5 2 1": readout mean windows), THREADS (all cores)
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
G=${GLOVEPOSE:-$ROOT/build/tools/glovepose}
OUT=${OUT:-beyond-out}
TEST_SEED=${TEST_SEED:-2027}
TEST_SUBJECTS=${TEST_SUBJECTS:-5}
TEST_MINUTES=${TEST_MINUTES:-2}
LINEAR_SEED=${LINEAR_SEED:-11}
THREADS=${THREADS:-$(nproc)}
WINDOWS=${WINDOWS:-5 2 1}
SEQUENCE=$ROOT/models/calibration_glauser2019.json
[ $# -ge 1 ] || { echo "usage: tools/experiments/beyond.sh MODEL [MODEL ...]" >&2; exit 2; }
mkdir -p "$OUT"
log() { echo "+ $*" >> "$OUT/commands.log"; "$@"; }

test_data=$OUT/test_seed${TEST_SEED}.safetensors
[ -f "$test_data" ] || log "$G" simulate --seed "$TEST_SEED" --subjects "$TEST_SUBJECTS" --sessions 1 --minutes "$TEST_MINUTES" \
  --gloves 1 --calibration-sequence "$SEQUENCE" --raw-rows --threads "$THREADS" --out "$test_data" > /dev/null
linear_data=$OUT/linear_seed${LINEAR_SEED}.safetensors
[ -f "$linear_data" ] || log "$G" simulate --seed "$LINEAR_SEED" --subjects 10 --sessions 2 --minutes 2 --gloves 1 \
  --threads "$THREADS" --out "$linear_data" > /dev/null
linear=$OUT/linear_seed${LINEAR_SEED}.model.safetensors
[ -f "$linear" ] || log "$G" train --data "$linear_data" --model linear --out "$linear" > /dev/null

row() {  # model label calibration window
  local json=$OUT/$(basename "$1" .safetensors)_$3_w$4.json csv=$OUT/predictions.csv
  log "$G" eval --model "$1" --data "$test_data" --calibration "$3" --replay-rows --mean-window "$4" --threads "$THREADS" --json \
    --predictions "$csv" > "$json"
  # Each person's mean error, from eval's per-frame predictions, for the per-person table.
  /usr/bin/python3 - "$csv" "$2, $3, $4" >> "$OUT/people.tsv" <<'PY'
import csv, math, sys
sums, counts = {}, {}
with open(sys.argv[1]) as f:
    rows = csv.reader(f)
    header = next(rows)
    n = sum(1 for h in header if h.startswith("label_"))
    for r in rows:
        sums[r[2]] = sums.get(r[2], 0.0) + sum(abs(float(r[4 + k]) - float(r[4 + n + k])) for k in range(n))
        counts[r[2]] = counts.get(r[2], 0) + n
print("\t".join([sys.argv[2]] + [f"{s}:{math.degrees(sums[s] / counts[s]):.3f}" for s in sorted(sums, key=int)]))
PY
  rm -f "$csv"
  /usr/bin/python3 - "$json" "$2" "$3" "$4" "$OUT/$(basename "$linear" .safetensors)_onthefly_w5.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
base = json.load(open(sys.argv[5]))["mean_deg"]
print(f"| {sys.argv[2]} | {sys.argv[3]} | {sys.argv[4]} | {r['mean_deg']:.3f} | {r['p95_deg']:.2f} | {100 * r['share_under_15deg']:.1f}% | {r['lag_ms']:.1f} | {r['mean_deg'] / base:.2f} |")
PY
}

echo "Test people: seed $TEST_SEED, subjects 0-$((TEST_SUBJECTS - 1)), 1 session x $TEST_MINUTES min each, guided calibration sequence; rows replayed."
echo
rm -f "$OUT/people.tsv"
echo "| model | calibration | mean window | mean (deg) | p95 | under 15 deg | lag (ms) | vs baseline |"
echo "|---|---|---:|---:|---:|---:|---:|---:|"
baseline=$(row "$linear" "linear map (baseline)" onthefly 5)
echo "$baseline"
for window in $WINDOWS; do [ "$window" = 5 ] || row "$linear" "linear map" onthefly "$window"; done
for model in "$@"; do
  for window in $WINDOWS; do
    row "$model" "$(basename "$model")" onthefly "$window"
    if "$G" info --model "$model" 2>/dev/null | grep -q "pose-guided calibration: sequence"; then row "$model" "$(basename "$model")" guided "$window"; fi
  done
done

# Per person: does any model lose to the baseline for anyone? (mean error of each person, degrees)
echo
/usr/bin/python3 - "$OUT/people.tsv" <<'PY'
import sys
lines = [l.rstrip("\n").split("\t") for l in open(sys.argv[1])]
people = [p.split(":")[0] for p in lines[0][1:]]
base = {p.split(":")[0]: float(p.split(":")[1]) for p in lines[0][1:]}
print("| model, calibration, window | " + " | ".join(f"person {p}" for p in people) + " | worst ratio to the baseline |")
print("|---|" + "---:|" * (len(people) + 1))
for l in lines:
    means = {p.split(":")[0]: float(p.split(":")[1]) for p in l[1:]}
    print(f"| {l[0]} | " + " | ".join(f"{means[p]:.2f}" for p in people) + f" | {max(means[p] / base[p] for p in people):.2f} |")
PY
