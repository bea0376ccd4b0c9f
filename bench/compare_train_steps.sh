#!/usr/bin/env bash
# Seconds per `spikems train` step of the hybrid recipe (configs/train/hybrid.toml at 5 ms
# steps, starting from INIT with TEACHER's distillation, batch 4, whole frames), one short run
# per variant, alternated over ROUNDS rounds; prints each variant's median over rounds of the
# median step time (steps 3 onwards: the first two include start-up) and its ratio to the first
# variant. A variant is `KERNELS[:THREADS[:ENV=VALUE,...]]`, e.g. dense:2 or auto:2:OPENBLAS_NUM_THREADS=4.
# INIT: the spiking model file to start from (the hybrid recipe's network, trained at 5 ms steps
# with the same-step onset: its firing rates set the sparse kernels' work);
# TEACHER: an ANN-2D model file of the same widths (loss.teacher; configs/train/hybrid.toml).
#
#   bench/compare_train_steps.sh DATA INIT TEACHER ROUNDS STEPS VARIANT...
#   bench/compare_train_steps.sh data/mod2-heldout INIT TEACHER 2 12 dense:2 sparse:2 auto:2 auto:1
set -euo pipefail
usage() { sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'; }
if [[ ${1:-} == -h || ${1:-} == --help ]]; then
  usage
  exit 0
fi
if [[ $# -lt 6 ]]; then
  usage >&2
  exit 2
fi
data=$1 init=$2 teacher=$3 rounds=$4 steps=$5
shift 5
[[ -f $data/manifest.json ]] || { echo "compare_train_steps: $data is not a simulator folder" >&2; exit 2; }
for f in "$init" "$teacher"; do
  [[ -f $f ]] || { echo "compare_train_steps: $f: no such model file" >&2; exit 2; }
done
[[ $rounds =~ ^[1-9][0-9]*$ && $steps =~ ^[1-9][0-9]*$ && $steps -ge 4 ]] ||
  { echo "compare_train_steps: ROUNDS >= 1 and STEPS >= 4 (whole numbers)" >&2; exit 2; }
SPIKEMS=${SPIKEMS:-build/spikems}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
run() {  # run VARIANT OUT
  local kernels threads envs
  IFS=: read -r kernels threads envs <<<"$1"
  local -a env_args=()
  [[ -n ${envs:-} ]] && IFS=, read -ra env_args <<<"$envs"
  env "${env_args[@]}" "$SPIKEMS" train --config configs/train/hybrid.toml -q \
    --set "model.init=\"$init\"" --set 'model.init_ann=""' \
    --set 'model.srm_onset="same_step"' --set sample.step_ms=5 \
    --set "run.threads=${threads:-2}" --set "run.kernels=\"$kernels\"" \
    --set "data.train=[{path=\"$data\",split=\"all\"}]" --set "data.val=[{path=\"$data\",split=\"all\"}]" \
    --set "loss.teacher=\"$teacher\"" \
    --set run.val_every=100000 --set run.val_samples=0 --set run.val_full_s=0 \
    --set run.log_every=1 --set run.checkpoint_every=100000 --set optim.batch=4 \
    --steps "$steps" --out "$2" >/dev/null 2>"$2.err" || { cat "$2.err" >&2; exit 1; }
}
for ((r = 0; r < rounds; ++r)); do
  for ((i = 1; i <= $#; ++i)); do
    run "${!i}" "$tmp/r$r-v$i"
    printf '.' >&2
  done
done
echo >&2
python3 - "$tmp" "$rounds" "$@" <<'EOF'
import json, statistics, sys
tmp, rounds, variants = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
def step_time(d):
    w = [l["wall_s"] for l in map(json.loads, open(d + "/log.jsonl")) if l.get("kind") == "train"]
    return statistics.median(b - a for a, b in zip(w[2:], w[3:]))
med = [statistics.median(step_time(f"{tmp}/r{r}-v{i + 1}") for r in range(rounds))
       for i in range(len(variants))]
print(f"{'variant':40s} {'s/step':>8s} {'vs first':>9s}")
for v, m in zip(variants, med):
    print(f"{v:40s} {m:8.3f} {med[0] / m:8.2f}x")
EOF
