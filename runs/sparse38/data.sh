#!/usr/bin/env bash
# The data of the thirty-eighth session's runs (runs/sparse38/README.md), each set then at half
# resolution (runs/ceil35/downsample2.sh). One core, ~45 min; sets already there are kept.
set -euo pipefail
cd "$(dirname "$0")/../.."
S=${SPIKEMS:-build/spikems}
sim() { local name=$1; shift; [ -f data/$name/manifest.json ] || "$S" simulate "$@" --out data/$name; \
        [ -f data/$name-ds2/manifest.json ] || runs/ceil35/downsample2.sh $name; }
sim mod2-val --preset mod --sequences 8 --duration 1s --seed 3001 --mask-period 10ms
sim posterflat-sim601 --config runs/flat23/poster-flat.toml --sequences 12 --duration 0.5s --seed 601
sim sparse-train --config runs/sparse38/mod-sparse.toml --sequences 24 --duration 1.5s --seed 3801 --mask-period 10ms
sim sparse-val --config runs/sparse38/mod-sparse.toml --sequences 8 --duration 1s --seed 3802 --mask-period 10ms
sim mod3-train16 --preset mod --sequences 16 --duration 1.5s --seed 41 --mask-period 10ms
sim sparsestatic-val --config runs/sparse38/modstatic-sparse.toml --sequences 12 --duration 0.5s --seed 3803
sim lookalikes-train --config runs/sparse38/mod-lookalikes.toml --sequences 24 --duration 1.5s --seed 3811 --mask-period 10ms
sim lookalikesstatic-val --config runs/sparse38/modstatic-lookalikes.toml --sequences 12 --duration 0.5s --seed 3812
