#!/usr/bin/env bash
# Reproduces `full` (models/spikems-full.safetensors: full resolution, 10 ms steps) from random
# weights, every stage in its own folder of OUT, each starting from the one before:
#   teacher        the ANN-2D teacher from random weights            (CPU, 55 min)
#   snn-cpu        the spiking network from its weights, 2 ms steps   (CPU, 105 min)
#   snn-gpu        the same loss on 64 more rooms                     (GPU, 220 s on an H100)
#   same5, same10  same-step neurons at 5 ms, then 10 ms steps         (CPU, 84 + 28 min)
#   full-noskip    without the skip into the output layer             (CPU, 5 min)
# then the calibration (best event IoU on the validation rooms) and recipes/score.sh into
# OUT/score. Times: one thread of a 2-core AMD EPYC VM and one NVIDIA H100, as measured.
#
# Usage: recipes/full/run.sh OUT        (data: recipes/data.sh first)
# Environment: SPIKEMS, DATA, THREADS, GPU_DEVICE (recipes/common/stages.sh).
set -euo pipefail
# shellcheck source-path=SCRIPTDIR source=../common/stages.sh
. "$(dirname "$0")/../common/stages.sh"
recipe_start "$0" "$@"

full_resolution_stages
cut_skip same10/best.safetensors full-noskip
stage full/full-noskip best.safetensors
calibrate full-noskip/best.safetensors spikems-full.safetensors --factors 1.2,1.4,1.6,1.8,2.0,2.2
score spikems-full.safetensors
