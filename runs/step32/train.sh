#!/usr/bin/env bash
# The thirty-second session's fine-tunes at 5 ms steps (runs/step32/README.md): a 2 ms model's
# weights with every time constant scaled by 5/2 (model.init_time_constants = "steps", so each
# step behaves as before with 2.5x the time and events in it), then trained at 5 ms steps with
# runs/drop29/train.sh's recipe (its teacher, the hybrid loss, drop up to 80 %, lr 2e-4 cosine,
# weight average 0.995, batch 4, one thread).
#   drop:   from runs/drop29/drop/val-step600 (the rooms only)
#   budget: from runs/budget31/static/drop/val-step600, with its SynOps budget (2,500 per
#           event, w 0.2) and 20 % static scenes, as runs/budget31/static
# Usage: [SPIKEMS=build/spikems] [STEPS=700] runs/step32/train.sh drop|budget [MORE ARGS]
set -euo pipefail
cd "$(dirname "$0")/../.."
S5=(--set sample.step_ms=5 --set 'model.init_time_constants="steps"')
case "${1:?drop or budget}" in
  drop)
    INIT=runs/drop29/drop/val-step600.safetensors ROOT=runs/step32 \
      exec runs/drop29/train.sh drop "${S5[@]}" "${@:2}" ;;
  budget)
    INIT=runs/budget31/static/drop/val-step600.safetensors ROOT=runs/step32/budget \
      exec runs/drop29/train.sh drop "${S5[@]}" --set loss.synops_weight=0.2 \
      --set loss.synops_budget=2500 \
      --set 'data.train=[{path="data/mod2-train",split="train",weight=0.16},{path="data/mod3-train",split="all",weight=0.64},{path="data/modstaticflat-sizes-train103",split="all",weight=0.1},{path="data/posterflat-sizes-train107",split="all",weight=0.1}]' \
      "${@:2}" ;;
  *) echo "unknown run $1 (drop or budget)" >&2; exit 1 ;;
esac
