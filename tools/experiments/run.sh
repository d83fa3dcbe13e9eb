#!/usr/bin/env bash
# Re-runs the paper's experiments (Glauser et al. 2019, Sec. 5.2 and 5.4) on the simulated corpus
# and writes a markdown section per experiment. See tools/experiments/README.md.
#
#   tools/experiments/run.sh table1|table2|table3|table45|fig12|fig14|all [--quick]
#
# Knobs (environment, defaults in brackets; --quick changes some, see usage below):
#   GLOVEPOSE, CORPUS, CORPUS_SEED, OUT, WIDTH, EPOCHS, FINETUNE_EPOCHS, STRIDE, THREADS, SEED,
#   SUBJECTS, TABLE2_SUBJECTS, TABLE2_FRACTIONS, TABLE2_SAME_STEPS, TABLE3_SUBJECTS, TABLE45_SUBJECTS, TABLE45_UNET_WIDTHS,
#   TABLE45_TORCH, FCN_OPTIMIZER, FIG12_SUBJECTS, FIG14_SUBJECTS
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
PY=/usr/bin/python3
REPORT="$HERE/report.py"

usage() {
  cat <<EOF
usage: tools/experiments/run.sh EXPERIMENT [--quick]

EXPERIMENT:
  table1    personalised / generic / fine-tuned models per subject (paper Table 1)
  table2    less training data: 100/50/25/10% (paper Table 2)
  table3    Glove II: generic (glove I), fine-tuned on glove II, personalised on glove II (paper Table 3)
  table45   FCN vs U-Net vs linear (and LSTM, ResNet, CGAN: TABLE45_TORCH) at ~3M and ~13M parameters (paper Tables 4, 5)
  fig12     14 vs 44 sensor cells, generic model (4) (paper Fig. 12)
  fig14     cumulative error curve of (4), with (2) and (3) (paper Fig. 14)
  all       all of the above (table1 first: the others reuse its models)

--quick     a tiny corpus (3 subjects x 5 sessions x 0.5 min) and tiny settings, to check the pipeline.

Environment knobs [default; --quick default]:
  GLOVEPOSE          the glovepose binary [<repo>/build/tools/glovepose]
  OUT                output directory [<repo>/experiments-out; <repo>/experiments-out/quick]
  CORPUS             dataset file [\$OUT/corpus.safetensors, simulated if missing]
  CORPUS_SEED        seed of the simulated corpus [1]
  WORLD              simulated world of that corpus (glovepose simulate --world) [fitted, the simulator's default]
  WITHOUT            effects of that world switched off, e.g. slip,drift (glovepose simulate --without) [none]
  SET                parameters of that world set, e.g. people.skin_spread=0.5 (glovepose simulate --set) [none]
  WIDTH              U-Net width of table1/table2/fig12/fig14 [64; 8]
  EPOCHS             training epochs [6; 1]
  FINETUNE_EPOCHS    fine-tuning epochs of Table 1 (5) [5; 1]
  STRIDE             frame stride of the generic models (personalised: 1) [5]
  THREADS            threads per glovepose command [all cores]
  SEED               training seed [1]
  SUBJECTS           subjects of table1 [all of the corpus]
  FIG14_SUBJECTS     subjects pooled in fig14 [\$SUBJECTS]
  TABLE2_SUBJECTS    [0,4,9; 0,2]     TABLE2_FRACTIONS  percentages [100 50 25 10]
  TABLE2_SAME_STEPS  1: train a fraction f for EPOCHS/f epochs (as many steps as 100%) [0: EPOCHS]
  TABLE3_SUBJECTS    [0,4,9; 0,2]
  TABLE45_SUBJECTS   [0,4,9; 0,2]     TABLE45_UNET_WIDTHS  [48 100 (paper3m, paper13m); 6 8]
  TABLE45_TORCH      networks of table45 trained with PyTorch (torch_networks.py), of the U-Net's size:
                     any of lstm resnet cgan unet fcn [none]
  FCN_OPTIMIZER      adam|sgd (sgd: the paper's lr 0.01) [adam]
  FIG12_SUBJECTS     [0,4,9; 0,2]
Lists: "0,4,9" or "0-9". Finished models and results are kept: a re-run skips them.
EOF
}

die() {
  echo "run.sh: error: $*" >&2
  exit 1
}

# ---------------------------------------------------------------------------------------------
# Arguments and knobs.

EXPERIMENT=""
QUICK=0
for arg in "$@"; do
  case "$arg" in
    --quick) QUICK=1 ;;
    -h | --help) usage; exit 0 ;;
    table1 | table2 | table3 | table45 | fig12 | fig14 | all)
      [[ -z $EXPERIMENT ]] || die "one experiment at a time (got '$EXPERIMENT' and '$arg'); use 'all' for every one"
      EXPERIMENT=$arg ;;
    *) usage >&2; die "unknown argument '$arg'" ;;
  esac
