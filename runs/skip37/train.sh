#!/usr/bin/env bash
# Thirty-seventh session (runs/skip37/README.md): the shipped models without the skip from
# layer 1 into the output layer. Two thirds of the output layer's drive were layer 1's spikes
# through that skip (docs/performance.md, "Where a step's time goes"); without it the output
# layer takes only the decoder's spikes. Each run starts from the shipped model's weights before
# calibration with the skip's weight rows removed (drop_skip.py), then its own recipe:
#   default: runs/drop29/train.sh control at 10 ms steps, 400 steps, two threads
#   fast:    the half-resolution student's recipe (runs/ceil35/half.sh teacher with the
#            thirty-sixth session's half-resolution teacher), 1,200 steps, two threads
#   default5: the same for the thirty-third session's 5 ms default (an experiment)
#   fast5: the fast model without the skip moved to 5 ms steps, 600 steps (an experiment)
# Usage: runs/skip37/train.sh default|default5|fast|fast5 [MORE ARGS]
set -euo pipefail
cd "$(dirname "$0")/../.."
SAME=(--set 'model.srm_onset="same_step"' --set sample.step_ms=10 --set run.threads=2)
case "${1:?default, default5, fast or fast5}" in
  default)
    python3 runs/skip37/drop_skip.py runs/onset33/same10/control/best.safetensors \
      runs/skip37/init-noskip.safetensors 11
    INIT=runs/skip37/init-noskip.safetensors STEPS=400 ROOT=runs/skip37 TIME_LIMIT=40min \
      exec runs/drop29/train.sh control "${SAME[@]}" "${@:2}" ;;
  default5)  # the thirty-third session's 5 ms default, the same way (an experiment: not shipped)
    python3 runs/skip37/drop_skip.py runs/onset33/same5/control/best.safetensors \
      runs/skip37/init-noskip5.safetensors 11
    INIT=runs/skip37/init-noskip5.safetensors STEPS=400 ROOT=runs/skip37/ms5 TIME_LIMIT=40min \
      exec runs/drop29/train.sh control --set 'model.srm_onset="same_step"' --set sample.step_ms=5 \
      --set run.threads=2 "${@:2}" ;;
  fast5)  # the fast model without the skip moved to 5 ms steps (an experiment: not shipped)
    INIT=runs/skip37/fast/control/best.safetensors STEPS=600 ROOT=runs/skip37/fast5 \
      TIME_LIMIT=30min exec runs/drop29/train.sh control --set 'model.srm_onset="same_step"' \
      --set sample.step_ms=5 --set 'model.init_time_constants="steps"' --set run.threads=2 \
      --set 'data.train=[{path="data/mod2-train-ds2",split="train",weight=0.2},{path="data/mod3-train-ds2",split="all",weight=0.8}]' \
      --set 'data.val=[{path="data/mod2-val-ds2",split="all"}]' \
      --set 'data.val_static=[{path="data/posterflat-sim601-ds2"}]' \
      --set 'loss.teacher="runs/half36/teacher-half-2500/best.safetensors"' "${@:2}" ;;
  fast)
    python3 runs/skip37/drop_skip.py runs/half36/student-t2500/control/best.safetensors \
      runs/skip37/init-fast-noskip.safetensors 11
    INIT=runs/skip37/init-fast-noskip.safetensors STEPS=1200 ROOT=runs/skip37/fast \
      TIME_LIMIT=40min exec runs/drop29/train.sh control "${SAME[@]}" \
      --set 'data.train=[{path="data/mod2-train-ds2",split="train",weight=0.2},{path="data/mod3-train-ds2",split="all",weight=0.8}]' \
      --set 'data.val=[{path="data/mod2-val-ds2",split="all"}]' \
      --set 'data.val_static=[{path="data/posterflat-sim601-ds2"}]' \
      --set 'loss.teacher="runs/half36/teacher-half-2500/best.safetensors"' "${@:2}" ;;
  *) echo "unknown run $1 (default, default5, fast or fast5)" >&2; exit 1 ;;
esac
