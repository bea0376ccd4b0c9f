#!/usr/bin/env bash
# Scores a thirty-third-session candidate as the default is scored (runs/onset33/README.md):
# calibrated on validation rooms (data/mod5-val1s: `spikems simulate --preset mod --sequences 24
# --duration 1s --seed 2001 --mask-period 10ms`), then the 48 held-out rooms (seeds 6001, 6002)
# at 20 and 100 ms, all windows and the authors' protocol, the real poster, and the runtime's
# work on one held-out room (spike counts and SynOps exact; the real-time factor depends on load).
# Usage: [EVAL_OUT=out/eval33] [FACTORS=1.3,1.45,1.6,1.75,1.9] [CAL_ARGS="--time-step-ms 5"] runs/onset33/eval.sh NAME MODEL
set -euo pipefail
SPIKEMS=${SPIKEMS:-build/spikems}
N=${1:?name} M=${2:?model}
O=${EVAL_OUT:-out/eval33}/$N
mkdir -p "$O"
"$SPIKEMS" calibrate --model "$M" --data data/mod5-val1s --split all \
  --factors "${FACTORS:-1.3,1.45,1.6,1.75,1.9}" ${CAL_ARGS:-} --threads 1 --quiet --out "$O/calibrated.safetensors" \
  > "$O/calibrate.txt" 2>&1
C=$O/calibrated.safetensors
R=(--data data/mod-heldout6001 --data data/mod-heldout6002 --split all --windows 20,100 --threads 1 --quiet)
"$SPIKEMS" eval --model "$C" "${R[@]}" --out "$O/rooms"
"$SPIKEMS" eval --model "$C" "${R[@]}" --min-moving-share 50 --group-windows 8 --out "$O/authors"
"$SPIKEMS" eval --model "$C" --data ../shared/data/formats/poster_translation.npz --static-scene \
  --split all --windows 10,20 --threads 1 --quiet --out "$O/poster"
"$SPIKEMS" segment --model "$C" --stats --threads 1 --quiet --input data/mod2-heldout/seq_0002.h5 \
  --out "$O/labels.txt" > "$O/segment-stats.txt" 2>&1
rm -f "$O/labels.txt"
