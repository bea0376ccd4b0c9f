#!/usr/bin/env bash
# Thirty-eighth session (runs/sparse38/README.md): does training on sparse walls (mod-sparse.toml:
# a few textured islands on nearly silent walls) stop the default calling a real static scene of
# shapes on a white wall moving? Fine-tunes of the default's weights before calibration
# (runs/skip37/fast5/control/best.safetensors: half resolution, 5 ms steps), its own recipe
# (runs/skip37/train.sh fast5: the half-resolution teacher, lr 2e-4 cosine, batch 4, weight
# average 0.995), 400 steps on one thread each (THREADS=N for more), the same rooms and steps:
#   sparse:  60 % the mod rooms (data/mod3-train16-ds2), 40 % sparse-wall rooms (data/sparse-train-ds2)
#   lookalikes: 60 % the mod rooms, 40 % rooms of plain walls with 4-10 static look-alikes
#            (mod-lookalikes.toml, data/lookalikes-train-ds2): only motion tells objects apart
#   control: the mod rooms alone (what further fine-tuning does without sparse walls)
# Validation: data/mod2-val-ds2; static scenes: the simulated flat poster and sparse static rooms.
# Data: runs/sparse38/data.sh. Usage: runs/sparse38/train.sh sparse|lookalikes|control [MORE ARGS]
set -euo pipefail
cd "$(dirname "$0")/../.."
case "${1:?sparse, lookalikes or control}" in
  sparse) TRAIN='[{path="data/mod3-train16-ds2",split="all",weight=0.6},{path="data/sparse-train-ds2",split="all",weight=0.4}]' ;;
  lookalikes) TRAIN='[{path="data/mod3-train16-ds2",split="all",weight=0.6},{path="data/lookalikes-train-ds2",split="all",weight=0.4}]' ;;
  control) TRAIN='[{path="data/mod3-train16-ds2",split="all",weight=1.0}]' ;;
  *) echo "unknown run $1 (sparse, lookalikes or control)" >&2; exit 1 ;;
esac
# NOTEACHER=1: without the ANN teacher (no distillation, no feature transfer; it calls 22.6 % of
# the static look-alike rooms' events moving, the SNN 10.2 %), into runs/sparse38/NAME-noteacher.
# TEACHER_MODEL=PATH: another teacher (teacher.sh's), into runs/sparse38/NAME-TAG (TAG=newteacher).
TEACHER=(--set "loss.teacher=\"${TEACHER_MODEL:-runs/half36/teacher-half-2500/best.safetensors}\"")
SUFFIX=${TEACHER_MODEL:+-${TAG:-newteacher}}
if [ -n "${NOTEACHER:-}" ]; then
  TEACHER=(--set 'loss.teacher=""' --set loss.teacher_weight=0 --set loss.feature_weight=0)
  SUFFIX=-noteacher
fi
INIT=runs/skip37/fast5/control/best.safetensors STEPS=${STEPS:-400} ROOT=runs/sparse38/$1$SUFFIX \
  TIME_LIMIT=${TIME_LIMIT:-40min} exec runs/drop29/train.sh control \
  --set 'model.srm_onset="same_step"' --set sample.step_ms=5 --set run.threads=${THREADS:-1} \
  --set "data.train=$TRAIN" \
  --set 'data.val=[{path="data/mod2-val-ds2",split="all"}]' \
  --set 'data.val_static=[{path="data/posterflat-sim601-ds2"},{path="data/sparsestatic-val-ds2"}]' \
  "${TEACHER[@]}" "${@:2}"
