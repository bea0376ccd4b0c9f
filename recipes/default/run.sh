#!/usr/bin/env bash
# Reproduces `default` (models/spikems-default.safetensors: half resolution, 10 ms steps) from
# random weights: the stages of `fast` (recipes/fast/run.sh: 5.2 h of CPU and 220 s of GPU as
# measured), then the static-budget calibration: among the output thresholds that call at most
# 5 % of the simulated static look-alike rooms' events moving (data/lookalikesstatic-val-ds2),
# the one with the best event IoU on the validation rooms (data/mod5-val1s); then
# recipes/score.sh into OUT/score. With the OUT of a `fast` recipe only the calibration and the
# score run.
#
# Usage: recipes/default/run.sh OUT     (data: recipes/data.sh first)
# Environment: SPIKEMS, DATA, THREADS, GPU_DEVICE (recipes/common/stages.sh).
set -euo pipefail
# shellcheck source-path=SCRIPTDIR source=../common/stages.sh
. "$(dirname "$0")/../common/stages.sh"
recipe_start "$0" "$@"

half_resolution_stages
stage common/lookalikes10 val-step800.safetensors
calibrate lookalikes10/val-step800.safetensors spikems-default.safetensors "${BUDGET[@]}"
score spikems-default.safetensors
