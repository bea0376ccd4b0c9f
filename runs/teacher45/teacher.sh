#!/usr/bin/env bash
# Forty-fifth session (runs/teacher45/README.md): can a stronger half-resolution ANN-2D teacher
# be trained on the CPU within a session? The six-level ANN-2D at 10 ms frames
# (runs/arch/ann-d6-step10-long's config) WITH U-Net skips, from scratch, on 96 rooms
# (data/mod7-train96-ds2, 60 %) and the 24 look-alike rooms (40 %), STEPS (8000) steps of batch 8,
# lr 1e-3 cosine. The teacher the shipped students learnt from (runs/lookalike39/teacher: no
# skips, 16 rooms) is the comparison: validation full-frame IoU on mod2-val-ds2 37.0 %.
#   [STEPS=N] [THREADS=2] [OUT=runs/teacher45/skips96] runs/teacher45/teacher.sh [MORE train ARGS]
# Data: ONLY="mod2-val lookalikes-train mod7-train96 lookalikesstatic-val" runs/rooms41/data.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
exec build/spikems train --config runs/arch/ann-d6-step10-long/config.json -q --threads ${THREADS:-2} \
  --set model.skips=true \
  --set 'data.train=[{path="data/mod7-train96-ds2",split="all",weight=0.6},{path="data/lookalikes-train-ds2",split="all",weight=0.4}]' \
  --set 'data.val=[{path="data/mod2-val-ds2",split="all"}]' \
  --set 'data.val_static=[{path="data/lookalikesstatic-val-ds2"}]' \
  --set optim.ema_decay=0.995 --set run.val_every=1000 --set run.keep_val_models=true \
  --steps ${STEPS:-8000} --time-limit ${TIME_LIMIT:-70min} --out "${OUT:-runs/teacher45/skips96}" "$@"
