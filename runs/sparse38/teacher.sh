#!/usr/bin/env bash
# Thirty-eighth session (runs/sparse38/README.md): the half-resolution ANN-2D teacher
# (runs/half36/teacher-half-2500) calls 22.6 % of the static look-alike rooms' events moving and
# teaches the SNN that through distillation and feature transfer. Fine-tune it on 60 % rooms,
# 40 % look-alike rooms (its own recipe of the thirty-sixth session), then the SNN again with it:
#   runs/sparse38/teacher.sh               # -> runs/sparse38/teacher-la/best.safetensors
#   TEACHER_MODEL=runs/sparse38/teacher-la/best.safetensors runs/sparse38/train.sh lookalikes
set -euo pipefail
cd "$(dirname "$0")/../.."
exec build/spikems train --config runs/arch/ann-d6-step10-long/config.json -q --threads 2 \
  --set 'model.init="runs/half36/teacher-half-2500/best.safetensors"' \
  --set 'data.train=[{path="data/mod3-train16-ds2",split="all",weight=0.6},{path="data/lookalikes-train-ds2",split="all",weight=0.4}]' \
  --set 'data.val=[{path="data/mod2-val-ds2",split="all"}]' \
  --set 'data.val_static=[{path="data/lookalikesstatic-val-ds2"}]' \
  --set optim.lr=0.0003 --set optim.warmup_steps=50 --set optim.ema_decay=0.995 \
  --set run.val_every=200 --set run.keep_val_models=true --steps ${STEPS:-1000} --time-limit 20min \
  --out runs/sparse38/teacher-la "$@"
