#!/usr/bin/env bash
# Reproduces `fast` (models/spikems-fast.safetensors: half resolution, 10 ms steps) from random
# weights, every stage in its own folder of OUT, each starting from the one before:
#   teacher            the ANN-2D teacher from random weights              (CPU, 55 min)
#   snn-cpu            the spiking network from its weights, 2 ms steps     (CPU, 105 min)
#   snn-gpu            the same loss on 64 more rooms                       (GPU, 220 s on an H100)
#   same5, same10      same-step neurons at 5 ms, then 10 ms steps           (CPU, 84 + 28 min)
#   teacher-half       the teacher at half resolution                       (CPU, 9 min)
#   half               same10 at half resolution under it                   (CPU, 7 min)
#   half-noskip        without the skip into the output layer               (CPU, 6 min)
#   teacher-lookalikes, teacher-lookalikes2: the half-resolution teacher on rooms of static
#                      look-alikes                                          (CPU, 6 + 6 min)
#   lookalikes10       half-noskip on 96 rooms and look-alike rooms         (CPU, 4 min)
# then the calibration (best event IoU on the validation rooms, no static budget) and
# recipes/score.sh into OUT/score. `default` is the same weights at another threshold
# (recipes/default/run.sh: give it the same OUT and only its calibration runs).
# Times: one thread (two for the teachers on look-alikes) of a 2-core AMD EPYC VM and one NVIDIA
# H100, as measured.
#
# Usage: recipes/fast/run.sh OUT        (data: recipes/data.sh first)
# Environment: SPIKEMS, DATA, THREADS, GPU_DEVICE (recipes/common/stages.sh).
set -euo pipefail
# shellcheck source-path=SCRIPTDIR source=../common/stages.sh
. "$(dirname "$0")/../common/stages.sh"
recipe_start "$0" "$@"

half_resolution_stages
stage common/lookalikes10 val-step800.safetensors
calibrate lookalikes10/val-step800.safetensors spikems-fast.safetensors --train-grid 173x130 \
  --factors 1.1,1.2,1.3,1.35,1.4,1.45,1.5
score spikems-fast.safetensors
