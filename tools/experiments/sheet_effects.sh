#!/usr/bin/env bash
# How linear a simulated world's glove is, and whether a network beats a linear map on it, for
# several settings of the world (docs/simulator.md, "How the sheet's nonlinear effects change the
# glove"). Per setting:
#   - the linearity corpus: seed 1, 10 subjects x 3 sessions x 2 minutes, one donning per person;
#   - world_measures.py linearity on it: held-out-session R^2 of the cells from the true angles,
#     linear against flexible (calibrated and raw), and the angles from the calibrated cells;
#   - personal models as Table 1's (1) splits them (sessions 0, 1 -> 2), a linear map and an FCN
#     (FCN, default fcn:512, the trainer's default epochs), per subject, against the labels and the
#     truth: the networks-against-linear gap, reported as it comes out.
#
# Usage: tools/experiments/sheet_effects.sh NAME[=SETTINGS] ...
#   NAME alone: the fitted world; NAME=SETTINGS: --set SETTINGS (world parameters, comma-separated).
#   e.g. tools/experiments/sheet_effects.sh fitted hold=wear.neighbour_hold=0.5
# Knobs: GLOVEPOSE (default build/tools/glovepose), OUT (default experiments-out/sheet), SUBJECTS
# (default 0-9, as a list 0 1 2), FCN. Needs /usr/bin/python3 with numpy and torch (world_measures.py).
# Everything it writes goes to OUT; a corpus, model or result that exists is reused.
set -euo pipefail

if (($# == 0)); then
  echo "usage: $0 NAME[=SETTINGS] ...   (e.g. fitted hold=wear.neighbour_hold=0.5)" >&2
  exit 2
fi
G=${GLOVEPOSE:-build/tools/glovepose}
OUT=${OUT:-experiments-out/sheet}
SUBJECTS=${SUBJECTS:-0 1 2 3 4 5 6 7 8 9}
FCN=${FCN:-fcn:512}
HERE=$(cd "$(dirname "$0")" && pwd)
[[ -x $G ]] || { echo "$0: no glovepose binary at $G (build it, or set GLOVEPOSE)" >&2; exit 2; }
mkdir -p "$OUT"

# summarise OUT NAME FCN CAL_ROW RAW_ROW INVERSE_ROW SUBJECT...: the setting's per-subject table (on
# stderr) and its summary row (on stdout).
summarise() {
  /usr/bin/python3 - "$@" <<'EOF'
import json, sys
out, name, fcn, cal, raw, inv, *subjects = sys.argv[1:]
cell = lambda row, i: row.split('|')[i].strip()
res = {a: {k: [] for k in ('vs_labels', 'vs_truth')} for a in ('linear', fcn)}
print(f"## {name}: personal models, session 2 (degrees)\n\n| subject | linear vs labels | {fcn} vs labels | linear vs truth | {fcn} vs truth |\n|---|---:|---:|---:|---:|", file=sys.stderr)
for s in subjects:
    row = []
    for a in ('linear', fcn):
        d = json.load(open(f"{out}/{name}.s{s}.{a.replace(':', '')}.json"))
        for k in ('vs_labels', 'vs_truth'):
            res[a][k].append(d[k]['mean_deg'])
    print(f"| {s} | {res['linear']['vs_labels'][-1]:.2f} | {res[fcn]['vs_labels'][-1]:.2f} | {res['linear']['vs_truth'][-1]:.2f} | {res[fcn]['vs_truth'][-1]:.2f} |", file=sys.stderr)
m = lambda xs: sum(xs) / len(xs)
wins = sum(f < l for f, l in zip(res[fcn]['vs_truth'], res['linear']['vs_truth']))
print(f"| {name} | {cell(cal, 2)} / {cell(cal, 3)} | {cell(raw, 2)} / {cell(raw, 3)} | {cell(inv, 2)} / {cell(inv, 3)} ({cell(inv, 4)}) | "
      f"{m(res['linear']['vs_truth']):.2f} / {m(res[fcn]['vs_truth']):.2f} ({m(res[fcn]['vs_truth']) / m(res['linear']['vs_truth']):.3f}; {wins} of {len(subjects)}) | "
      f"{m(res['linear']['vs_labels']):.2f} / {m(res[fcn]['vs_labels']):.2f} ({m(res[fcn]['vs_labels']) / m(res['linear']['vs_labels']):.3f}) |")
EOF
}

summary=()
for arg in "$@"; do
  name=${arg%%=*}
  set_args=()
  [[ $arg == *=* ]] && set_args=(--set "${arg#*=}")
  corpus=$OUT/$name.safetensors
  if [[ ! -f $corpus ]]; then
    "$G" simulate --seed 1 --subjects 10 --sessions 3 --minutes 2 --gloves 1 --calibration-seconds 30 --threads 0 \
      "${set_args[@]}" --out "$corpus" >&2  # written whole or not at all
  fi
  report=$OUT/$name.linearity.md
  if [[ ! -f $report ]]; then
    nice -n 19 /usr/bin/python3 "$HERE/world_measures.py" linearity "$corpus" > "$report.partial"
    mv "$report.partial" "$report"
  fi
  # The three "| mean |" rows of the report: calibrated cells, raw cells, angles from cells.
  mapfile -t means < <(grep '^| mean |' "$report")
  ((${#means[@]} == 3)) || { echo "$0: $report has ${#means[@]} mean rows, expected 3" >&2; exit 1; }
  for s in $SUBJECTS; do
    for arch in linear "$FCN"; do
      tag=${arch//:/}
      model=$OUT/$name.s$s.$tag.safetensors
      [[ -f $model ]] || "$G" train --data "$corpus" --architecture "$arch" --subjects "$s" --gloves 0 --sessions 0,1 \
        --calibration-mode onthefly --threads 0 --quiet --out "$model" >&2
      [[ -f ${model%.safetensors}.json ]] || {
        "$G" eval --model "$model" --data "$corpus" --subjects "$s" --gloves 0 --sessions 2 --json > "${model%.safetensors}.json.partial"
        mv "${model%.safetensors}.json.partial" "${model%.safetensors}.json"
      }
    done
  done
  line=$(summarise "$OUT" "$name" "$FCN" "${means[@]}" $SUBJECTS)
  summary+=("$line")
done

echo
echo "| setting | R^2 calibrated cells, linear / flexible | R^2 raw cells, linear / flexible | angles from cells vs truth, linear / flexible (ratio) | personal (1) vs truth, linear / $FCN (ratio; subjects the FCN wins) | the same vs labels (ratio) |"
echo "|---|---:|---:|---:|---:|---:|"
printf '%s\n' "${summary[@]}"
