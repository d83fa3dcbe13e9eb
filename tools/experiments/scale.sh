#!/usr/bin/env bash
# Training at scale (docs/results.md, "Training at scale: people, architectures"): the linear map,
# an FCN and the U-Net trained on the first N people of one corpus, each with min-max and
# pose-guided calibration, evaluated on new people with one reading per row.
#
#   tools/experiments/scale.sh
#
# Knobs: GLOVEPOSE (build/tools/glovepose), OUT (scale-out), PEOPLE ("10 30 100"),
#        MODELS ("linear fcn:512 unet:64"), CORPUS (made here when missing: seed 101, 100 people x
#        2 sessions x 1.5 min, guided sequence, 2-reading cells), FIT (made when missing: seed 21,
#        400 people x 1.5 min, for glovepose fit-guided), TEST (made when missing: seed 2027, 5
#        people x 2 min with raw rows), THREADS (1: the published figures' setting),
#        AUGMENT ("none": training augmentation settings to compare, e.g. "none 0.05,0.05,0.02" for
#        glovepose train --augment GAIN,OFFSET,NOISE).
# Every command is logged in OUT/commands.log; the table goes to stdout.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
G=${GLOVEPOSE:-$ROOT/build/tools/glovepose}
OUT=${OUT:-scale-out}
PEOPLE=${PEOPLE:-10 30 100}
MODELS=${MODELS:-linear fcn:512 unet:64}
THREADS=${THREADS:-1}
AUGMENT=${AUGMENT:-none}
SEQUENCE=$ROOT/models/calibration_glauser2019.json
mkdir -p "$OUT"
CORPUS=${CORPUS:-$OUT/corpus100.safetensors}
FIT=${FIT:-$OUT/fit400.safetensors}
TEST=${TEST:-$OUT/test_seed2027.safetensors}
log() { echo "+ $*" >> "$OUT/commands.log"; "$@"; }

[ -f "$CORPUS" ] || log "$G" simulate --seed 101 --subjects 100 --sessions 2 --minutes 1.5 --gloves 1 \
  --calibration-sequence "$SEQUENCE" --mean-window 2 --threads "$THREADS" --out "$CORPUS" > /dev/null
[ -f "$FIT" ] || log "$G" simulate --seed 21 --subjects 400 --sessions 1 --minutes 1.5 --gloves 1 \
  --calibration-sequence "$SEQUENCE" --mean-window 2 --threads "$THREADS" --out "$FIT" > /dev/null
[ -f "$TEST" ] || log "$G" simulate --seed 2027 --subjects 5 --sessions 1 --minutes 2 --gloves 1 \
  --calibration-sequence "$SEQUENCE" --raw-rows --threads "$THREADS" --out "$TEST" > /dev/null

mean() {  # model calibration -> "mean lag" of glovepose eval on the test people, one reading per row
  log "$G" eval --model "$1" --data "$TEST" --calibration-mode "$2" --replay-rows --mean-window 1 --threads "$THREADS" --json |
    /usr/bin/python3 -c 'import json, sys; r = json.load(sys.stdin); print("%.3f %.1f" % (r["mean_deg"], r["lag_ms"]))'
}

echo "| model | augmentation | training people | min-max (deg) | pose-guided (deg) | lag (ms) |"
echo "|---|---|---:|---:|---:|---:|"
for model in $MODELS; do
  for augment in $AUGMENT; do
  for n in $PEOPLE; do
    name=$OUT/$(echo "$model" | tr -d ':')_p$n
    extra=()
    if [ "$augment" != none ]; then
      name=${name}_aug$(echo "$augment" | tr ',' '_')
      extra=(--augment "$augment")
    fi
    [ -f "$name.safetensors" ] || log "$G" train --data "$CORPUS" --architecture "$model" --gloves 0 --subjects "0-$((n - 1))" --stride 2 --validation-split frames \
      --epochs 10 --seed 1 --weights f16 --threads "$THREADS" --quiet "${extra[@]}" --out "$name.safetensors" > /dev/null
    [ -f "${name}_g.safetensors" ] || log "$G" fit-guided --model "$name.safetensors" --data "$FIT" --threads "$THREADS" \
      --out "${name}_g.safetensors" > /dev/null
    minmax=$(mean "${name}_g.safetensors" onthefly)
    guided=$(mean "${name}_g.safetensors" guided)
    echo "| $model | $augment | $n | ${minmax% *} | ${guided% *} | ${minmax#* } |"
  done
  done
done
