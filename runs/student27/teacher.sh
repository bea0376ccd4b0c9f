#!/usr/bin/env bash
# The twenty-seventh session's teacher pair (runs/student27/README.md): the CPU students'
# teacher (runs/sizes24/teacher-static-sizes-step1000.safetensors) fine-tuned further with its
# own recipe (runs/sizes24/train.sh static-sizes: rooms 0.16 + 0.64, static scenes 0.2), in
# `tsparse` with half of the static share given to the sparse static rooms; `tcontrol` as it was.
# Usage: runs/student27/teacher.sh tcontrol|tsparse [MORE train ARGS]
set -euo pipefail
SPIKEMS=${SPIKEMS:-build/spikems}
ROOMS='{path="data/mod2-train",split="train",weight=0.16},{path="data/mod3-train",split="all",weight=0.64}'
case "${1:?tcontrol or tsparse}" in
  tcontrol) STATIC='{path="data/modstaticflat-sizes-train103",split="all",weight=0.1},{path="data/posterflat-sizes-train107",split="all",weight=0.1}' ;;
  tsparse) STATIC='{path="data/modstaticflat-sizes-train103",split="all",weight=0.05},{path="data/posterflat-sizes-train107",split="all",weight=0.05},{path="data/modstaticsparse-sizes-train131",split="all",weight=0.1}' ;;
  *) echo "unknown run $1 (tcontrol or tsparse)" >&2; exit 1 ;;
esac
exec "$SPIKEMS" train --config configs/train/ann2d.toml --steps 750 --threads 1 -q \
  --set 'model.channels=[16,32,64,64,64,64]' --set sample.crop=0 --set sample.step_ms=10 \
  --set model.skips=true --set 'model.init="runs/sizes24/teacher-static-sizes-step1000.safetensors"' \
  --set optim.lr=0.0003 --set run.val_every=250 --set run.keep_val_models=true \
  --set 'data.val_static=[{path="data/modstaticsparse-sizes-val5015"},{path="data/posterflat-sim601"}]' \
  --time-limit "${TIME_LIMIT:-18min}" --out "runs/student27/$1" --set "data.train=[$ROOMS,$STATIC]" "${@:2}"
