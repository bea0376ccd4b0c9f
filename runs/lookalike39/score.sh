#!/usr/bin/env bash
# Scores a calibrated half-resolution model as the default is scored (runs/lookalike39/README.md):
# the 48 held-out rooms (seeds 6001, 6002; runs/onset33/README.md) at 20 and 100 ms over all
# windows and under the authors' protocol, the real poster through `segment`, and the real static
# scenes of scripts/real_static (ECD slices in $ECD, docs/evaluation.md) at 10 and 20 ms.
# Usage: [OUT=out/eval39] [ECD=/tmp/ecd] runs/lookalike39/score.sh NAME CALIBRATED_MODEL
set -euo pipefail
cd "$(dirname "$0")/../.."
S=${SPIKEMS:-build/spikems}
N=${1:?name} M=${2:?calibrated model}
O=${OUT:-out/eval39}/$N
mkdir -p "$O"
R=(--data data/mod-heldout6001 --data data/mod-heldout6002 --split all --windows 20,100 --threads 1 --quiet)
"$S" eval --model "$M" "${R[@]}" --out "$O/rooms"
"$S" eval --model "$M" "${R[@]}" --min-moving-share 50 --group-windows 8 --out "$O/authors"
"$S" segment --model "$M" --quiet --input ../shared/data/formats/poster_translation.npz \
  --out "$O/poster-labels.txt"
awk '!/^#/ {n++; m += $5} END {printf "segment: %d of %d events moving (%.3f %%)\n", m, n, 100*m/n}' \
  "$O/poster-labels.txt" > "$O/poster-segment.txt"
rm -f "$O/poster-labels.txt"
OUT=$O/real scripts/real_static "$M" "${ECD:-/tmp/ecd}"
