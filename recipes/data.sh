#!/usr/bin/env bash
# Makes the simulated data sets the shipped models' recipes train on and their scores use, with
# `spikems simulate` (its presets) and fixed seeds: the simulator reproduces a seed's rooms on
# every machine. Each set is a folder OUTDIR/NAME
# (manifest.json + seq_XXXX.h5); NAME-ds2 is the same set at half resolution (173x130,
# `spikems convert --downsample 2`) for the half-resolution stages. Sets already there are kept.
#
#   training      mod2-train mod3-train mod3-train40 mod4-train gpu-train-a gpu-train-b
#                 mod3-train16 lookalikes-train mod7-train96 mod8-train96
#   validation    mod2-val posterflat-sim601 lookalikesstatic-val (static look-alike rooms)
#                 mod5-val1s (the calibration's rooms)
#   held out      mod-heldout6001 mod-heldout6002 (24 x 2 s), mod-heldout7001 mod-heldout7002
#                 (24 x 1 s), mod2-heldout (3 x 2 s; its seq_0002 is the busy room of the speed
#                 figures, also written as seq2.raw, EVT 3.0 as a camera writes it)
#
# 914 s of rooms in all (96 rooms of 1.5 s take ~12 min on two threads).
#
# Usage: [THREADS=N] [ONLY="NAME ..."] recipes/data.sh [OUTDIR]      (OUTDIR: data)
#   ONLY: make only these sets (and their -ds2), e.g. the held-out rooms for recipes/score.sh:
#   ONLY="mod-heldout6001 mod-heldout6002 mod-heldout7001 mod-heldout7002" recipes/data.sh
# Environment: SPIKEMS (default build/spikems, else spikems on the PATH).
set -euo pipefail
# shellcheck source-path=SCRIPTDIR source=common/paths.sh
. "$(dirname "$0")/common/paths.sh"
usage() { usage_of "$0" "$1"; }
case "${1:-}" in -h | --help) usage 0 ;; -*) usage 2 ;; esac
[ $# -le 1 ] || usage 2
S=$(find_spikems)
D=${1:-data}
T=${THREADS:-$(nproc)}
ONLY=${ONLY:-}
mkdir -p "$D"

# NAME-ds2: every sequence of NAME at half resolution, the manifest copied with the halved sensor.
ds2() {
  local src=$D/$1 dst=$D/$1-ds2 f
  [ -f "$dst/manifest.json" ] && return 0
  mkdir -p "$dst"
  for f in "$src"/*.h5; do "$S" convert "$f" "$dst/$(basename "$f")" --downsample 2 -q; done
  python3 - "$src" "$dst" <<'PY'
import json, sys
src, dst = sys.argv[1:]
m = json.load(open(f"{src}/manifest.json"))
w, h = m["sensor"]
m["sensor"] = [w // 2, h // 2]
for q in m.get("sequences", []):
    q["sensor"] = [w // 2, h // 2]
m["config"] = str(m.get("config", "")) + "; convert --downsample 2"
json.dump(m, open(f"{dst}/manifest.json", "w"), indent=1)
PY
}

# sim NAME DS2 ARGS...: OUTDIR/NAME from `spikems simulate ARGS`, then NAME-ds2 when DS2 is 1.
sim() {
  local name=$1 half=$2
  shift 2
  [ -z "$ONLY" ] || [[ " $ONLY " == *" $name "* ]] || return 0
  if [ ! -f "$D/$name/manifest.json" ]; then
    echo "data.sh: $name" >&2
    "$S" simulate "$@" --threads "$T" --out "$D/$name"
  fi
  if [ "$half" = 1 ]; then ds2 "$name"; fi
}

M=(--preset mod --mask-period 10ms)
LA=$REPO/configs/sim/mod-lookalikes.toml
LS=$REPO/configs/sim/modstatic-lookalikes.toml
PF=$REPO/configs/sim/poster-flat.toml
# Validation and calibration.
sim mod2-val 1 "${M[@]}" --sequences 8 --duration 1s --seed 3001
sim posterflat-sim601 1 --config "$PF" --sequences 12 --duration 0.5s --seed 601
sim lookalikesstatic-val 1 --config "$LS" --sequences 12 --duration 0.5s --seed 3812
sim mod5-val1s 0 "${M[@]}" --sequences 24 --duration 1s --seed 2001
# Training rooms. mod3-train40 and mod3-train16 are the first 40 and 16 rooms of mod3-train,
# gpu-train-a its first 32 (the same seed).
sim mod2-train 1 "${M[@]}" --sequences 24 --duration 1.5s --seed 31
sim mod3-train 0 "${M[@]}" --sequences 80 --duration 1.5s --seed 41
sim mod4-train 0 "${M[@]}" --sequences 40 --duration 1.5s --seed 51
sim gpu-train-a 0 "${M[@]}" --sequences 32 --duration 1.5s --seed 41
sim gpu-train-b 0 "${M[@]}" --sequences 32 --duration 1.5s --seed 43
sim mod3-train40 1 "${M[@]}" --sequences 40 --duration 1.5s --seed 41
sim mod3-train16 1 "${M[@]}" --sequences 16 --duration 1.5s --seed 41
sim lookalikes-train 1 --config "$LA" --sequences 24 --duration 1.5s --seed 3811 --mask-period 10ms
sim mod7-train96 1 "${M[@]}" --sequences 96 --duration 1.5s --seed 7101
sim mod8-train96 1 "${M[@]}" --sequences 96 --duration 1.5s --seed 7102
# Held out: no stage trains or calibrates on these seeds.
sim mod-heldout6001 0 "${M[@]}" --sequences 24 --duration 2s --seed 6001
sim mod-heldout6002 0 "${M[@]}" --sequences 24 --duration 2s --seed 6002
sim mod-heldout7001 0 "${M[@]}" --sequences 24 --duration 1s --seed 7001
sim mod-heldout7002 0 "${M[@]}" --sequences 24 --duration 1s --seed 7002
sim mod2-heldout 0 "${M[@]}" --sequences 3 --duration 2s --seed 1001
if [ -f "$D/mod2-heldout/seq_0002.h5" ] && [ ! -f "$D/seq2.raw" ]; then
  "$S" convert "$D/mod2-heldout/seq_0002.h5" "$D/seq2.raw" -q
fi
echo "data.sh: the data sets are in $D" >&2
