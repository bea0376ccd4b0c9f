#!/usr/bin/env bash
# ctest package_deb (labels package, slow): builds the .deb with scripts/package (arguments go
# to cmake), unpacks it into a temporary root with dpkg -x, and checks that the unpacked
# spikems runs: --version is the package's version, and `segment` of a small text file finds
# the installed default model and writes one label per event. With --pgo first (ctest
# package_deb_pgo), it also checks that the package's build was profile-guided.
set -euo pipefail
cd "$(dirname "$0")/../.."
fail() { echo "FAIL: $*" >&2; exit 1; }

deb=$(scripts/package "$@" | tail -n 1)
[ -f "$deb" ] || fail "scripts/package printed no .deb path ($deb)"
echo "package: $deb"
pkgdir=${PACKAGE_BUILD_DIR:-build-package}
if [ "${1:-}" = --pgo ]; then
  grep -q '^CMAKE_CXX_FLAGS:STRING=-fprofile-use=' "$pkgdir/CMakeCache.txt" ||
    fail "scripts/package --pgo: $pkgdir was not built with -fprofile-use"
fi

# Control fields: name, version from project(), dependencies from dpkg-shlibdeps.
[ "$(dpkg-deb -f "$deb" Package)" = spikems ] || fail "Package field"
version=$(dpkg-deb -f "$deb" Version)
want=$(sed -n 's/^project(spikems VERSION \([0-9.]*\).*/\1/p' CMakeLists.txt)
[ "$version" = "$want" ] || fail "Version field '$version', project() says '$want'"
depends=$(dpkg-deb -f "$deb" Depends)
grep -q 'libc6' <<<"$depends" || fail "Depends lacks libc6 (dpkg-shlibdeps not run?): $depends"
echo "Depends: $depends"

root=$(mktemp -d)
trap 'rm -rf "$root"' EXIT
dpkg -x "$deb" "$root"
exe=$root/usr/bin/spikems
model=$root/usr/share/spikems/models/spikems-default.safetensors
for f in "$exe" "$model" "$root/usr/share/doc/spikems/LICENSE" \
  "$root/usr/share/doc/spikems/docs/cli.md" "$root/usr/share/spikems/models/README.md"; do
  [ -f "$f" ] || fail "$f missing from the package"
done

# Every shared library the programs load comes from a package that Depends names (HDF5 is
# linked from its static archive where Debian ships one, so it need not be among them).
# ldconfig lives in /sbin, which is not on a Debian user's PATH.
loader_cache=$(/sbin/ldconfig -p)
for bin in "$exe" "$root/usr/lib/spikems/spikems-torch"; do
  [ -f "$bin" ] || continue
  for so in $(readelf -d "$bin" | sed -n 's/.*Shared library: \[\(.*\)\]/\1/p'); do
    path=$(awk -v s="$so" '$1 == s { print $NF; exit }' <<<"$loader_cache")
    [ -n "$path" ] || fail "$bin needs $so, which this system's loader does not know"
    pkg=$(dpkg -S "$path" 2>/dev/null | sed -n '1s/:.*//p') || true
    [ -n "$pkg" ] || pkg=$(dpkg -S "$(realpath "$path")" 2>/dev/null | sed -n '1s/:.*//p') || true
    [ -n "$pkg" ] || continue  # not from a package (a LibTorch built by hand): nothing to name
    tr ',|' '\n\n' <<<"$depends" | awk '{ print $1 }' | grep -xF "$pkg" >/dev/null ||
      fail "Depends lacks $pkg, which provides $so for ${bin#"$root"}: $depends"
  done
done

[ "$("$exe" --version)" = "spikems $version" ] || fail "--version: $("$exe" --version)"
# With training built, the LibTorch commands' helper is packaged and `spikems train` finds it.
if [ -f "$pkgdir/CMakeCache.txt" ] && ! grep -q '^SPIKEMS_WITH_TRAIN:BOOL=OFF' \
  "$pkgdir/CMakeCache.txt"; then
  [ -x "$root/usr/lib/spikems/spikems-torch" ] || fail "usr/lib/spikems/spikems-torch missing"
  "$exe" train --help | grep -q -- "--resume" || fail "packaged spikems train --help"
fi

# 40 events on a 16 x 16 sensor: a bar moving right, one event per pixel and 0.5 ms.
work=$root/work
mkdir "$work"
{
  echo "# sensor 16 16"
  for i in $(seq 0 39); do echo "$((1000 + 500 * i)) $((i % 16)) $((4 + i / 16)) 1"; done
} >"$work/ev.txt"
unset SPIKEMS_MODEL
(cd "$work" && "$exe" segment --input ev.txt --out labels.txt --stats) >"$work/log" 2>&1 ||
  { cat "$work/log"; fail "segment with the installed model"; }
lines=$(grep -vc '^#' "$work/labels.txt" || true)
[ "$lines" = 40 ] || fail "labels.txt has $lines label lines for 40 events"
# Each line: the event as given, then a label 0 or 1.
paste -d' ' <(grep -v '^#' "$work/ev.txt") <(grep -v '^#' "$work/labels.txt") |
  awk '$1 != $5 || $2 != $6 || $3 != $7 || $4 != $8 || ($9 != 0 && $9 != 1) { bad = 1 }
       END { exit bad }' || fail "labels.txt does not repeat the events with a 0/1 label"

# The model came from the install: without it the same command says where it looked.
mv "$model" "$model.away"
if (cd "$work" && "$exe" segment --input ev.txt --out l2.txt) >"$work/log2" 2>&1; then
  fail "segment ran without the installed model"
fi
grep -q "share/spikems/models/spikems-default.safetensors" "$work/log2" ||
  { cat "$work/log2"; fail "the error does not name the install's model path"; }
echo "ok: the unpacked spikems $version runs and finds its installed model"
