#!/usr/bin/env bash
# Thirty-ninth session (runs/lookalike39/README.md, "`--model full`"): the look-alike treatment at
# full resolution (346x260, 10 ms steps), shorter for time: the full-resolution ANN-2D teacher
# (runs/arch/ann-d6-step10-long/teacher-step4000) fine-tuned STEPS_T (400) steps on 60 % rooms /
# 40 % look-alike rooms, then `full`'s weights before calibration (runs/skip37/control/best.safetensors)
# STEPS_S (400) steps under it with `full`'s recipe (runs/drop29/train.sh control), two threads.
#   [STEPS_T=N] [TEACHER_OUT=DIR] runs/lookalike39/full.sh teacher
#   [STEPS_S=N] [TAG=T] [TEACHER_MODEL=M] runs/lookalike39/full.sh student   # -> full/la[-T]/control; M: the committed 1,600-step
#   teacher by default; ROOMS=NAME: data/NAME for the rooms (mod3-train16 by default); this session's 400 + 400 run used runs/lookalike39/full/teacher/val-step400 (not kept)
set -euo pipefail
cd "$(dirname "$0")/../.."
TRAIN="[{path=\"data/${ROOMS:-mod3-train16}\",split=\"all\",weight=0.6},{path=\"data/lookalikes-train\",split=\"all\",weight=0.4}]"
case "${1:?teacher or student}" in
  teacher)
    exec build/spikems train --config runs/arch/ann-d6-step10-long/config.json -q --threads 2 \
      --set 'model.init="runs/arch/ann-d6-step10-long/teacher-step4000.safetensors"' \
      --set "data.train=$TRAIN" --set 'data.val=[{path="data/mod2-val",split="all"}]' \
      --set 'data.val_static=[{path="data/lookalikesstatic-val"}]' \
      --set optim.lr=0.0003 --set optim.warmup_steps=50 --set optim.ema_decay=0.995 \
      --set run.val_every=200 --set run.keep_val_models=true --steps ${STEPS_T:-400} \
      --time-limit 30min --out "${TEACHER_OUT:-runs/lookalike39/full/teacher}" "${@:2}" ;;
  student)
    INIT=runs/skip37/control/best.safetensors STEPS=${STEPS_S:-400} ROOT=runs/lookalike39/full/la${TAG:+-$TAG} \
      TIME_LIMIT=${TIME_LIMIT:-40min} exec runs/drop29/train.sh control \
      --set 'model.srm_onset="same_step"' --set sample.step_ms=10 --set run.threads=2 \
      --set "data.train=$TRAIN" --set 'data.val=[{path="data/mod2-val",split="all"}]' \
      --set 'data.val_static=[{path="data/posterflat-sim601"},{path="data/lookalikesstatic-val"}]' \
      --set "loss.teacher=\"${TEACHER_MODEL:-runs/lookalike39/full/teacher1600/val-step1600.safetensors}\"" "${@:2}" ;;
  *) echo "unknown stage $1 (teacher or student)" >&2; exit 1 ;;
esac
