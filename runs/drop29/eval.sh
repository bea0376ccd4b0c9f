#!/usr/bin/env bash
# Scores one run of the pair as the default is scored (output θ x 1.6, gate 10 ms, as shipped):
# the 48 held-out rooms, seed 6001 thinned to every 2nd / 4th event (data/thin, made by
# spikems convert + awk, docs/results.md "Twenty-ninth session"), and the real poster.
# Usage: runs/drop29/eval.sh drop|control [MODEL]
set -euo pipefail
SPIKEMS=${SPIKEMS:-build/spikems}
R=${1:?drop or control}
M=${2:-runs/drop29/$R/model.safetensors}
O=out/eval29/$R
"$SPIKEMS" eval --model "$M" --output-thresholds 1.6 --output-gates 10 --data data/mod-heldout6001 \
  --data data/mod-heldout6002 --data data/thin/h6001-k2 --data data/thin/h6001-k4 --split all \
  --windows 20,100 --threads 1 --quiet --out "$O-rooms"
"$SPIKEMS" eval --model "$M" --data ../shared/data/formats/poster_translation.npz --static-scene \
  --split all --windows 20 --output-gates 10 --output-thresholds 1.6,1.8 --threads 1 --quiet \
  --out "$O-poster"
