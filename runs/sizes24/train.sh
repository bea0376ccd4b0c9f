#!/usr/bin/env bash
# The twenty-fourth session's CPU runs (runs/sizes24/README.md): the skip teacher fine-tuned as
# runs/flat23's `static` run, with static scenes from two cameras (346 x 260 and 240 x 180,
# 55-80 degrees), and in `sizes` also a fifth of its samples from rooms with objects seen by
# those cameras. Usage: runs/sizes24/train.sh sizes|static-sizes|sizes-plain|flat-1cam [OUT_NAME [MORE train ARGS]]
# (sizes-ema: runs/sizes24/train.sh sizes sizes-ema --set optim.ema_decay=0.998)
set -euo pipefail
SPIKEMS=${SPIKEMS:-build/spikems}
case "${1:-}" in
  sizes) DATA='[{path="data/mod2-train",split="train",weight=0.16},{path="data/mod3-train",split="all",weight=0.44},{path="data/modflat-sizes-train101",split="all",weight=0.2},{path="data/modstaticflat-sizes-train103",split="all",weight=0.1},{path="data/posterflat-sizes-train107",split="all",weight=0.1}]' ;;
  static-sizes) DATA='[{path="data/mod2-train",split="train",weight=0.16},{path="data/mod3-train",split="all",weight=0.64},{path="data/modstaticflat-sizes-train103",split="all",weight=0.1},{path="data/posterflat-sizes-train107",split="all",weight=0.1}]' ;;
  # The pair that separates `sizes`'s two changes: its rooms without flat walls, or with flat
  # walls from the one 346 x 260 camera (the same seed, 101).
  sizes-plain) DATA='[{path="data/mod2-train",split="train",weight=0.16},{path="data/mod3-train",split="all",weight=0.44},{path="data/mod-sizes-train101",split="all",weight=0.2},{path="data/modstaticflat-sizes-train103",split="all",weight=0.1},{path="data/posterflat-sizes-train107",split="all",weight=0.1}]' ;;
  flat-1cam) DATA='[{path="data/mod2-train",split="train",weight=0.16},{path="data/mod3-train",split="all",weight=0.44},{path="data/modflat-train101",split="all",weight=0.2},{path="data/modstaticflat-sizes-train103",split="all",weight=0.1},{path="data/posterflat-sizes-train107",split="all",weight=0.1}]' ;;
  *) echo "usage: $0 sizes|static-sizes|sizes-plain|flat-1cam" >&2; exit 2 ;;
esac
exec "$SPIKEMS" train --config configs/train/ann2d.toml --steps 4000 --threads 1 -q \
  --set 'model.channels=[16,32,64,64,64,64]' --set sample.crop=0 --set sample.step_ms=10 \
  --set model.skips=true --set 'model.init="runs/arch19/skips/teacher-step3500.safetensors"' \
  --set optim.lr=0.0003 --set run.val_every=1000 --set run.keep_val_models=true \
  --set 'data.val_static=[{path="data/posterflat-sim601"}]' --time-limit "${TIME_LIMIT:-70min}" \
  --out "runs/sizes24/${2:-$1}" --set "data.train=$DATA" "${@:3}"
