# shellcheck shell=bash
# The steps the per-model recipes (recipes/<model>/run.sh) are made of; sourced, not run.
#
# Every stage trains in its own folder of the recipe's output folder OUT, from a stage config
# (recipes/*/NAME.toml) whose paths are relative to OUT: the weights it starts from
# (`same10/best.safetensors`), its teacher, and the data sets through OUT/data, a link to the
# data folder. A stage whose kept file is already there is skipped, so several recipes can
# share one OUT (the common stages then run once) and an interrupted recipe goes on where it
# stopped: a stage with a checkpoint resumes (`spikems train --resume`).
#
# Environment: SPIKEMS (the spikems binary; default build/spikems, else spikems on the PATH),
# DATA (the data sets of recipes/data.sh; default data/ of the repository), THREADS (CPU threads
# for every stage and score instead of each config's own), GPU_DEVICE (the device of the GPU
# stage; default cuda: `GPU_DEVICE=cpu` trains it on the CPU, about 16,000 samples).

# shellcheck source-path=SCRIPTDIR source=paths.sh
. "$(dirname "${BASH_SOURCE[0]}")/paths.sh"
GPU_DEVICE=${GPU_DEVICE:-cuda}

say() { printf '%s %s\n' "$(date +%H:%M:%S)" "$*" >&2; }
die() { printf '%s: %s\n' "$(basename "$0")" "$*" >&2; exit 1; }

