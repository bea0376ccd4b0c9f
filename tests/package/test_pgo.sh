#!/usr/bin/env bash
# scripts/build_pgo gives a spikems whose labels, masks and scores are byte for byte the plain
# build's, on a room that is not the profile's (seed 9502 against the profile's 9501), for the
# default model and `fast`. Two builds of `spikems`: "slow" (ctest -L pgo).
#   test_pgo.sh BUILD_DIR    (the plain build holding spikems)
set -euo pipefail
plain=$(cd "$1" && pwd)/spikems
src=$(cd "$(dirname "$0")/../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
BUILD_DIR="$tmp/pgo" "$src/scripts/build_pgo" >"$tmp/build.log" 2>&1 || {
  tail -30 "$tmp/build.log"
  exit 1
}
# shellcheck disable=SC2034  # read as ${!b} below
pgo="$tmp/pgo/spikems"
"$plain" simulate --preset mod --sequences 1 --duration 0.5s --seed 9502 --threads 2 \
  --no-progress --out "$tmp/room" >/dev/null
room=$(ls "$tmp"/room/*.h5 | head -n 1)
cd "$src"
for m in default fast; do
  for b in plain pgo; do
    "${!b}" segment --quiet --model "models/spikems-$m.safetensors" --input "$room" --out "$tmp/$b-$m.txt" \
      --labels "$tmp/$b-$m.npy" --masks-dir "$tmp/$b-$m-masks" --score >"$tmp/$b-$m.score"
  done
  for f in "$m.txt" "$m.npy" "$m.score"; do
    cmp "$tmp/plain-$f" "$tmp/pgo-$f" || { echo "FAIL: $f differs between the builds"; exit 1; }
  done
  diff -r "$tmp/plain-$m-masks" "$tmp/pgo-$m-masks" >/dev/null ||
    { echo "FAIL: $m's mask frames differ between the builds"; exit 1; }
  [[ $(wc -l <"$tmp/plain-$m.txt") -gt 1000 ]] || { echo "FAIL: too few labelled events"; exit 1; }
done
echo "ok: the profile-guided build labels a room it was not profiled on as the plain build does"
