#!/usr/bin/env bash
# The twenty-seventh session's paired fine-tunes of the CPU student (runs/student27/README.md):
# both start from runs/student26/t2's averaged model at step 2,875 with a fresh optimizer and a short
# cosine schedule (lr 3e-4 -> 2e-5 over 500 steps, weight average 0.995) and keep static scenes
# at a fifth of the samples. `control` keeps t2's data mix; `sparse` gives half of the static
# share to rooms without objects whose walls are mostly flat and which hold 3-8 static
# look-alikes (modstatic-sparse-sizes.toml): event-dense islands that do not move.
# Usage: runs/student27/train.sh control|sparse [MORE train ARGS]
# INIT, LR, STEPS and ROOT change the start model, learning rate, length and output folder
# (runs/student28/train.sh uses them); their defaults are what this session ran.
set -euo pipefail
INIT=${INIT:-runs/student26/t2/val-step2875.safetensors}
LR=${LR:-0.0003}
STEPS=${STEPS:-500}
ROOT=${ROOT:-runs/student27}
SPIKEMS=${SPIKEMS:-build/spikems}
T=runs/sizes24/teacher-static-sizes-step1000.safetensors
ROOMS='{path="data/mod2-train",split="train",weight=0.12},{path="data/mod3-train",split="all",weight=0.48},{path="data/modfine-train121",split="all",weight=0.2}'
STATIC_OLD='data/modstaticflat-sizes-train103 data/posterflat-sizes-train107 data/modstaticfine-sizes-train123 data/posterfine-sizes-train127'
case "${1:?control or sparse}" in
  control) W=0.05; EXTRA='' ;;
  sparse) W=0.025; EXTRA=',{path="data/modstaticsparse-sizes-train131",split="all",weight=0.1}' ;;
  *) echo "unknown run $1 (control or sparse)" >&2; exit 1 ;;
esac
DATA="[$ROOMS"
for d in $STATIC_OLD; do DATA+=",{path=\"$d\",split=\"all\",weight=$W}"; done
DATA+="$EXTRA]"
exec "$SPIKEMS" train --config configs/train/hybrid.toml --threads 1 -q \
  --set "model.init=\"$INIT\"" --set 'model.init_ann=""' \
  --set "loss.teacher=\"$T\"" --set "data.train=$DATA" \
  --set 'data.val_static=[{path="data/modstaticsparse-sizes-val5015"},{path="data/posterflat-sim601"}]' \
  --set optim.lr=$LR --set optim.warmup_steps=20 --set optim.ema_decay=0.995 \
  --set run.val_every=100 --set run.keep_val_models=true --set run.val_full_s=0.5 \
  --steps "$STEPS" --time-limit "${TIME_LIMIT:-80min}" --out "$ROOT/$1" "${@:2}"
