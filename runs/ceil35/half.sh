#!/usr/bin/env bash
# Half resolution (thirty-fifth session, runs/ceil35/README.md): the default's recipe on the rooms
# downsampled 2x (`spikems convert --downsample 2`: data/NAME-ds2, made by
# runs/ceil35/downsample2.sh NAME), from the default before calibration. The runtime's cost is
# in visiting the full-resolution maps, so a network on 173x130 runs its network ~3.8x faster.
# Usage: [STEPS=300] [SUFFIX=] [ROOT=runs/ceil35/half-RUN] runs/ceil35/half.sh teacher|noteacher [MORE ARGS]
set -euo pipefail
cd "$(dirname "$0")/../.."
case "${1:?teacher or noteacher}" in
  teacher) X=() ;;
  noteacher) X=(--set loss.teacher_weight=0 --set loss.feature_weight=0) ;;
  *) echo "unknown run $1" >&2; exit 1 ;;
esac
INIT=runs/onset33/same10/control/best.safetensors ROOT=${ROOT:-runs/ceil35/half-$1${SUFFIX:-}} \
  STEPS=${STEPS:-300} \
  exec runs/drop29/train.sh control --set 'model.srm_onset="same_step"' \
  --set sample.step_ms=10 --set 'model.init_time_constants="steps"' \
  --set 'data.train=[{path="data/mod2-train-ds2",split="train",weight=0.2},{path="data/mod3-train-ds2",split="all",weight=0.8}]' \
  --set 'data.val=[{path="data/mod2-val-ds2",split="all"}]' \
  --set 'data.val_static=[{path="data/posterflat-sim601-ds2"}]' "${X[@]}" "${@:2}"
