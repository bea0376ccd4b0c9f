#!/usr/bin/env bash
# Scores a candidate of the thirtieth session's runs (runs/long30/README.md) as the default is
# scored: validation rooms (mod5-val, first 1 s) at output factors FACTORS, the 48 held-out rooms
# (seeds 6001, 6002) at FACTOR, the real static scenes, and the runtime's work on one held-out
# room (spike counts and SynOps are exact; the real-time factor depends on the machine's load).
# Usage: [EVAL_OUT=out/eval30] runs/long30/eval.sh NAME MODEL [FACTOR] [FACTORS]
set -euo pipefail
SPIKEMS=${SPIKEMS:-build/spikems}
N=${1:?name} M=${2:?model} F=${3:-1.6} FS=${4:-1.5,1.6,1.7}
O=${EVAL_OUT:-out/eval30}/$N
mkdir -p "$O-segment"
"$SPIKEMS" eval --model "$M" --output-thresholds "$FS" --output-gates 10 --data data/mod5-val \
  --split all --windows 20,100 --max-seconds 1 --threads 1 --quiet --out "$O-val"
"$SPIKEMS" eval --model "$M" --output-thresholds "$F" --output-gates 10 --data data/mod-heldout6001 \
  --data data/mod-heldout6002 --split all --windows 20,100 --threads 1 --quiet --out "$O-rooms"
OUT=$O-real SPIKEMS_BIN=$SPIKEMS scripts/real_static "$M" /work/realdata "$F"
"$SPIKEMS" segment --model "$M" --output-threshold "$F" --stats --threads 1 --quiet \
  --input data/mod2-heldout/seq_0002.h5 --out "$O-segment/labels.txt" > "$O-segment/stats.txt" 2>&1
