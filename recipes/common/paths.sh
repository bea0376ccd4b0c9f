# shellcheck shell=bash
# What every recipe script starts with; sourced, not run: RECIPES and REPO, its usage text, and
# the spikems binary.
RECIPES=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
REPO=$(dirname "$RECIPES")

# usage_of SCRIPT STATUS: SCRIPT's header comment (from line 2 to `set -euo`), then exit.
usage_of() { sed -n '2,/^set -euo/{/^set -euo/d;s/^# \{0,1\}//p}' "$1" >&2; exit "$2"; }

# find_spikems: the absolute path of $SPIKEMS, else of build/spikems, else of spikems on the
# PATH; fails naming what to do.
find_spikems() {
  local s=${SPIKEMS:-}
  if [ -z "$s" ] && [ -x "$REPO/build/spikems" ]; then s=$REPO/build/spikems; fi
  if [ -z "$s" ] || [[ $s != */* ]]; then
    s=$(command -v "${s:-spikems}") || {
      echo "$(basename "$0"): no spikems: build it (scripts/build) or set SPIKEMS" >&2
      return 1
    }
  fi
  echo "$(cd "$(dirname "$s")" && pwd)/$(basename "$s")"
}
