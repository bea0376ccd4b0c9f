#!/usr/bin/env bash
# The twenty-eighth session's second restart of the CPU student (runs/student28/README.md):
# runs/student27/train.sh's `control` (t2's data mix, teacher and losses, weight average 0.995)
# from the first restart's end, runs/student27/control/val-step500.safetensors, with a fresh
# optimizer and lr 2e-4 cosine over 700 steps. The first restart lowered the real poster's
# share at an unchanged held-out IoU; this asks whether a second one goes on doing so.
# Usage: runs/student28/train.sh control [MORE train ARGS]
set -euo pipefail
[ "${1:-}" = control ] || { echo "usage: runs/student28/train.sh control" >&2; exit 1; }
INIT=runs/student27/control/val-step500.safetensors LR=0.0002 STEPS=${STEPS:-700} \
  ROOT=runs/student28 exec "$(dirname "$0")/../student27/train.sh" "$@"
