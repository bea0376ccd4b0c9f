#!/usr/bin/env bash
# The twenty-ninth session's paired fine-tunes of the shipped model's weights
# (runs/drop29/README.md): the default labels fewer and fewer events moving as the event rate
# falls (the same held-out room thinned to 1/4 of its events: 20 ms IoU 52 -> 22 %; to 1/10:
# 1 %), and it was trained with event drop of at most 20 %. `drop` trains with up to 80 % of
# each sample's events dropped; `control` keeps 20 %; otherwise both are the same: from
# runs/gpu-hybrid/ft-cont (the default before calibration), its teacher and rooms, a fresh
# optimizer, lr 2e-4 cosine over STEPS, batch 4, weight average 0.995, one thread.
# Usage: runs/drop29/train.sh drop|control [MORE train ARGS]
set -euo pipefail
INIT=${INIT:-runs/gpu-hybrid/ft-cont/model.safetensors}
LR=${LR:-0.0002}
STEPS=${STEPS:-600}
ROOT=${ROOT:-runs/drop29}
SPIKEMS=${SPIKEMS:-build/spikems}
T=runs/arch/ann-d6-step10-long/teacher-step4000.safetensors
case "${1:?drop or control}" in
  drop) D=0.8 ;;
  control) D=0.2 ;;
  *) echo "unknown run $1 (drop or control)" >&2; exit 1 ;;
esac
exec "$SPIKEMS" train --config configs/train/hybrid.toml --threads 1 -q \
  --set "model.init=\"$INIT\"" --set 'model.init_ann=""' --set "loss.teacher=\"$T\"" \
  --set 'data.train=[{path="data/mod2-train",split="train",weight=0.2},{path="data/mod3-train",split="all",weight=0.8}]' \
  --set 'data.val_static=[{path="data/posterflat-sim601"}]' \
  --set sample.drop_max=$D \
  --set optim.lr=$LR --set optim.warmup_steps=20 --set optim.ema_decay=0.995 \
  --set run.val_every=100 --set run.keep_val_models=true --set run.val_full_s=0.5 \
  --steps "$STEPS" --time-limit "${TIME_LIMIT:-95min}" --out "$ROOT/$1" "${@:2}"