done
[[ -n $EXPERIMENT ]] || { usage >&2; die "no experiment given"; }

abspath() { [[ $1 = /* ]] && printf '%s' "$1" || printf '%s/%s' "$PWD" "$1"; }

if ((QUICK)); then
  OUT=${OUT:-$ROOT/experiments-out/quick}
  WIDTH=${WIDTH:-8}
  EPOCHS=${EPOCHS:-1}
  FINETUNE_EPOCHS=${FINETUNE_EPOCHS:-1}
  TABLE2_SUBJECTS=${TABLE2_SUBJECTS:-0,2}
  TABLE3_SUBJECTS=${TABLE3_SUBJECTS:-0,2}
  TABLE45_SUBJECTS=${TABLE45_SUBJECTS:-0,2}
  TABLE45_UNET_WIDTHS=${TABLE45_UNET_WIDTHS:-6 8}
  FIG12_SUBJECTS=${FIG12_SUBJECTS:-0,2}
else
  OUT=${OUT:-$ROOT/experiments-out}
  WIDTH=${WIDTH:-64}
  EPOCHS=${EPOCHS:-6}
  FINETUNE_EPOCHS=${FINETUNE_EPOCHS:-5}
  TABLE2_SUBJECTS=${TABLE2_SUBJECTS:-0,4,9}
  TABLE3_SUBJECTS=${TABLE3_SUBJECTS:-0,4,9}
  TABLE45_SUBJECTS=${TABLE45_SUBJECTS:-0,4,9}
  TABLE45_UNET_WIDTHS=${TABLE45_UNET_WIDTHS:-48 100}
  FIG12_SUBJECTS=${FIG12_SUBJECTS:-0,4,9}
fi
OUT=$(abspath "$OUT")
GLOVEPOSE=$(abspath "${GLOVEPOSE:-$ROOT/build/tools/glovepose}")
CORPUS=$(abspath "${CORPUS:-$OUT/corpus.safetensors}")
CORPUS_SEED=${CORPUS_SEED:-1}
WORLD=${WORLD:-fitted}
WITHOUT=${WITHOUT:-}
SET=${SET:-}
STRIDE=${STRIDE:-5}
THREADS=${THREADS:-$(nproc)}
SEED=${SEED:-1}
TABLE2_FRACTIONS=${TABLE2_FRACTIONS:-100 50 25 10}
TABLE2_SAME_STEPS=${TABLE2_SAME_STEPS:-0}
FCN_OPTIMIZER=${FCN_OPTIMIZER:-adam}
TABLE45_TORCH=${TABLE45_TORCH:-}

is_uint() { [[ $1 =~ ^[0-9]+$ ]]; }
for knob in WIDTH EPOCHS FINETUNE_EPOCHS STRIDE THREADS SEED CORPUS_SEED TABLE2_SAME_STEPS; do
  is_uint "${!knob}" || die "$knob='${!knob}' is not a non-negative integer"
done
((WIDTH >= 1 && EPOCHS >= 1 && FINETUNE_EPOCHS >= 1 && STRIDE >= 1 && THREADS >= 1)) ||
  die "WIDTH, EPOCHS, FINETUNE_EPOCHS, STRIDE and THREADS must be >= 1"
for w in $TABLE45_UNET_WIDTHS; do is_uint "$w" && ((w >= 1)) || die "TABLE45_UNET_WIDTHS: '$w' is not a width >= 1"; done
for p in $TABLE2_FRACTIONS; do is_uint "$p" && ((p >= 1 && p <= 100)) || die "TABLE2_FRACTIONS: '$p' is not a percentage 1..100"; done
for n in $TABLE45_TORCH; do [[ $n =~ ^(lstm|resnet|cgan|unet|fcn)$ ]] || die "TABLE45_TORCH: '$n', expected lstm, resnet, cgan, unet or fcn"; done
[[ $FCN_OPTIMIZER == adam || $FCN_OPTIMIZER == sgd ]] || die "FCN_OPTIMIZER='$FCN_OPTIMIZER', expected adam or sgd"
[[ -x $GLOVEPOSE ]] || die "no glovepose binary at $GLOVEPOSE (build it: cmake --build build --target glovepose, or set GLOVEPOSE)"
[[ -x $PY ]] || die "$PY not found (Debian's python3 with numpy is needed for the reports)"

mkdir -p "$OUT"
LOG=$OUT/commands.log

# "0-2,5" -> "0 1 2 5"
expand_list() {
  local item ids=() lo hi v items
  IFS=',' read -ra items <<<"$1"
  for item in "${items[@]}"; do
    item=${item// /}
    [[ -n $item ]] || continue
    if [[ $item =~ ^([0-9]+)-([0-9]+)$ ]]; then
      lo=${BASH_REMATCH[1]} hi=${BASH_REMATCH[2]}
      ((lo <= hi)) || die "list '$1': range '$item' runs backwards"
      for ((v = lo; v <= hi; v++)); do ids+=("$v"); done
    elif [[ $item =~ ^[0-9]+$ ]]; then
      ids+=("$item")
    else
      die "list '$1': '$item' is not an id or a range like 0-3"
    fi
  done
  ((${#ids[@]})) || die "list '$1' is empty"
  echo "${ids[@]}"
}

# Shell-quoted command line with the binary shown as 'glovepose'.
quote() {
  local s="" a
  for a in "$@"; do
    if [[ $a =~ ^[A-Za-z0-9_./:,=+@%-]+$ ]]; then s+="$a "; else s+="$(printf '%q' "$a") "; fi
  done
  s=${s% }
  printf '%s' "${s//"$GLOVEPOSE"/glovepose}"
}
# The same, paths relative to the repository root (as shown in the markdown).
show() { local s; s=$(quote "$@"); printf '%s' "${s//"$ROOT"\//}"; }
log() { printf '%s  %s\n' "$(date '+%F %T')" "$*" >>"$LOG"; }
rel() { local p=$1; [[ $p == "$ROOT"/* ]] && p=${p#"$ROOT"/}; printf '%s' "$p"; }
say() { printf '[%s] %s\n' "$CURRENT" "$*" >&2; }

# ---------------------------------------------------------------------------------------------
# The corpus and the settings every stored model depends on.

CURRENT=setup
if [[ ! -s $CORPUS ]]; then
  sim=("$GLOVEPOSE" simulate --seed "$CORPUS_SEED" --world "$WORLD" --threads "$THREADS" --out "$CORPUS.partial")
  [[ -n $WITHOUT ]] && sim+=(--without "$WITHOUT")
  [[ -n $SET ]] && sim+=(--set "$SET")
  ((QUICK)) && sim+=(--subjects 3 --sessions 5 --minutes 0.5)
  mkdir -p "$(dirname "$CORPUS")"
  say "simulating the corpus: $(quote "${sim[@]}")"
  log "$(quote "${sim[@]}") && mv $(quote "$CORPUS.partial" "$CORPUS")"
  "${sim[@]}" >&2 || die "glovepose simulate failed"
  mv "$CORPUS.partial" "$CORPUS"
fi
ALL_SUBJECTS=$("$PY" "$REPORT" corpus-subjects "$CORPUS") || die "cannot read the subjects of $CORPUS"
SUBJECTS=${SUBJECTS:-$(tr ' ' ',' <<<"$ALL_SUBJECTS")}
FIG14_SUBJECTS=${FIG14_SUBJECTS:-$SUBJECTS}
check_subjects() {  # NAME LIST -> expanded list; dies on a subject not in the corpus
  local s list
  list=$(expand_list "$2")
  for s in $list; do
    [[ " $ALL_SUBJECTS " == *" $s "* ]] || die "$1: subject $s is not in $CORPUS (its subjects: $ALL_SUBJECTS)"
  done
  (($(wc -w <<<"$ALL_SUBJECTS") > 1)) || die "the corpus has one subject: generic (leave-one-out) models need two or more"
  echo "$list"
}

# Models are kept between runs; a run with other settings would silently mix them, so refuse it.
SETTINGS="corpus=$CORPUS corpus_bytes=$(stat -c %s "$CORPUS") width=$WIDTH epochs=$EPOCHS finetune_epochs=$FINETUNE_EPOCHS stride=$STRIDE seed=$SEED quick=$QUICK"
if [[ -f $OUT/settings.txt ]]; then
  [[ $(cat "$OUT/settings.txt") == "$SETTINGS" ]] ||
    die "$OUT holds models made with other settings:
  stored: $(cat "$OUT/settings.txt")
  now:    $SETTINGS
use another OUT, or remove $OUT to start over"
else
  echo "$SETTINGS" >"$OUT/settings.txt"
fi

# ---------------------------------------------------------------------------------------------
# Jobs: every model and result is written under a temporary name and renamed when complete, so an
# interrupted run leaves no file that a later run would take as finished.

JOB_CMDS=""   # the glovepose commands of the entry being built (for the manifest)
MANIFEST=""

# train_model OUT.safetensors LABEL glovepose-args...   (train or finetune; --out/--threads added)
train_model() {
  local out=$1 label=$2
  shift 2
  # --validation-split frames: the tables in docs/results.md were made with it (the last 10% of
  # every session validates; whole held-out sessions would take them out of training).
  local shown=("$GLOVEPOSE" "$@" --validation-split frames --threads "$THREADS" --out "$out")
  JOB_CMDS+="$(show "${shown[@]}") ; "
  if [[ -s $out ]]; then
    log "skip (exists): $(quote "${shown[@]}")"
    return 0
  fi
  local tmp=${out%.safetensors}.partial.safetensors joblog=${out%.safetensors}.log
  [[ $joblog == "$OUT"/* ]] && joblog=$OUT/logs/${joblog#"$OUT"/}
  mkdir -p "$(dirname "$joblog")" "$(dirname "$out")"
  local cmd=("$GLOVEPOSE" "$@" --validation-split frames --threads "$THREADS" --out "$tmp")
  log "$(quote "${cmd[@]}") && mv $(quote "$tmp" "$out")"
  say "$label: $1 ..."
  local start=$SECONDS status=0
  "${cmd[@]}" >"$joblog" 2>&1 || status=$?
  if ((status == 130)); then
    die "interrupted during $label; a re-run continues here (this model is trained again, the finished ones are kept)"
  elif ((status != 0)); then
    tail -n 15 "$joblog" >&2
    die "glovepose $1 failed (exit $status) for $label; full output in $joblog"
  fi
  mv "$tmp" "$out"
  local result
  result=$(grep -E '^(done|stopped)' "$joblog" | tail -n 1 | sed 's/; wrote .*//') || true
  say "$label: ${result:-finished} [$((SECONDS - start)) s]"
}

# eval_json OUT.json LABEL eval-args...   (--json/--threads added)
eval_json() {
  local out=$1 label=$2
  shift 2
  local shown=("$GLOVEPOSE" eval "$@" --threads "$THREADS" --json)
  JOB_CMDS+="$(show "${shown[@]}") > $(rel "$out") ; "
  if [[ -s $out ]]; then
    log "skip (exists): $(quote "${shown[@]}") > $(quote "$out")"
    return 0
  fi
  local joblog=$OUT/logs/eval.log status=0
  mkdir -p "$OUT/logs" "$(dirname "$out")"
  log "$(quote "${shown[@]}") > $(quote "$out.partial") && mv $(quote "$out.partial" "$out")"
  "${shown[@]}" >"$out.partial" 2>>"$joblog" || status=$?
  if ((status != 0)); then
    tail -n 5 "$joblog" >&2
    die "glovepose eval failed (exit $status) for $label; see $joblog"
  fi
  mv "$out.partial" "$out"
  say "$label: mean error $("$PY" -c 'import json,sys; print("%.2f deg" % json.load(open(sys.argv[1]))["mean_deg"])' "$out")"
}

# torch_json OUT.json LABEL torch_networks.py-args...   (--json/--threads added): trains with PyTorch and scores
torch_json() {
  local out=$1 label=$2
  shift 2
  local shown=("$PY" "$HERE/torch_networks.py" "$@" --threads "$THREADS" --json)
  JOB_CMDS+="$(show "${shown[@]}") $(rel "$out") ; "
  if [[ -s $out ]]; then
    log "skip (exists): $(quote "${shown[@]}" "$out")"
    return 0
  fi
  local joblog=$OUT/logs/${out#"$OUT"/}
  joblog=${joblog%.json}.log status=0 start=$SECONDS
  mkdir -p "$(dirname "$joblog")" "$(dirname "$out")"
  log "$(quote "${shown[@]}" "$out.partial") && mv $(quote "$out.partial" "$out")"
  say "$label (PyTorch) ..."
  "${shown[@]}" "$out.partial" >"$joblog" 2>&1 || status=$?
  if ((status != 0)); then
    tail -n 15 "$joblog" >&2
    die "torch_networks.py failed (exit $status) for $label; full output in $joblog"
  fi
  mv "$out.partial" "$out"
  say "$label: $(tail -n 1 "$joblog" | sed 's/; wrote .*//') [$((SECONDS - start)) s]"
}

# record SUBJECT "TAGS" JSON: one manifest line for report.py; resets JOB_CMDS.
record() {
  printf '%s\t%s\t%s\t%s\n' "$1" "$2" "$3" "$JOB_CMDS" >>"$MANIFEST"
  JOB_CMDS=""
}

begin_experiment() {
  CURRENT=$1
  mkdir -p "$OUT/$1"
  MANIFEST=$OUT/$1/manifest.tsv
  : >"$MANIFEST"
  JOB_CMDS=""
  log "=== $(experiment_command "$1")"
  say "output in $(rel "$OUT/$1")/, commands in $(rel "$LOG")"
}

# The exact command, with every knob that changes the results.
# The corpus's world matters only when the run simulates it; it is always named.
WORLD_KNOBS=" WORLD=$WORLD"
[[ -n $WITHOUT ]] && WORLD_KNOBS+=" WITHOUT=$WITHOUT"
[[ -n $SET ]] && WORLD_KNOBS+=" SET=$SET"
COMMAND_LINE="CORPUS=$(rel "$CORPUS")$WORLD_KNOBS WIDTH=$WIDTH EPOCHS=$EPOCHS FINETUNE_EPOCHS=$FINETUNE_EPOCHS STRIDE=$STRIDE SEED=$SEED"
experiment_command() {  # EXPERIMENT "EXTRA KNOBS"
  local quick=""
  ((QUICK)) && quick=" --quick"
  printf '%s%s tools/experiments/run.sh %s%s' "$COMMAND_LINE" "${2:+ $2}" "$1" "$quick"
}

finish_experiment() {  # EXPERIMENT "EXTRA KNOBS" [SVG]
  local args=("$1" --manifest "$MANIFEST" --md "$OUT/$1.md" --corpus "$CORPUS" --root "$ROOT"
    --title-command "$(experiment_command "$1" "$2")"
    --setting "width=$WIDTH" --setting "epochs=$EPOCHS" --setting "finetune_epochs=$FINETUNE_EPOCHS"
    --setting "stride=$STRIDE (personalised 1)" --setting "seed=$SEED" --setting "fcn_optimizer=$FCN_OPTIMIZER")
  ((QUICK)) && args+=(--setting "quick=yes (tiny corpus and settings: not results)")
  [[ -n ${3:-} ]] && args+=(--svg "$3")
  echo >&2
  "$PY" "$REPORT" "${args[@]}" || die "report.py $1 failed"
  say "wrote $(rel "$OUT/$1.md")${3:+ and $(rel "$3")}"
}

# ---------------------------------------------------------------------------------------------
# The models of Table 1 (paper Sec. 5.2), kept in $OUT/table1/ and reused by the other experiments.
# Glove 0 only. Each sets JSON to its eval result.

T1=$OUT/table1
personal_intra() {  # (1): sessions 0, 1 -> session 2
  local s=$1 m=$T1/s${1}_intra.safetensors
  train_model "$m" "s$s (1) intra" train --data "$CORPUS" --architecture "unet:$WIDTH" --subjects "$s" --gloves 0 --sessions 0,1 \
    --calibration-mode onthefly --batch 256 --epochs "$EPOCHS" --seed "$SEED"
  JSON=$T1/s${s}_intra.json
  eval_json "$JSON" "s$s (1) intra" --model "$m" --data "$CORPUS" --subjects "$s" --gloves 0 --sessions 2 --calibration-mode onthefly
}
personal_inter() {  # (2): sessions 0-3 -> session 4; [STRIDE TAG DIR EPOCHS] for Table 2
  local s=$1 stride=${2:-1} tag=${3:-inter} dir=${4:-$T1} epochs=${5:-$EPOCHS}
  local m=$dir/s${s}_$tag.safetensors
  train_model "$m" "s$s (2) $tag" train --data "$CORPUS" --architecture "unet:$WIDTH" --subjects "$s" --gloves 0 --sessions 0-3 \
    --stride "$stride" --calibration-mode onthefly --batch 256 --epochs "$epochs" --seed "$SEED"
  JSON=$dir/s${s}_$tag.json
  eval_json "$JSON" "s$s (2) $tag" --model "$m" --data "$CORPUS" --subjects "$s" --gloves 0 --sessions 4 --calibration-mode onthefly
}
generic_nocal() {  # (3): other subjects, training-data min-max -> all sessions of s
  local s=$1 m=$T1/s${1}_nocal.safetensors
  train_model "$m" "s$s (3) generic w/o calib" train --data "$CORPUS" --architecture "unet:$WIDTH" --exclude-subjects "$s" --gloves 0 \
    --stride "$STRIDE" --calibration-mode training --batch 1024 --epochs "$EPOCHS" --seed "$SEED"
  JSON=$T1/s${s}_nocal.json
  eval_json "$JSON" "s$s (3) generic w/o calib" --model "$m" --data "$CORPUS" --subjects "$s" --gloves 0 --calibration-mode training
}
generic_cal_model() {  # (4)'s model; [STRIDE TAG DIR EPOCHS] for Table 2
  local s=$1 stride=${2:-$STRIDE} tag=${3:-cal} dir=${4:-$T1} epochs=${5:-$EPOCHS}
  MODEL=$dir/s${s}_$tag.safetensors
  train_model "$MODEL" "s$s (4) $tag" train --data "$CORPUS" --architecture "unet:$WIDTH" --exclude-subjects "$s" --gloves 0 \
    --stride "$stride" --calibration-mode onthefly --batch 1024 --epochs "$epochs" --seed "$SEED"
}
generic_cal() {  # (4): other subjects, on-the-fly calibration -> all sessions of s
  local s=$1 tag=${3:-cal} dir=${4:-$T1}
  generic_cal_model "$@"
  JSON=$dir/s${s}_$tag.json
  eval_json "$JSON" "s$s (4) $tag" --model "$MODEL" --data "$CORPUS" --subjects "$s" --gloves 0 --calibration-mode onthefly
}
finetuned() {  # (5): (4) fine-tuned on session 0 of s -> sessions 1-4
  local s=$1 m=$T1/s${1}_tuned.safetensors
  generic_cal_model "$s"
  train_model "$m" "s$s (5) fine-tuned" finetune --model "$MODEL" --data "$CORPUS" --subjects "$s" --gloves 0 --sessions 0 \
    --epochs "$FINETUNE_EPOCHS" --seed "$SEED"
  JSON=$T1/s${s}_tuned.json
  eval_json "$JSON" "s$s (5) fine-tuned" --model "$m" --data "$CORPUS" --subjects "$s" --gloves 0 --sessions 1-4 --calibration-mode onthefly
}
generic_cal_s14() {  # (4) on sessions 1-4 only: (5)'s test sessions, for a like-for-like comparison
  local s=$1
  generic_cal_model "$s"
  JSON=$T1/s${s}_cal_s1-4.json
  eval_json "$JSON" "s$s (4) on sessions 1-4" --model "$MODEL" --data "$CORPUS" --subjects "$s" --gloves 0 --sessions 1-4 --calibration-mode onthefly
}

# ---------------------------------------------------------------------------------------------
# Experiments.

run_table1() {
  begin_experiment table1
  local s
  local subjects
  subjects=$(check_subjects SUBJECTS "$SUBJECTS")
  for s in $subjects; do
    personal_intra "$s"; record "$s" "column=intra" "$JSON"
    personal_inter "$s"; record "$s" "column=inter" "$JSON"
    generic_nocal "$s"; record "$s" "column=nocal" "$JSON"
    generic_cal "$s"; record "$s" "column=cal" "$JSON"
    finetuned "$s"; record "$s" "column=tuned" "$JSON"
    generic_cal_s14 "$s"; record "$s" "column=cal_s1-4" "$JSON"
  done
  finish_experiment table1 "SUBJECTS=$SUBJECTS"
}

run_table2() {
  begin_experiment table2
  local s p sp sg e
  local subjects
  subjects=$(check_subjects TABLE2_SUBJECTS "$TABLE2_SUBJECTS")
  for s in $subjects; do
    for p in $TABLE2_FRACTIONS; do
      sp=$(((100 + p / 2) / p))                 # round(1 / f)
      sg=$(((100 * STRIDE + p / 2) / p))        # round(STRIDE / f)
      e=$EPOCHS
      ((TABLE2_SAME_STEPS)) && e=$(((EPOCHS * 100 + p / 2) / p))  # as many gradient steps as at 100%
      if ((p == 100)); then
        personal_inter "$s"
      else
        personal_inter "$s" "$sp" "inter_p${p}_e$e" "$OUT/table2" "$e"
      fi
      record "$s" "column=inter percent=$p stride=$sp epochs=$e" "$JSON"
      if ((p == 100)); then
        generic_cal "$s"
      else
        generic_cal "$s" "$sg" "cal_p${p}_e$e" "$OUT/table2" "$e"
      fi
      record "$s" "column=cal percent=$p stride=$sg epochs=$e" "$JSON"
    done
  done
  finish_experiment table2 "TABLE2_SUBJECTS=$TABLE2_SUBJECTS TABLE2_FRACTIONS='$TABLE2_FRACTIONS' TABLE2_SAME_STEPS=$TABLE2_SAME_STEPS"
}

# Glove II (the corpus' glove 1: each subject's two sessions with it, each a fresh donning). The paper
# tests on one Glove II session; here session 1, after fine-tuning or training on session 0 (5 min).
run_table3() {
  begin_experiment table3
  local dir=$OUT/table3 s m
  local subjects
  subjects=$(check_subjects TABLE3_SUBJECTS "$TABLE3_SUBJECTS")
  for s in $subjects; do
    generic_cal_model "$s"  # Table 1's (4): the other subjects, glove I only
    JSON=$dir/s${s}_glove1.json
    eval_json "$JSON" "s$s glove II, generic (glove I)" --model "$MODEL" --data "$CORPUS" --subjects "$s" --gloves 1 --sessions 1 \
      --calibration-mode onthefly
    record "$s" "column=glove1" "$JSON"
    m=$dir/s${s}_tuned.safetensors
    train_model "$m" "s$s glove II, fine-tuned" finetune --model "$MODEL" --data "$CORPUS" --subjects "$s" --gloves 1 --sessions 0 \
      --epochs "$FINETUNE_EPOCHS" --seed "$SEED"
    JSON=$dir/s${s}_tuned.json
    eval_json "$JSON" "s$s glove II, fine-tuned" --model "$m" --data "$CORPUS" --subjects "$s" --gloves 1 --sessions 1 --calibration-mode onthefly
    record "$s" "column=tuned" "$JSON"
    m=$dir/s${s}_personal.safetensors
    train_model "$m" "s$s glove II, personalised" train --data "$CORPUS" --architecture "unet:$WIDTH" --subjects "$s" --gloves 1 --sessions 0 \
      --calibration-mode onthefly --batch 256 --epochs "$EPOCHS" --seed "$SEED"
    JSON=$dir/s${s}_personal.json
    eval_json "$JSON" "s$s glove II, personalised" --model "$m" --data "$CORPUS" --subjects "$s" --gloves 1 --sessions 1 --calibration-mode onthefly
    record "$s" "column=personal" "$JSON"
  done
  finish_experiment table3 "TABLE3_SUBJECTS=$TABLE3_SUBJECTS"
}

run_table45() {
  begin_experiment table45
  local dir=$OUT/table45 s w h size arch m tag opt=()
  [[ $FCN_OPTIMIZER == sgd ]] && opt=(--optimizer sgd)
  local subjects
  subjects=$(check_subjects TABLE45_SUBJECTS "$TABLE45_SUBJECTS")
  for s in $subjects; do
    size=0
    for w in $TABLE45_UNET_WIDTHS; do
      size=$((size + 1))
      h=$("$PY" "$REPORT" fcn-width --params "$("$PY" "$REPORT" unet-params --width "$w")")
      for arch in "unet:$w" "fcn:$h"; do
        local name=${arch/:/} extra=()
        if [[ $arch == fcn:* ]]; then name+=_$FCN_OPTIMIZER; extra=("${opt[@]}"); fi
        # personalised (2): sessions 0-3 -> 4
        m=$dir/s${s}_inter_$name.safetensors
        train_model "$m" "s$s (2) $name" train --data "$CORPUS" --architecture "$arch" --subjects "$s" --gloves 0 --sessions 0-3 \
          --calibration-mode onthefly --batch 256 --epochs "$EPOCHS" --seed "$SEED" "${extra[@]}"
        eval_json "${m%.safetensors}.json" "s$s (2) $name" --model "$m" --data "$CORPUS" --subjects "$s" --gloves 0 --sessions 4 --calibration-mode onthefly
        record "$s" "column=inter arch=${arch%%:*} width=${arch#*:} size=$size" "${m%.safetensors}.json"
        # generic (4): other subjects, on-the-fly calibration -> all sessions of s
        m=$dir/s${s}_cal_$name.safetensors
        train_model "$m" "s$s (4) $name" train --data "$CORPUS" --architecture "$arch" --exclude-subjects "$s" --gloves 0 \
          --stride "$STRIDE" --calibration-mode onthefly --batch 1024 --epochs "$EPOCHS" --seed "$SEED" "${extra[@]}"
        eval_json "${m%.safetensors}.json" "s$s (4) $name" --model "$m" --data "$CORPUS" --subjects "$s" --gloves 0 --calibration-mode onthefly
        record "$s" "column=cal arch=${arch%%:*} width=${arch#*:} size=$size" "${m%.safetensors}.json"
      done
      # The paper's other networks (and, to compare the trainers, its U-Net) with PyTorch, of the U-Net's size
      local params n
      params=$("$PY" "$REPORT" unet-params --width "$w")
      for n in $TABLE45_TORCH; do
        m=$dir/s${s}_inter_torch_${n}_$params.json
        torch_json "$m" "s$s (2) $n" --data "$CORPUS" --model "$n@$params" --subjects "$s" --gloves 0 --sessions 0-3 \
          --eval-subjects "$s" --eval-sessions 4 --batch 256 --epochs "$EPOCHS" --seed "$SEED"
        record "$s" "column=inter arch=$n trainer=pytorch size=$size" "$m"
        m=$dir/s${s}_cal_torch_${n}_$params.json
        torch_json "$m" "s$s (4) $n" --data "$CORPUS" --model "$n@$params" --exclude-subjects "$s" --gloves 0 \
          --stride "$STRIDE" --eval-subjects "$s" --batch 1024 --epochs "$EPOCHS" --seed "$SEED"
        record "$s" "column=cal arch=$n trainer=pytorch size=$size" "$m"
      done
    done
    m=$dir/s${s}_inter_linear.safetensors
    train_model "$m" "s$s (2) linear" train --data "$CORPUS" --architecture linear --subjects "$s" --gloves 0 --sessions 0-3 --calibration-mode onthefly
    eval_json "${m%.safetensors}.json" "s$s (2) linear" --model "$m" --data "$CORPUS" --subjects "$s" --gloves 0 --sessions 4 --calibration-mode onthefly
    record "$s" "column=inter arch=linear" "${m%.safetensors}.json"
    m=$dir/s${s}_cal_linear.safetensors
    train_model "$m" "s$s (4) linear" train --data "$CORPUS" --architecture linear --exclude-subjects "$s" --gloves 0 --stride "$STRIDE" --calibration-mode onthefly
    eval_json "${m%.safetensors}.json" "s$s (4) linear" --model "$m" --data "$CORPUS" --subjects "$s" --gloves 0 --calibration-mode onthefly
    record "$s" "column=cal arch=linear" "${m%.safetensors}.json"
  done
  finish_experiment table45 "TABLE45_SUBJECTS=$TABLE45_SUBJECTS TABLE45_UNET_WIDTHS='$TABLE45_UNET_WIDTHS'${TABLE45_TORCH:+ TABLE45_TORCH='$TABLE45_TORCH'} FCN_OPTIMIZER=$FCN_OPTIMIZER"
}

run_fig12() {
  begin_experiment fig12
  local dir=$OUT/fig12 s m
  local data14=$dir/corpus_main14.safetensors glove14=$dir/main14.glove.json
  local cmd=("$PY" "$REPORT" glove14 --data "$CORPUS" --data-out "$data14" --glove-out "$glove14")
  if [[ ! -s $data14 || ! -s $glove14 ]]; then
    log "$(quote "${cmd[@]}")"
    say "cutting the 14-cell glove out of the corpus"
    "${cmd[@]}" >&2 || die "making the 14-cell dataset failed"
  fi
  local subjects
  subjects=$(check_subjects FIG12_SUBJECTS "$FIG12_SUBJECTS")
  for s in $subjects; do
    generic_cal "$s"
    record "$s" "cells=44" "$JSON"
    JOB_CMDS="$(show "${cmd[@]}") ; "
    m=$dir/s${s}_cal_main14.safetensors
    train_model "$m" "s$s (4) 14 cells" train --data "$data14" --glove "$glove14" --architecture "unet:$WIDTH" --exclude-subjects "$s" \
      --gloves 0 --stride "$STRIDE" --calibration-mode onthefly --batch 1024 --epochs "$EPOCHS" --seed "$SEED"
    eval_json "${m%.safetensors}.json" "s$s (4) 14 cells" --model "$m" --data "$data14" --subjects "$s" --gloves 0 --calibration-mode onthefly
    record "$s" "cells=14" "${m%.safetensors}.json"
  done
  finish_experiment fig12 "FIG12_SUBJECTS=$FIG12_SUBJECTS"
}

run_fig14() {
  begin_experiment fig14
  local s
  local subjects
  subjects=$(check_subjects FIG14_SUBJECTS "$FIG14_SUBJECTS")
  for s in $subjects; do
    generic_cal "$s"; record "$s" "column=cal" "$JSON"
    personal_inter "$s"; record "$s" "column=inter" "$JSON"
    generic_nocal "$s"; record "$s" "column=nocal" "$JSON"
  done
  finish_experiment fig14 "FIG14_SUBJECTS=$FIG14_SUBJECTS" "$OUT/fig14_cumulative.svg"
}

case "$EXPERIMENT" in
  all)
    for e in table1 fig14 table2 table3 table45 fig12; do "run_$e"; done
    cat "$OUT"/{table1,table2,table3,table45,fig12,fig14}.md >"$OUT/all.md"
    echo "run.sh: all experiments done; the sections are in $(rel "$OUT")/all.md" >&2 ;;
  *) "run_$EXPERIMENT" ;;
esac
