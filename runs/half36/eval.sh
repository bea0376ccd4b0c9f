#!/usr/bin/env bash
# A half-resolution model scored on the full-resolution data through `--downsample auto`
# (thirty-sixth session, runs/half36/README.md): runs/onset33/eval.sh with the model's training
# grid recorded at calibration (--train-grid 173x130, so every later command downsamples the
# 346x260 rooms 2x and keeps the 240x180 poster as it is), then the share of the real poster's
# events that `spikems segment` calls moving.
# Usage: [EVAL_OUT=out/eval36] [FACTORS=...] [CAL_MORE="--data data/mod2-val"] runs/half36/eval.sh NAME MODEL
set -euo pipefail
cd "$(dirname "$0")/../.."
SPIKEMS=${SPIKEMS:-build/spikems}
O=${EVAL_OUT:-out/eval36}/${1:?name}
EVAL_OUT=${EVAL_OUT:-out/eval36} FACTORS=${FACTORS:-1.2,1.4,1.6,1.8,2.0,2.2} \
  CAL_ARGS="--train-grid 173x130 ${CAL_MORE:-}" runs/onset33/eval.sh "$1" "${2:?model}"
"$SPIKEMS" segment --model "$O/calibrated.safetensors" --quiet \
  --input ../shared/data/formats/poster_translation.npz --out "$O/poster-labels.txt"
awk '!/^#/ {n++; m += $5} END {printf "segment: %d of %d events moving (%.2f %%)\n", m, n, 100*m/n}' \
  "$O/poster-labels.txt" > "$O/poster-segment.txt"
rm -f "$O/poster-labels.txt"
