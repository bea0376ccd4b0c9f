#!/usr/bin/env bash
# The forty-fourth session's data (runs/default44/README.md): held-out rooms of seeds 6001/6002 and 7001/7002, the validation rooms and static look-alikes, as runs/rooms41/data.sh makes them (~25 min on two threads).
set -euo pipefail
cd "$(dirname "$0")/../.."
S=${SPIKEMS:-build/spikems} T=${THREADS:-2}
sim() { local name=$1 ds=$2; shift 2; [ -f data/$name/manifest.json ] || "$S" simulate "$@" --threads $T --out data/$name
        [ "$ds" = 0 ] || [ -f data/$name-ds2/manifest.json ] || runs/ceil35/downsample2.sh $name; }
M=(--preset mod --mask-period 10ms)
sim mod-heldout6001 0 "${M[@]}" --sequences 24 --duration 2s --seed 6001
sim mod-heldout6002 0 "${M[@]}" --sequences 24 --duration 2s --seed 6002
sim mod5-val1s 0 "${M[@]}" --sequences 24 --duration 1s --seed 2001
sim lookalikesstatic-val 1 --config runs/sparse38/modstatic-lookalikes.toml --sequences 12 --duration 0.5s --seed 3812
sim mod-heldout7001 0 "${M[@]}" --sequences 24 --duration 1s --seed 7001
sim mod-heldout7002 0 "${M[@]}" --sequences 24 --duration 1s --seed 7002
sim mod2-heldout 0 "${M[@]}" --sequences 3 --duration 2s --seed 1001
[ -f /tmp/seq2.raw ] || "$S" convert data/mod2-heldout/seq_0002.h5 /tmp/seq2.raw >/dev/null   # the speed room as EVT 3.0
echo data done
