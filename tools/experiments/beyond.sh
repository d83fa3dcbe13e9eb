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
# people x 2 sessions x 2 min of LINEAR_SEED (the default protocol, min-max on the fly); its best
# readout window (lowest error against the truth) is the baseline.
# Prints a markdown table (mean against the labels and against the true angles, then p95, share under
# 15 degrees and lag against the truth) and the ratio to the baseline, then each person's mean error
# against the truth and the worst ratio to the baseline over the people (does a model ever lose to the
# linear map for someone?).
#
# Knobs: GLOVEPOSE (build/tools/glovepose), OUT (beyond-out), WORLD (the simulator's default world),
#        TEST_SEED (2027), TEST_SUBJECTS (5), TEST_MINUTES (2), LINEAR_SEED (11),
#        WINDOWS ("5 2 1": readout mean windows), THREADS (all cores)
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
WORLD_ARGS=()
[ -z "${WORLD:-}" ] || WORLD_ARGS=(--world "$WORLD")
SEQUENCE=$ROOT/models/calibration_glauser2019.json
[ $# -ge 1 ] || { echo "usage: tools/experiments/beyond.sh MODEL [MODEL ...]" >&2; exit 2; }
mkdir -p "$OUT"
log() { echo "+ $*" >> "$OUT/commands.log"; "$@"; }

test_data=$OUT/test_seed${TEST_SEED}.safetensors
[ -f "$test_data" ] || log "$G" simulate "${WORLD_ARGS[@]}" --seed "$TEST_SEED" --subjects "$TEST_SUBJECTS" --sessions 1 \
  --minutes "$TEST_MINUTES" --gloves 1 --calibration-sequence "$SEQUENCE" --raw-rows --threads "$THREADS" --out "$test_data" > /dev/null
linear_data=$OUT/linear_seed${LINEAR_SEED}.safetensors
[ -f "$linear_data" ] || log "$G" simulate "${WORLD_ARGS[@]}" --seed "$LINEAR_SEED" --subjects 10 --sessions 2 --minutes 2 --gloves 1 \
  --threads "$THREADS" --out "$linear_data" > /dev/null
linear=$OUT/linear_seed${LINEAR_SEED}.model.safetensors
[ -f "$linear" ] || log "$G" train --data "$linear_data" --architecture linear --validation-split frames --out "$linear" > /dev/null

rm -f "$OUT/rows.tsv"
row() {  # model label calibration window: eval -> JSON, and each person's mean error against the truth
  local json=$OUT/$(basename "$1" .safetensors)_$3_w$4.json csv=$OUT/predictions.csv
  if ! log "$G" eval --model "$1" --data "$test_data" --calibration-mode "$3" --replay-rows --mean-window "$4" --threads "$THREADS" --json \
    --predictions "$csv" > "$json" 2> "$OUT/eval.err"; then  # e.g. a calibration unlike the model's sequence: a row saying why
    printf '%s\t%s\t%s\trefused\t%s\n' "$2" "$3" "$4" "$(tr '\n\t' '  ' < "$OUT/eval.err")" >> "$OUT/rows.tsv"
    return
  fi
  /usr/bin/python3 - "$csv" >> "$OUT/rows.tsv" <<PY
import csv, math, sys
sums, counts = {}, {}
with open(sys.argv[1]) as f:
    rows = csv.reader(f)
    header = next(rows)
    pred = [i for i, h in enumerate(header) if h.startswith("pred_")]
    ref = [i for i, h in enumerate(header) if h.startswith("truth_")] or [i for i, h in enumerate(header) if h.startswith("label_")]
    for r in rows:
        sums[r[2]] = sums.get(r[2], 0.0) + sum(abs(float(r[p]) - float(r[t])) for p, t in zip(pred, ref))
        counts[r[2]] = counts.get(r[2], 0) + len(pred)
people = " ".join(f"{s}:{math.degrees(sums[s] / counts[s]):.3f}" for s in sorted(sums, key=int))
print("\t".join(["$2", "$3", "$4", "$json", people]))
PY
  rm -f "$csv"
}

for window in $WINDOWS; do row "$linear" "linear map" onthefly "$window"; done
for model in "$@"; do
  for window in $WINDOWS; do
    row "$model" "$(basename "$model")" onthefly "$window"
    if "$G" info --model "$model" 2>/dev/null | grep -q "pose-guided calibration: sequence"; then row "$model" "$(basename "$model")" guided "$window"; fi
  done
done

echo "Test people: seed $TEST_SEED, subjects 0-$((TEST_SUBJECTS - 1)), 1 session x $TEST_MINUTES min each, guided calibration sequence; rows replayed."
echo
/usr/bin/python3 - "$OUT/rows.tsv" <<'PY'
import json, sys
rows, refused = [], []
for line in open(sys.argv[1]):
    label, calibration, window, path, people = line.rstrip("\n").split("\t")
    if path == "refused":
        refused.append(f"| {label} | {calibration} | {window} | refused: {people.strip()} |")
        continue
    r = json.load(open(path))
    truth = r["vs_truth"] or r["vs_labels"]
    rows.append((label, calibration, window, r["vs_labels"], truth, {p.split(":")[0]: float(p.split(":")[1]) for p in people.split()}))
linear = [r for r in rows if r[0] == "linear map"]
base = min(linear, key=lambda r: r[4]["mean_deg"])
print(f"Baseline: the linear map with its best readout window ({base[2]} readings), {base[4]['mean_deg']:.3f} degrees against the truth.")
print()
print("| model | calibration | mean window | mean vs labels (deg) | mean vs truth | p95 | under 15 deg | lag (ms) | vs baseline |")
print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
for label, calibration, window, labels, truth, _ in rows:
    print(f"| {label} | {calibration} | {window} | {labels['mean_deg']:.3f} | {truth['mean_deg']:.3f} | {truth['p95_deg']:.2f} | "
          f"{100 * truth['share_under_15deg']:.1f}% | {truth['lag_ms']:.1f} | {truth['mean_deg'] / base[4]['mean_deg']:.2f} |")
for line in refused: print(line)
print()
people = sorted(base[5], key=int)
print("| model, calibration, window | " + " | ".join(f"person {p}" for p in people) + " | worst ratio to the baseline |")
print("|---|" + "---:|" * (len(people) + 1))
for label, calibration, window, _, _, means in rows:
    print(f"| {label}, {calibration}, {window} | " + " | ".join(f"{means[p]:.2f}" for p in people) +
          f" | {max(means[p] / base[5][p] for p in people):.2f} |")
PY
