#!/usr/bin/env bash
# The thirty-fifth session's firing-rate fine-tunes of the default (runs/ceil35/README.md): the
# runtime's cost on a busy room is in the full-resolution layers (1, 2, 10, 11 and the output
# they drive), so their rate ceilings (loss.rate_ceilings, paid as floor_weight * (r/c - 1)^2
# above c; the default's recipe has 0.06) are lowered to CEIL, from
# runs/onset33/same10/control/best.safetensors (the default before calibration: same-step
# neurons, 10 ms steps) with the default's own recipe (runs/drop29/train.sh control).
# Usage: [CEIL=0.03] [ROOT=runs/ceil35/cCEIL] [STEPS=400] [SPIKEMS=build/spikems] runs/ceil35/train.sh [MORE ARGS]
set -euo pipefail
cd "$(dirname "$0")/../.."
C=${CEIL:-0.03}
INIT=runs/onset33/same10/control/best.safetensors ROOT=${ROOT:-runs/ceil35/c$C} STEPS=${STEPS:-400} \
  exec runs/drop29/train.sh control --set 'model.srm_onset="same_step"' \
  --set sample.step_ms=10 --set 'model.init_time_constants="steps"' \
  --set "loss.rate_ceilings=[$C, $C, 0.25, 0.3, 0.3, 0.3, 0.3, 0.3, 0.25, $C, $C]" "$@"
