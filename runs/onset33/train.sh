#!/usr/bin/env bash
# The thirty-third session's fine-tunes with same-step neurons (model.srm_onset = "same_step",
# docs/model.md): the shipped default's raw weights (runs/gpu-hybrid/ft-cont, before
# calibration), every layer switched to the kernel sampled at the end of the spike's step, so
# that an input reaches the output in its own step instead of 2-12 steps later; then trained on
# with runs/drop29/train.sh's `control` recipe (the default's own: its teacher and rooms, drop up
# to 20 %, lr 2e-4 cosine, weight average 0.995, batch 4, one thread).
#   same2: at the model's 2 ms steps
#   same5: at 5 ms steps (time constants scaled by 5/2: each step behaves as the 2 ms one did)
#   same10: at 10 ms steps from same5's best (the shipped default before calibration), scaled 2x
#   same20: at 20 ms steps from same10's best (thirty-fourth session), scaled 2x again
# Usage: [SPIKEMS=build/spikems] [STEPS=600] [TIME_LIMIT=95min] runs/onset33/train.sh same2|same5|same10|same20 [MORE ARGS]
set -euo pipefail
cd "$(dirname "$0")/../.."
SAME=(--set 'model.srm_onset="same_step"')
case "${1:?same2, same5, same10 or same20}" in
  same2) ROOT=runs/onset33/same2 exec runs/drop29/train.sh control "${SAME[@]}" "${@:2}" ;;
  same5)
    ROOT=runs/onset33/same5 exec runs/drop29/train.sh control "${SAME[@]}" \
      --set sample.step_ms=5 --set 'model.init_time_constants="steps"' "${@:2}" ;;
  same10)
    INIT=runs/onset33/same5/control/best.safetensors ROOT=runs/onset33/same10 \
      exec runs/drop29/train.sh control "${SAME[@]}" \
      --set sample.step_ms=10 --set 'model.init_time_constants="steps"' "${@:2}" ;;
  same20)
    INIT=${INIT:-runs/onset33/same10/control/best.safetensors} ROOT=runs/onset33/same20 \
      exec runs/drop29/train.sh control "${SAME[@]}" \
      --set sample.step_ms=20 --set 'model.init_time_constants="steps"' "${@:2}" ;;
  *) echo "unknown run $1 (same2, same5, same10 or same20)" >&2; exit 1 ;;
esac
