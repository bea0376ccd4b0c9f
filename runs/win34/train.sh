#!/usr/bin/env bash
# The thirty-fourth session's fine-tune of the default with longer loss windows
# (runs/win34/README.md): from runs/onset33/same10/control/best.safetensors (the default before
# calibration: same-step neurons, 10 ms steps), the default's recipe (runs/drop29/train.sh
# control: teacher, rooms, drop <= 20 %, lr 2e-4 cosine, weight average 0.995, batch 4) with
# sample.window_ms = WINDOW (default 20: two steps scored per sample instead of one), two threads.
# Usage: [WINDOW=20] [STEPS=500] [SPIKEMS=build/spikems] runs/win34/train.sh [MORE ARGS]
set -euo pipefail
cd "$(dirname "$0")/../.."
W=${WINDOW:-20}
INIT=runs/onset33/same10/control/best.safetensors ROOT=runs/win34/w$W \
  exec runs/drop29/train.sh control --set 'model.srm_onset="same_step"' \
  --set sample.step_ms=10 --set 'model.init_time_constants="steps"' \
  --set sample.window_ms=$W --set run.threads=2 "$@"
