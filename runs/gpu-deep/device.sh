#!/usr/bin/env bash
# One command on a lent GPU (the workplace's device tool, 10-minute limit): build spikems against
# the machine's CUDA LibTorch, simulate the data, train three deep-SNN probes side by side on the
# one GPU, each stopped by --time-limit, and return the runs under $OUT. Run from the checkout:
#   runs/gpu-deep/device.sh [NAME='ARGS'...]   (.gpu/deps.tar.xz = scripts/pack_build_deps' folder
#       packed with xz; .gpu/spikems-nb.xz = a CPU-only spikems built here, xz-packed, which
#       simulates there while the CUDA build runs)
# Each NAME='ARGS' is one run of configs/train/deep.toml with those extra `spikems train`
# arguments (words split on spaces; at most 4 runs: $OUT returns 8 files). Without any, the
# tenth session's three (docs/results.md, "Tenth session"): the recipe, skips at levels 3-5 only,
# and tau_s = 2 ms everywhere; same data, seed, batch 8. Environment: DEADLINE (s, default 535),
# ROOMS (per training chunk, default 32), BATCH (8), WAIT_B (s: train without the second chunk
# if it is not made by then, default 290), CUDA_TESTS=1 (also build test_train and run the
# NeuronCuda tests beside the training: the fused kernels and the data-driven initialisation on
# the GPU against the CPU; log in $OUT/cuda-tests.log), CONFIG (default configs/train/deep.toml),
# SEED_A / SEED_B (the training rooms' seeds, default 41 / 43), ROOM_S (their length, 1.5s),
# STEPS (--steps, the learning-rate schedule's length; default 3000), VAL_EVERY (default 250),
# KEEP=1 (run.keep_val_models: every validation's model comes back, to be chosen here by
# held-out rooms and the real poster).
# STATIC=N: also N static rooms and N static posters with flat patches (20 % of the samples)
# and a static validation set (data.val_static); see static_sets below.
# STATIC_A / STATIC_B / VAL_STATIC: the static rooms' / posters' / static validation posters'
# configs (default runs/flat23/modstatic-flat.toml / poster-flat.toml / poster-flat.toml;
# runs/sizes24/*-sizes.toml: two cameras per set).
# SIM_A / SIM_B: the simulator's scene arguments for chunk a / b (default `--preset mod`; e.g.
# SIM_A="--config runs/flat23/mod-flat.toml": the same rooms as SEED_A's with flat patches;
# runs/sizes24/mod-flat-sizes.toml: the same with a camera drawn per room).
# The logs come back in $OUT/logs.tar.gz; a run larger than 15 MB packed comes back in parts
# (NAME.partK.tar.gz: unpack all of them into one folder).
# For a dry run on a CPU machine: SKIP_BUILD=<a spikems> DEVICE=cpu (EXTRA: more train arguments).
set -u
# Checked before any work: a malformed run would only fail after minutes of device time.
if [ $# -gt 4 ]; then echo "device.sh: at most 4 runs (\$OUT returns 8 files), got $#" >&2; exit 2; fi
for spec in "$@"; do
  if ! [[ $spec =~ ^[A-Za-z0-9_.-]+= ]]; then
    echo "device.sh: '$spec' is not NAME='ARGS' (NAME of letters, digits, '.', '_', '-')" >&2
    exit 2
  fi
done
T0=$SECONDS
OUT=${OUT:-/tmp/gpu-out}
mkdir -p "$OUT"
DEADLINE=${DEADLINE:-535}   # seconds after start by which training has stopped
ROOMS=${ROOMS:-32}          # rooms per training chunk (two chunks, seeds SEED_A and SEED_B)
# 41 and 43 by default (earlier calls); seed 41 makes the first 32 rooms of data/mod3-train (the
# simulator seeds each room by the global seed and its index): new seeds give new rooms.
SEED_A=${SEED_A:-41}
SEED_B=${SEED_B:-43}
ROOM_S=${ROOM_S:-1.5s}     # each training room's length: shorter rooms, more of them per minute
log() { echo "[$((SECONDS - T0)) s] $*" | tee -a "$OUT/main.log"; }
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader | tee -a "$OUT/main.log"
nproc | tee -a "$OUT/main.log"

python3 - <<'PY'
import lzma, shutil, tarfile, os
tarfile.open('.gpu/deps.tar.xz').extractall('/tmp/dp')
with lzma.open('.gpu/spikems-nb.xz') as f, open('/tmp/spikems-nb', 'wb') as g:
    shutil.copyfileobj(f, g)
os.chmod('/tmp/spikems-nb', 0o755)
PY
# shellcheck disable=SC1091
source /tmp/dp/deps/env.sh
log "deps unpacked"

TORCH=$(python3 -c 'import torch;print(torch.utils.cmake_prefix_path)' 2>/dev/null)
(
  [ -n "${SKIP_BUILD:-}" ] && { mkdir -p build-cuda; cp "$SKIP_BUILD" build-cuda/spikems; echo 0 >/tmp/build.rc; exit; }
  BUILD_DIR=build-cuda TARGET=spikems JOBS=16 scripts/build \
    -DCMAKE_PREFIX_PATH="$SPIKEMS_DEPS_PREFIX;$TORCH" -DCMAKE_CUDA_ARCHITECTURES=90 -DSPIKEMS_CUDA=ON \
    >"$OUT/build.log" 2>&1
  echo $? >/tmp/build.rc
) &
BPID=$!

SIM=/tmp/spikems-nb
if ! $SIM --version >>"$OUT/main.log" 2>&1; then
  log "the CPU-only spikems does not run here: simulating after the build"
  wait $BPID
  SIM=build-cuda/spikems
fi
mkdir -p data
sim() {  # name n duration seed [scene arguments, default --preset mod]
  # shellcheck disable=SC2086  # the scene arguments are words
  nice -n 5 $SIM simulate ${5:---preset mod} --sequences "$2" --duration "$3" --seed "$4" \
    --mask-period 10ms --no-progress --out "data/$1.partial" >>"$OUT/sim.log" 2>&1 &&
    mv "data/$1.partial" "data/$1" && log "made data/$1"
}
# STATIC=N: static scenes with flat patches too (runs/flat23): N rooms without objects (1 s,
# seed 95) and N posters (0.5 s, seed 97) as 20 % of the samples, and 8 posters (seed 601) that
# every validation scores as data.val_static (the log's static_moving).
static_sets() {
  [ -z "${STATIC:-}" ] && return 0
  sim gpu-static-a "$STATIC" 1s 95 "--config ${STATIC_A:-runs/flat23/modstatic-flat.toml}" &&
    sim gpu-static-b "$STATIC" 0.5s 97 "--config ${STATIC_B:-runs/flat23/poster-flat.toml}"
}
(sim mod2-val 8 1s 3001 && { [ -z "${STATIC:-}" ] || sim val-static 8 0.5s 601 "--config ${VAL_STATIC:-runs/flat23/poster-flat.toml}"; } &&
  sim gpu-train-a "$ROOMS" "$ROOM_S" "$SEED_A" "${SIM_A:-}" &&
  sim gpu-train-b "$ROOMS" "$ROOM_S" "$SEED_B" "${SIM_B:-}" && static_sets) &
SPID=$!

wait $BPID
log "build rc $(cat /tmp/build.rc)"
if [ "$(cat /tmp/build.rc)" != 0 ]; then
  tail -30 "$OUT/build.log"
  log "fused CUDA build failed: building with SPIKEMS_CUDA=OFF (LibTorch ops on the GPU)"
  BUILD_DIR=build-ops TARGET=spikems JOBS=16 scripts/build \
    -DCMAKE_PREFIX_PATH="$SPIKEMS_DEPS_PREFIX;$TORCH" -DSPIKEMS_CUDA=OFF >>"$OUT/build.log" 2>&1 ||
    { log "build failed"; tail -40 "$OUT/build.log"; exit 1; }
  B=build-ops/spikems
else
  B=build-cuda/spikems
fi
grep -i "fused CUDA" "$OUT/build.log" | tee -a "$OUT/main.log"
if [ -n "${CUDA_TESTS:-}" ] && [ "$B" = build-cuda/spikems ]; then  # the kernels against the CPU
  # Built after spikems and beside the training, so a failing test build never costs a run.
  (nice -n 10 cmake --build build-cuda -j 12 --target test_train >"$OUT/cuda-tests.log" 2>&1 &&
    build-cuda/test_train --gtest_filter='NeuronCuda.*' >>"$OUT/cuda-tests.log" 2>&1
   log "cuda tests rc $?: $(grep -E '^\[  (PASSED|FAILED)|^\[  SKIPPED' "$OUT/cuda-tests.log" | tr '\n' ' ')") &
fi

# Train as soon as validation and the first chunk exist; take the second if it is made by WAIT_B.
while [ ! -d data/gpu-train-a ] && kill -0 $SPID 2>/dev/null; do sleep 2; done
[ -d data/gpu-train-a ] || { log "no training data"; tail -20 "$OUT/sim.log"; exit 1; }
LAST=data/gpu-train-b
[ -n "${STATIC:-}" ] && LAST=data/gpu-static-b
while [ ! -d $LAST ] && [ $((SECONDS - T0)) -lt "${WAIT_B:-290}" ] && kill -0 $SPID 2>/dev/null; do sleep 2; done
if [ -d data/gpu-static-b ]; then
  TRAIN='data.train=[{path="data/gpu-train-a",split="all",weight=0.4},{path="data/gpu-train-b",split="all",weight=0.4},{path="data/gpu-static-a",split="all",weight=0.1},{path="data/gpu-static-b",split="all",weight=0.1}]'
elif [ -d data/gpu-train-b ]; then
  kill $SPID 2>/dev/null; pkill -f "simulate --config runs/" 2>/dev/null
  TRAIN='data.train=[{path="data/gpu-train-a",split="all"},{path="data/gpu-train-b",split="all"}]'
else
  kill $SPID 2>/dev/null; pkill -f "simulate --" 2>/dev/null
  TRAIN='data.train=[{path="data/gpu-train-a",split="all"}]'
fi
log "training on: $TRAIN"

nvidia-smi --query-gpu=timestamp,memory.used,utilization.gpu --format=csv -l 15 >"$OUT/smi.csv" 2>&1 &
LIM=$((DEADLINE - (SECONDS - T0) - 25))
[ "$LIM" -lt 30 ] && LIM=30   # late: still a short run rather than none
log "time limit ${LIM} s per run"
C=(--device "${DEVICE:-cuda}" --time-limit "${LIM}s" -q --steps "${STEPS:-3000}" --set optim.batch=${BATCH:-8} --set run.loader_threads=4
   --set run.val_every=${VAL_EVERY:-250} --set "$TRAIN")
[ -n "${KEEP:-}" ] && C+=(--set run.keep_val_models=true)
[ -d data/val-static ] && C+=(--set 'data.val_static=[{path="data/val-static"}]')
probe() {  # name extra-args...
  local name=$1; shift
  mkdir -p "runs/$name"
  $B train ${EXTRA:-} --config "${CONFIG:-configs/train/deep.toml}" --out "runs/$name" "${C[@]}" "$@" >"runs/$name/stdout.txt" 2>&1
  log "$name: rc $?, $(tail -c 300 "runs/$name/log.jsonl" | tail -1)"
}
if [ $# -eq 0 ]; then
  set -- gpu-deep-skips= "gpu-deep-skiplv=--set model.skip_levels=[3,4,5]" \
    "gpu-deep-tau2=--set model.tau_s=[2,2,2,2,2,2]"
fi
NAMES=()
PIDS=()
for spec in "$@"; do
  name=${spec%%=*}
  # shellcheck disable=SC2086  # the run's arguments are words
  probe "$name" ${spec#*=} &
  NAMES+=("$name")
  PIDS+=($!)
done
wait "${PIDS[@]}"
pkill -f "nvidia-smi" 2>/dev/null
log "training done; packing"
python3 - "$OUT" "${NAMES[@]}" <<'PY'
import os, sys, tarfile
out = sys.argv[1]
LIMIT = 15 << 20  # $OUT returns files of at most 16 MiB
def pack(name, files):
    with tarfile.open(f'{out}/{name}.tar.gz', 'w:gz') as t:
        for f in files:
            t.add(f, arcname=os.path.relpath(f, 'runs'))
for n in sys.argv[2:]:
    files = sorted(os.path.join(r, f) for r, _, fs in os.walk(f'runs/{n}') for f in fs)
    files = [f for f in files if not f.endswith('checkpoint.pt')]  # optimizer state: not needed here
    if any('/val-step' in f for f in files):  # best.safetensors is one of them
        files = [f for f in files if not f.endswith('/best.safetensors')]
    parts, cur, size = [], [], 0
    for f in files:  # model files barely compress: split by raw size
        s = os.path.getsize(f)
        if cur and size + s > LIMIT:
            parts.append(cur); cur, size = [], 0
        cur.append(f); size += s
    parts.append(cur)
    if len(parts) == 1:
        pack(n, parts[0])
    else:
        for k, p in enumerate(parts):
            pack(f'{n}.part{k}', p)
logs = [f for f in ('main.log', 'build.log', 'sim.log', 'smi.csv', 'cuda-tests.log')
        if os.path.exists(f'{out}/{f}')]
with tarfile.open(f'{out}/logs.tar.gz', 'w:gz') as t:
    for f in logs:
        t.add(f'{out}/{f}', arcname=f)
for f in logs:  # only 8 files come back
    os.remove(f'{out}/{f}')
PY
echo "[$((SECONDS - T0)) s] packed"
ls -la "$OUT"
