#!/usr/bin/env bash
# The thirty-fourth session's SynOps-budget fine-tune of the default (runs/budget34/README.md):
# from runs/onset33/same10/control/best.safetensors (the default before calibration:
# same-step neurons, 10 ms steps) with the default's own recipe (runs/drop29/train.sh control:
# its teacher and rooms, drop <= 20 %, lr 2e-4 cosine, weight average 0.995, batch 4, one
# thread) and a budget of BUDGET synaptic operations per input event (loss.synops_budget,
# weight 0.2; the default does ~4,500 per event on training samples, ~9,000 on whole validation
# frames, so 5,000 would not bind).
# Usage: [BUDGET=3000] [ROOT=runs/budget34/bBUDGET] [STEPS=600] [SPIKEMS=build/spikems] runs/budget34/train.sh [MORE ARGS]
set -euo pipefail
cd "$(dirname "$0")/../.."
B=${BUDGET:-3000}
INIT=runs/onset33/same10/control/best.safetensors ROOT=${ROOT:-runs/budget34/b$B} \
  exec runs/drop29/train.sh control --set 'model.srm_onset="same_step"' \
  --set sample.step_ms=10 --set 'model.init_time_constants="steps"' \
  --set loss.synops_weight=0.2 --set loss.synops_budget=$B "$@"
