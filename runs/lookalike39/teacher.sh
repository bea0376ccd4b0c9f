#!/usr/bin/env bash
# Thirty-ninth session (runs/lookalike39/README.md): the look-alike teacher of the thirty-eighth
# session (runs/sparse38/teacher-la: the half-resolution ANN-2D fine-tuned on 60 % rooms, 40 %
# rooms of static look-alikes; its share of static look-alike rooms called moving still falling
# at step 1,000) trained longer: from its step 400 (best.safetensors), STEPS more (1,600), the
# same mix and recipe (lr 3e-4, warm-up 50, weight average 0.995), two threads.
#   runs/lookalike39/teacher.sh        # -> runs/lookalike39/teacher/val-step*.safetensors
# STATIC=1: 50 % rooms, 35 % look-alike rooms, 15 % look-alike rooms without moving objects
# (data/lookalikesstatic-train-ds2: every event background), into runs/lookalike39/teacher-static.
# ROOMS=NAME (data/NAME-ds2 for the rooms), INIT=MODEL, OUT=DIR, THREADS=N: the fortieth session's
# teacher on 96 rooms (runs/rooms40/README.md).
# Data: runs/sparse38/data.sh (mod3-train16, lookalikes-train, mod2-val, lookalikesstatic-val; -ds2).
set -euo pipefail
cd "$(dirname "$0")/../.."
R="data/${ROOMS:-mod3-train16}-ds2"
TRAIN="[{path=\"$R\",split=\"all\",weight=0.6},{path=\"data/lookalikes-train-ds2\",split=\"all\",weight=0.4}]"
OUT=${OUT:-runs/lookalike39/teacher}
if [ -n "${STATIC:-}" ]; then
  TRAIN='[{path="data/mod3-train16-ds2",split="all",weight=0.5},{path="data/lookalikes-train-ds2",split="all",weight=0.35},{path="data/lookalikesstatic-train-ds2",split="all",weight=0.15}]'
  OUT=runs/lookalike39/teacher-static
fi
exec build/spikems train --config runs/arch/ann-d6-step10-long/config.json -q --threads ${THREADS:-2} \
  --set "model.init=\"${INIT:-runs/sparse38/teacher-la/best.safetensors}\"" \
  --set "data.train=$TRAIN" \
  --set 'data.val=[{path="data/mod2-val-ds2",split="all"}]' \
  --set 'data.val_static=[{path="data/lookalikesstatic-val-ds2"}]' \
  --set optim.lr=0.0003 --set optim.warmup_steps=50 --set optim.ema_decay=0.995 \
  --set run.val_every=400 --set run.keep_val_models=true --steps ${STEPS:-1600} --time-limit 40min \
  --out "$OUT" "$@"
