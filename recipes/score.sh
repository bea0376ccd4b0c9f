#!/usr/bin/env bash
# Scores one model as the model card's evaluation does, into the folder OUT:
#   rooms, authors          the 48 held-out rooms of seeds 6001/6002 (24 x 2 s each), every
#                           window (IoU, detection, event precision / recall at 20 and 100 ms),
#                           and the SpikeMS authors' protocol (only windows with at least half of
#                           their events moving, IoU per batch of 8 windows)
#   rooms7k, authors7k      the same on the 48 rooms of seeds 7001/7002 (24 x 1 s each)
#   poster-segment.txt      the real static poster of ../shared (every event background) through
#                           `spikems segment`: the share of its events called moving
#   real                    with ECD=DIR: that poster and the Event Camera Dataset slices in DIR
#                           (scripts/real_static, docs/evaluation.md "Real static scenes")
#   summary.txt             every figure above pooled over its data sets (recipes/combine.py)
# The rooms are scored on the grid the model was trained on (--downsample auto).
#
# Usage: [ECD=DIR] [DATA=data] [THREADS=1] recipes/score.sh MODEL OUT
#   MODEL: a model file, or a shipped model's name (default, fast, fine, full)
#   data: recipes/data.sh (the held-out sets only: see its ONLY)
# Environment: SPIKEMS (default build/spikems, else spikems on the PATH).
set -euo pipefail
# shellcheck source-path=SCRIPTDIR source=common/paths.sh
. "$(dirname "$0")/common/paths.sh"
usage() { usage_of "$0" "$1"; }
case "${1:-}" in -h | --help) usage 0 ;; esac
[ $# -eq 2 ] || usage 2
S=$(find_spikems)
M=$1
if [ ! -f "$M" ] && [ -f "$REPO/models/spikems-$M.safetensors" ]; then M=$REPO/models/spikems-$M.safetensors; fi
[ -f "$M" ] || { echo "score.sh: no model $1" >&2; exit 1; }
M=$(cd "$(dirname "$M")" && pwd)/$(basename "$M")
D=${DATA:-data}
for s in mod-heldout6001 mod-heldout6002 mod-heldout7001 mod-heldout7002; do
  [ -f "$D/$s/manifest.json" ] || { echo "score.sh: no $D/$s: run recipes/data.sh" >&2; exit 1; }
done
mkdir -p "$2"
O=$(cd "$2" && pwd)
E=(--split all --windows "20,100" --threads "${THREADS:-1}" --quiet)
A=(--min-moving-share 50 --group-windows 8)
R6=(--data "$D/mod-heldout6001" --data "$D/mod-heldout6002")
R7=(--data "$D/mod-heldout7001" --data "$D/mod-heldout7002")
"$S" eval --model "$M" "${R6[@]}" "${E[@]}" --out "$O/rooms" >/dev/null
"$S" eval --model "$M" "${R6[@]}" "${E[@]}" "${A[@]}" --out "$O/authors" >/dev/null
"$S" eval --model "$M" "${R7[@]}" "${E[@]}" --out "$O/rooms7k" >/dev/null
"$S" eval --model "$M" "${R7[@]}" "${E[@]}" "${A[@]}" --out "$O/authors7k" >/dev/null
POSTER=$REPO/../shared/data/formats/poster_translation.npz
if [ -f "$POSTER" ]; then
  "$S" segment --model "$M" --quiet --input "$POSTER" --labels "$O/poster-labels.txt"
  awk '{n++; m += ($1 != 0)} END {printf "segment: %d of %d events moving (%.3f %%)\n", m, n, 100*m/n}' \
    "$O/poster-labels.txt" > "$O/poster-segment.txt"
  rm -f "$O/poster-labels.txt"
else
  echo "score.sh: $POSTER absent: the real poster skipped" >&2
fi
RESULTS=("$O"/rooms/results.json "$O"/authors/results.json "$O"/rooms7k/results.json "$O"/authors7k/results.json)
if [ -n "${ECD:-}" ]; then
  OUT=$O/real SPIKEMS_BIN=$S "$REPO/scripts/real_static" "$M" "$(cd "$ECD" && pwd)" >/dev/null
  RESULTS+=("$O/real/results.json")
fi
{ python3 "$RECIPES/combine.py" "${RESULTS[@]}"; cat "$O/poster-segment.txt" 2>/dev/null || true; } |
  sed "s|$O/||" | tee "$O/summary.txt"
