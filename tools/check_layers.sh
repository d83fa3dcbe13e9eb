#!/usr/bin/env bash
# Fails when a header in include/glovepose includes a folder above its own layer. The order, lowest
# first (docs/architecture.md, "Layers"): the base files config.hpp and status.hpp; core/ (the one
# random generator); hand/ (the hand model, the vocabulary of poses); io/ (the container, JSON,
# half floats, recordings); sensor/; device/ (the wire protocol of a glove on a link); filter/; nn/ (knows nothing of gloves or training); grid/;
# calibration/; model/ (the model file's metadata); train/; sim/; and the composition files at the
# top (estimator.hpp, pose_model.hpp, ..., and detail/, their members' definitions). A header may
# include its own folder and anything below it.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/include/glovepose"
order=(base core hand io sensor device filter nn grid calibration model train sim top)

layer_of() {  # path relative to include/glovepose -> layer index
  local rel="$1" name
  case "$rel" in
    config.hpp | status.hpp) name=base ;;
    detail/*) name=top ;;  # the composition's member definitions, beside the fronts that include them
    */*) name="${rel%%/*}" ;;
    *) name=top ;;
  esac
  for i in "${!order[@]}"; do
    if [[ "${order[$i]}" == "$name" ]]; then echo "$i"; return; fi
  done
  echo "check_layers: $rel is in folder '$name', which has no layer; add it to the order" >&2
  echo 99
}

status=0
while IFS= read -r header; do
  rel="${header#"$root"/}"
  own=$(layer_of "$rel")
  [[ "$own" == 99 ]] && status=1
  dir="$(dirname "$header")"
  while IFS= read -r included; do
    target="$(realpath -m "$dir/$included")"
    [[ "$target" == "$root"/* ]] || continue
    target_rel="${target#"$root"/}"
    theirs=$(layer_of "$target_rel")
    if (( theirs > own )); then
      echo "check_layers: $rel (layer ${order[$own]}) includes $target_rel (layer ${order[$theirs]}), which is above it" >&2
      status=1
    fi
  done < <(sed -n 's/^[[:space:]]*#[[:space:]]*include[[:space:]]*"\([^"]*\)".*/\1/p' "$header")
done < <(find "$root" -name '*.hpp' | sort)
if (( status == 0 )); then echo "check_layers: every include in include/glovepose points down (${order[*]})"; fi
exit "$status"
