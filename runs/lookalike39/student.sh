#!/usr/bin/env bash
# Thirty-ninth session (runs/lookalike39/README.md): the SNN student of runs/sparse38/train.sh
# lookalikes (the default's weights before calibration, runs/skip37/fast5/control/best.safetensors;
# lr 2e-4 cosine, batch 4, weight average 0.995) with the longer look-alike teacher (teacher.sh),
# STEPS (400) steps, THREADS (1) threads. Runs:
#   la:     60 % rooms, 40 % look-alike rooms (as runs/sparse38's students)
#   static: 50 % rooms, 35 % look-alike rooms, 15 % the same rooms WITHOUT moving objects
#           (data/lookalikesstatic-train, seed 3913): every event background, a direct
#           false-positive signal from the mask (random crops: nothing to centre on)
# Its static check is the flat poster and the static look-alike rooms of seed 3812 (the set the
# calibration's static budget uses; never trained on).
#   [BASE=fast] [STEPS=N] [TAG=T] [TEACHER_MODEL=M] [ROOMS=NAME] runs/lookalike39/student.sh la|static [MORE train ARGS]   # -> runs/lookalike39/[fast-]RUN[-T]/control
# ROOMS: the rooms' data set(s) (data/NAME-ds2; mod3-train16 by default, 16 rooms of 1.5 s).
set -euo pipefail
cd "$(dirname "$0")/../.."
# Several names (ROOMS="a b"): the rooms' share split evenly between the sets.
read -ra RS <<< "${ROOMS:-mod3-train16}"
rooms() { local w; w=$(awk -v s="$1" -v n=${#RS[@]} 'BEGIN { printf "%g", s / n }')
          for r in "${RS[@]}"; do printf '{path="data/%s-ds2",split="all",weight=%s},' "$r" "$w"; done; }
L='{path="data/lookalikes-train-ds2",split="all",weight'
case "${1:?la or static}" in
  la) TRAIN="[$(rooms 0.6)$L=0.4}]" ;;
  static) TRAIN="[$(rooms 0.5)$L=0.35},{path=\"data/lookalikesstatic-train-ds2\",split=\"all\",weight=0.15}]" ;;
  *) echo "unknown run $1 (la or static)" >&2; exit 1 ;;
esac
# BASE=fast: the same for `--model fast` (its weights before calibration, 10 ms steps).
INIT=runs/skip37/fast5/control/best.safetensors STEP_MS=5
if [ "${BASE:-default}" = fast ]; then INIT=runs/skip37/fast/control/best.safetensors STEP_MS=10; fi
INIT=$INIT STEPS=${STEPS:-400} ROOT=runs/lookalike39/${BASE:+$BASE-}$1${TAG:+-$TAG} \
  TIME_LIMIT=${TIME_LIMIT:-60min} exec runs/drop29/train.sh control \
  --set 'model.srm_onset="same_step"' --set sample.step_ms=$STEP_MS --set run.threads=${THREADS:-1} \
  --set "data.train=$TRAIN" \
  --set 'data.val=[{path="data/mod2-val-ds2",split="all"}]' \
  --set 'data.val_static=[{path="data/posterflat-sim601-ds2"},{path="data/lookalikesstatic-val-ds2"}]' \
  --set "loss.teacher=\"${TEACHER_MODEL:-runs/lookalike39/teacher/val-step1600.safetensors}\"" "${@:2}"
