#!/usr/bin/env bash
# ctest install_tree (label install): `cmake --install BUILD --prefix TMP` puts the program, the
# shipped model and the docs in place, and the installed spikems finds its model without
# --model in the documented order (docs/cli.md): $SPIKEMS_MODEL, <exe>/../models/,
# <exe>/../share/spikems/models/; the LibTorch commands run the helper from lib/spikems/.
set -euo pipefail
build=$1
fail() { echo "FAIL: $*" >&2; exit 1; }
prefix=$(mktemp -d)
trap 'rm -rf "$prefix"' EXIT
cmake --install "$build" --prefix "$prefix" >/dev/null
exe=$prefix/bin/spikems
model=$prefix/share/spikems/models/spikems-default.safetensors
for f in "$exe" "$model" "$prefix/share/spikems/models/README.md" \
  "$prefix/share/spikems/models/spikems-fast.safetensors" \
  "$prefix/share/doc/spikems/README.md" "$prefix/share/doc/spikems/LICENSE" \
  "$prefix/share/doc/spikems/docs/cli.md"; do
  [ -f "$f" ] || fail "$f not installed"
done
# Exactly the two shipped models (default and fast) and their card.
installed=$(cd "$prefix/share/spikems/models" && echo *)
[ "$installed" = "README.md spikems-default.safetensors spikems-fast.safetensors" ] ||
  fail "installed models: $installed"
cmp -s "$model" "$(dirname "$0")/../../models/spikems-default.safetensors" ||
  fail "installed model differs from models/spikems-default.safetensors"

work=$prefix/work
mkdir "$work"
printf '# sensor 16 16\n1000 1 1 1\n1500 2 1 0\n2000 3 2 1\n' >"$work/ev.txt"
unset SPIKEMS_MODEL
seg() { (cd "$work" && "$exe" segment --quiet --input ev.txt "$@") 2>&1; }

# 1. Only the installed model exists: found, and the same labels as naming it.
seg --out default.txt >/dev/null || fail "segment without --model: $(seg --out default.txt)"
seg --out named.txt --model "$model" >/dev/null || fail "segment --model $model"
cmp -s "$work/default.txt" "$work/named.txt" || fail "default and named model disagree"
[ "$(grep -vc '^#' "$work/default.txt")" = 3 ] || fail "not one label per event"
# The other shipped model by its name: the installed file.
seg --out fast.txt --model fast >/dev/null || fail "segment --model fast: $(seg --out fast.txt --model fast)"
seg --out fastnamed.txt --model "$prefix/share/spikems/models/spikems-fast.safetensors" >/dev/null ||
  fail "segment --model spikems-fast.safetensors"
cmp -s "$work/fast.txt" "$work/fastnamed.txt" || fail "--model fast and its file disagree"

# 2. <exe>/../models/ (the source-tree place) comes first: a broken file there is the one read.
mkdir "$prefix/models"
echo "not a model" >"$prefix/models/spikems-default.safetensors"
if out=$(seg --out x.txt); then fail "read the installed model although models/ comes first"; fi
grep -q "$prefix/models/spikems-default.safetensors" <<<"$out" || fail "error: $out"
rm -r "$prefix/models"

# 3. $SPIKEMS_MODEL, when set, is the only place looked at.
if out=$(SPIKEMS_MODEL=$work/none.safetensors seg --out y.txt); then
  fail "ran although SPIKEMS_MODEL names a missing file"
fi
grep -q "looked at: $work/none.safetensors)" <<<"$out" || fail "error: $out"
# 4. With training built, `spikems train` runs the installed helper (lib/spikems/spikems-torch).
if grep -q '^SPIKEMS_WITH_TRAIN:BOOL=ON' "$build/CMakeCache.txt"; then
  [ -x "$prefix/lib/spikems/spikems-torch" ] || fail "lib/spikems/spikems-torch not installed"
  out=$("$exe" train --help 2>&1) || fail "installed spikems train --help: $out"
  grep -q -- "--resume" <<<"$out" || fail "train --help: $out"
fi
echo "ok: installed tree complete; default model found in the documented order"
