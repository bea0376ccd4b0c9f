#!/usr/bin/env bash
# Held-out rooms of seeds 7001/7002 (24 x 1 s each) for one model: all windows and the authors' protocol.
# Usage: [OUT=out/eval44] runs/default44/score7k.sh NAME MODEL
set -euo pipefail
cd "$(dirname "$0")/../.."
N=${1:?name} M=${2:?model} O=${OUT:-out/eval44}/$N-7k
R=(--data data/mod-heldout7001 --data data/mod-heldout7002 --split all --windows 20,100 --threads 1 --quiet)
build/spikems eval --model "$M" "${R[@]}" --out "$O/rooms"
build/spikems eval --model "$M" "${R[@]}" --min-moving-share 50 --group-windows 8 --out "$O/authors"
