#!/usr/bin/env bash
# The twenty-fifth session's CPU student (runs/student25/README.md): the hybrid recipe
# (configs/train/hybrid.toml, the default model's first stage) with the twenty-fourth session's
# teacher (runs/sizes24/teacher-static-sizes-step1000.safetensors) and that teacher's data:
# the original rooms plus static scenes from two cameras as a fifth of the samples.
# Usage: runs/student25/train.sh [OUT_NAME [MORE train ARGS]]
set -euo pipefail
SPIKEMS=${SPIKEMS:-build/spikems}
T=runs/sizes24/teacher-static-sizes-step1000.safetensors
DATA='[{path="data/mod2-train",split="train",weight=0.16},{path="data/mod3-train",split="all",weight=0.64},{path="data/modstaticflat-sizes-train103",split="all",weight=0.1},{path="data/posterflat-sizes-train107",split="all",weight=0.1}]'
exec "$SPIKEMS" train --config configs/train/hybrid.toml --threads 1 -q \
  --set "model.init_ann=\"$T\"" --set "loss.teacher=\"$T\"" --set "data.train=$DATA" \
  --set 'data.val_static=[{path="data/posterflat-sim601"}]' \
  --set run.val_every=250 --set run.keep_val_models=true --time-limit "${TIME_LIMIT:-85min}" \
  --out "runs/student25/${1:-t1}" "${@:2}"
