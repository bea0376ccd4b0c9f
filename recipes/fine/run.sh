#!/usr/bin/env bash
# Reproduces `fine` (models/spikems-fine.safetensors: half resolution, 5 ms steps) from random
# weights, every stage in its own folder of OUT, each starting from the one before: the stages
# of `fast` up to half-noskip and its teachers (recipes/fast/run.sh), then
#   half5          half-noskip at 5 ms steps                           (CPU, 5 min)
#   lookalikes5    half5 on 192 rooms and look-alike rooms             (CPU, 30 min)
# then the static-budget calibration (as `default`'s) and recipes/score.sh into OUT/score.
# Times: one thread of a 2-core AMD EPYC VM and one NVIDIA H100, as measured.
#
# Usage: recipes/fine/run.sh OUT        (data: recipes/data.sh first)
# Environment: SPIKEMS, DATA, THREADS, GPU_DEVICE (recipes/common/stages.sh).
set -euo pipefail
# shellcheck source-path=SCRIPTDIR source=../common/stages.sh
. "$(dirname "$0")/../common/stages.sh"
recipe_start "$0" "$@"

half_resolution_stages
stage fine/half5 best.safetensors
stage fine/lookalikes5 val-step1600.safetensors
calibrate lookalikes5/val-step1600.safetensors spikems-fine.safetensors "${BUDGET[@]}"
score spikems-fine.safetensors
