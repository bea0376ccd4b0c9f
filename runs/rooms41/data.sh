#!/usr/bin/env bash
# The data of the forty-first session's runs (runs/rooms41/README.md), in the order they are
# needed: calibration and training first, held-out scoring after.
# THREADS (2) simulator threads; sets already there are kept. ~55 min on two threads.
# ONLY="name ..." makes only those sets (e.g. the held-out and validation ones: runs/default44).
set -euo pipefail
cd "$(dirname "$0")/../.."
S=${SPIKEMS:-build/spikems} T=${THREADS:-2} ONLY=${ONLY:-}
sim() { local name=$1 ds=$2; shift 2; [ -z "$ONLY" ] || [[ " $ONLY " == *" $name "* ]] || return 0
        [ -f data/$name/manifest.json ] || "$S" simulate "$@" --threads $T --out data/$name
        [ "$ds" = 0 ] || [ -f data/$name-ds2/manifest.json ] || runs/ceil35/downsample2.sh $name; }
M=(--preset mod --mask-period 10ms)
sim mod5-val1s 0 "${M[@]}" --sequences 24 --duration 1s --seed 2001
sim lookalikesstatic-val 1 --config runs/sparse38/modstatic-lookalikes.toml --sequences 12 --duration 0.5s --seed 3812
sim mod2-val 1 "${M[@]}" --sequences 8 --duration 1s --seed 3001
sim posterflat-sim601 1 --config runs/flat23/poster-flat.toml --sequences 12 --duration 0.5s --seed 601
sim lookalikes-train 1 --config runs/sparse38/mod-lookalikes.toml --sequences 24 --duration 1.5s --seed 3811 --mask-period 10ms
sim mod7-train96 1 "${M[@]}" --sequences 96 --duration 1.5s --seed 7101
sim mod8-train96 1 "${M[@]}" --sequences 96 --duration 1.5s --seed 7102
sim mod-heldout6001 0 "${M[@]}" --sequences 24 --duration 2s --seed 6001
sim mod-heldout6002 0 "${M[@]}" --sequences 24 --duration 2s --seed 6002
sim mod2-heldout 0 "${M[@]}" --sequences 3 --duration 2s --seed 1001
sim mod-heldout7001 0 "${M[@]}" --sequences 24 --duration 1s --seed 7001
sim mod-heldout7002 0 "${M[@]}" --sequences 24 --duration 1s --seed 7002
sim mod6-val1s 0 "${M[@]}" --sequences 24 --duration 1s --seed 2002
[ -f /tmp/seq2.raw ] || [ ! -f data/mod2-heldout/seq_0002.h5 ] || "$S" convert data/mod2-heldout/seq_0002.h5 /tmp/seq2.raw >/dev/null
echo data done
