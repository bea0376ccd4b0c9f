#!/usr/bin/env bash
# ctest pack_build_deps (label install): scripts/pack_build_deps packs the build dependencies into
# a folder that still works after a move (another machine), with every library reachable by its
# SONAME and no dangling link, and CMake configures spikems from it with the system prefix
# ignored (what a machine without the Debian packages sees; HDF5 excepted: it stays the
# target's own where the target has it, through its h5cc).
set -euo pipefail
src=$(cd "$(dirname "$0")/../.." && pwd)
fail() { echo "FAIL: $*" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$src/scripts/pack_build_deps" "$tmp/packed" >/dev/null
mv "$tmp/packed" "$tmp/moved"  # relocatable: env.sh finds itself
d=$tmp/moved
[ -f "$d/env.sh" ] || fail "no env.sh"
[ -z "$(find "$d/root" -xtype l)" ] || fail "dangling links: $(find "$d/root" -xtype l | head -3)"
lib=$d/root/usr/lib/x86_64-linux-gnu
for so in libtomlplusplus.so.3 libzip.so.4 liblz4.so.1 libpng16.so.16 libhdf5_serial.so.103; do
  [ -e "$lib/$so" ] || fail "$so missing"
done
[ -x "$d/root/usr/bin/flatc" ] || fail "flatc missing"
"$src/scripts/pack_build_deps" --help | grep -q "Usage" || fail "--help"
"$src/scripts/pack_build_deps" >/dev/null 2>&1 && fail "no argument accepted"
(
  source "$d/env.sh"
  [ "$SPIKEMS_DEPS_PREFIX" = "$d/root/usr" ] || fail "SPIKEMS_DEPS_PREFIX=$SPIKEMS_DEPS_PREFIX"
  [ "$(command -v pkg-config)" = "$d/root/usr/bin/pkg-config" ] || fail "packed pkg-config not first"
  pkg-config --cflags tomlplusplus | grep -q -- "-I$d/root/usr/include" || fail "pkg-config paths"
  # This machine has every library itself, so none is put on the loader's path.
  [ -z "$(ls "$d/missing")" ] || fail "libraries this machine has were linked: $(ls "$d/missing" | head -3)"
  cmake -S "$src" -B "$tmp/b" -G Ninja -DSPIKEMS_WITH_TRAIN=OFF -DSPIKEMS_BUILD_TESTS=OFF \
    -DSPIKEMS_BUILD_BENCH=OFF -DCMAKE_PREFIX_PATH="$SPIKEMS_DEPS_PREFIX" \
    -DCMAKE_IGNORE_PREFIX_PATH="/usr;/" >"$tmp/configure.log" 2>&1 ||
    { cat "$tmp/configure.log"; fail "configure"; }
  for v in nlohmann_json_DIR CLI11_DIR FLATC; do
    grep "^$v:" "$tmp/b/CMakeCache.txt" | grep -q "$d/root" || fail "$v not from the pack: $(grep "^$v:" "$tmp/b/CMakeCache.txt")"
  done
  grep -q "$d/root/usr/include" "$tmp/b/CMakeCache.txt" || fail "no packed include path"
)
echo "pack_build_deps: packed, moved, configured"