# recipe_start SCRIPT ARGS...: --help, the output folder, the binary and the data link.
recipe_start() {
  local script=$1; shift
  if [ $# -ne 1 ] || [ "$1" = -h ] || [ "$1" = --help ] || [ -z "$1" ]; then
    [ $# -eq 1 ] && { [ "$1" = -h ] || [ "$1" = --help ]; } && usage_of "$script" 0
    usage_of "$script" 2
  fi
  mkdir -p "$1"
  OUT=$(cd "$1" && pwd)
  SPIKEMS=$(find_spikems) || exit 1
  local data=${DATA:-$REPO/data}
  [ -d "$data" ] || die "no data folder $data: make it with recipes/data.sh (or set DATA)"
  data=$(cd "$data" && pwd)
  if [ -L "$OUT/data" ]; then ln -sfn "$data" "$OUT/data"
  elif [ ! -e "$OUT/data" ]; then ln -s "$data" "$OUT/data"
  fi
  THREAD_ARGS=()
  if [ -n "${THREADS:-}" ]; then THREAD_ARGS=(--threads "$THREADS"); fi
  say "output folder $OUT, data $data, $SPIKEMS"
}

# stage CONFIG KEEP [train ARGS...]: trains recipes/CONFIG.toml into OUT/NAME (NAME = the
# config's name) unless OUT/NAME/KEEP is there; KEEP is the file the next stage starts from.
stage() {
  local rel=$1 config=$RECIPES/$1.toml keep=$2 name
  shift 2
  name=$(basename "$config" .toml)
  if [ -f "$OUT/$name/$keep" ]; then say "$name: kept ($name/$keep)"; return 0; fi
  if [ -f "$OUT/$name/checkpoint.pt" ]; then
    say "$name: resumed"
    (cd "$OUT" && "$SPIKEMS" train --resume "$name" -q "${THREAD_ARGS[@]}" "$@")
  else
    say "$name: training (recipes/$rel.toml)"
    (cd "$OUT" && "$SPIKEMS" train --config "$config" --out "$name" -q "${THREAD_ARGS[@]}" "$@")
  fi
  [ -f "$OUT/$name/$keep" ] || die "$name: no $name/$keep after training"
  say "$name: done ($name/$keep)"
}

# stage_until CONFIG STEP: as `stage`, stopped once the model of validation step STEP is kept
# (the config keeps one per validation: run.keep_val_models, run.val_every dividing STEP).
stage_until() {
  local config=$RECIPES/$1.toml step=$2 name pid
  name=$(basename "$config" .toml)
  local keep=val-step$step.safetensors
  if [ -f "$OUT/$name/$keep" ]; then say "$name: kept ($name/$keep)"; return 0; fi
  say "$name: training to step $step (recipes/$1.toml)"
  if [ -f "$OUT/$name/checkpoint.pt" ]; then
    (cd "$OUT" && exec "$SPIKEMS" train --resume "$name" -q "${THREAD_ARGS[@]}") &
  else
    (cd "$OUT" && exec "$SPIKEMS" train --config "$config" --out "$name" -q "${THREAD_ARGS[@]}") &
  fi
  pid=$!
  while kill -0 "$pid" 2>/dev/null && [ ! -f "$OUT/$name/$keep" ]; do sleep 5; done
  if [ -f "$OUT/$name/$keep" ]; then kill -TERM "$pid" 2>/dev/null || true; fi
  wait "$pid" || true
  [ -f "$OUT/$name/$keep" ] || die "$name: the run ended before step $step"
  say "$name: done ($name/$keep)"
}

# cut_skip FROM STAGE: STAGE/init.safetensors = FROM without the output layer's skip input
# (the skip from the first layer), the start of the `*-noskip` stages.
cut_skip() {
  [ -f "$OUT/$2/init.safetensors" ] && return 0
  mkdir -p "$OUT/$2"
  python3 "$RECIPES/common/drop_skip.py" "$OUT/$1" "$OUT/$2/init.safetensors" 11
  say "$2: init.safetensors = $1 without the output layer's skip"
}

# calibrate FROM MODEL [calibrate ARGS...]: OUT/MODEL = FROM at the output threshold the
# arguments choose on the validation rooms (data/mod5-val1s); the table in MODEL's .txt.
calibrate() {
  local from=$1 model=$2
  shift 2
  if [ -f "$OUT/$model" ]; then say "$model: kept"; return 0; fi
  (cd "$OUT" && "$SPIKEMS" calibrate --model "$from" --data data/mod5-val1s --split all "$@" \
    --threads "${THREADS:-1}" --quiet --out "$model" > "${model%.safetensors}.calibration.txt")
  say "$model: θ x $(awk -F'|' '/chosen/ {gsub(/ /, "", $2); print $2; exit}' \
    "$OUT/${model%.safetensors}.calibration.txt")"
}

# The static-budget rule: among the factors that call at most 5 % of the simulated static
# look-alike rooms' events moving, the one with the best event IoU on the validation rooms.
# shellcheck disable=SC2034  # used by the recipes that source this file
BUDGET=(--train-grid 173x130 --factors "1.4,1.45,1.5,1.55,1.6,1.65,1.7,1.75,1.8,1.85,1.9,1.95,2.0"
        --static data/lookalikesstatic-val-ds2 --max-static-moving 5)

# score MODEL: recipes/score.sh on OUT/MODEL into OUT/score.
score() {
  DATA=$OUT/data SPIKEMS=$SPIKEMS "$RECIPES/score.sh" "$OUT/$1" "$OUT/score"
}

# The stages every shipped model shares: the ANN-2D teacher, the spiking student on the CPU and
# the GPU, then same-step neurons at 5 and 10 ms (`full` continues from same10).
full_resolution_stages() {
  stage common/teacher best.safetensors
  stage_until common/snn-cpu 1616
  stage common/snn-gpu model.safetensors --device "$GPU_DEVICE"
  stage common/same5 best.safetensors
  stage common/same10 best.safetensors
}

# ... then half resolution without the outer skip, and the look-alike teachers (`default`,
# `fast` and `fine` continue from here).
half_resolution_stages() {
  full_resolution_stages
  stage common/teacher-half best.safetensors
  stage common/half best.safetensors
  cut_skip half/best.safetensors half-noskip
  stage common/half-noskip best.safetensors
  stage common/teacher-lookalikes best.safetensors
  stage common/teacher-lookalikes2 val-step1600.safetensors
}
