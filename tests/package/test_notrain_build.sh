#!/usr/bin/env bash
# ctest notrain_build (label slow): the whole build without LibTorch (-DSPIKEMS_WITH_TRAIN=OFF,
# what a robot installs) in its own folder, and its default tests. The default run covers the
# same configuration more cheaply: spikems-notrain and test_cli_notrain share the core's objects.
set -euo pipefail
src=$(cd "$(dirname "$0")/../.." && pwd)
dir=${1:?usage: test_notrain_build.sh BUILD_DIR}
cmake -S "$src" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DSPIKEMS_WITH_TRAIN=OFF \
  -DSPIKEMS_BUILD_BENCH=OFF >/dev/null
cmake --build "$dir" -j "$(nproc)"
ctest --test-dir "$dir" --output-on-failure -j "$(nproc)" -LE "slow|fuzz|python|install|browser"
