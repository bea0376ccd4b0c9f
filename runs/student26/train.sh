#!/usr/bin/env bash
# The twenty-sixth session's fork of the CPU student (runs/student26/README.md): runs/student25/t1
# continued from its checkpoint with finely textured backgrounds added to the data (rooms with
# objects and static scenes whose wall or poster texture is as fine in the image as the
# objects'). Everything else (model, teacher, schedule, seed) is t1's.
# Usage: runs/student26/train.sh [OUT_NAME [MORE train ARGS]]
# A new OUT_NAME forks the run folder FROM (default runs/student25/t1: its checkpoint, config and
# log); t2 was forked from t1's step-1,350 checkpoint, which was not kept.
set -euo pipefail
SPIKEMS=${SPIKEMS:-build/spikems}
OUT=runs/student26/${1:-t2}
FROM=${FROM:-runs/student25/t1}
if [ ! -e "$OUT/checkpoint.pt" ]; then
  mkdir -p "$OUT"
  cp "$FROM/checkpoint.pt" "$FROM/config.json" "$FROM/log.jsonl" "$OUT/"
fi
DATA='[{path="data/mod2-train",split="train",weight=0.12},{path="data/mod3-train",split="all",weight=0.48},{path="data/modfine-train121",split="all",weight=0.2},{path="data/modstaticflat-sizes-train103",split="all",weight=0.05},{path="data/posterflat-sizes-train107",split="all",weight=0.05},{path="data/modstaticfine-sizes-train123",split="all",weight=0.05},{path="data/posterfine-sizes-train127",split="all",weight=0.05}]'
exec "$SPIKEMS" train --resume "$OUT" --threads 1 -q --set "data.train=$DATA" \
  --time-limit "${TIME_LIMIT:-140min}" "${@:2}"
