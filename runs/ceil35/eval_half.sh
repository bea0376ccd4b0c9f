#!/usr/bin/env bash
# runs/onset33/eval.sh at half resolution: calibrated on data/mod5-val1s-ds2, the 48 held-out
# rooms of seeds 6001/6002 downsampled 2x (data/mod-heldout600[12]-ds2), the real poster
# downsampled 2x, and the runtime's work on data/mod2-heldout/seq_0002.h5 downsampled 2x.
# Usage: [EVAL_OUT=out/eval35] [FACTORS=...] runs/ceil35/eval_half.sh NAME MODEL
set -euo pipefail
SPIKEMS=${SPIKEMS:-build/spikems}
N=${1:?name} M=${2:?model}
O=${EVAL_OUT:-out/eval35}/$N
mkdir -p "$O"
"$SPIKEMS" calibrate --model "$M" --data data/mod5-val1s-ds2 --split all \
  --factors "${FACTORS:-1.2,1.4,1.6,1.8,2.0,2.2}" --threads 1 --quiet --out "$O/calibrated.safetensors" \
  > "$O/calibrate.txt" 2>&1
C=$O/calibrated.safetensors
R=(--data data/mod-heldout6001-ds2 --data data/mod-heldout6002-ds2 --split all --windows 20,100 --threads 1 --quiet)
"$SPIKEMS" eval --model "$C" "${R[@]}" --out "$O/rooms"
"$SPIKEMS" eval --model "$C" "${R[@]}" --min-moving-share 50 --group-windows 8 --out "$O/authors"
P=$O/poster_ds2.h5
"$SPIKEMS" convert ../shared/data/formats/poster_translation.npz "$P" --downsample 2 -q
"$SPIKEMS" eval --model "$C" --data "$P" --static-scene --split all --windows 10,20 --threads 1 --quiet --out "$O/poster"
S=$O/seq2_ds2.h5
"$SPIKEMS" convert data/mod2-heldout/seq_0002.h5 "$S" --downsample 2 -q
"$SPIKEMS" segment --model "$C" --stats --threads 1 --quiet --input "$S" --out "$O/labels.txt" > "$O/segment-stats.txt" 2>&1
rm -f "$O/labels.txt" "$P" "$S"
