#!/usr/bin/env bash
# Wall time of whole shell commands, alternated: runs each command once per round (A, B, ...
# in order), REPS rounds, and prints per command the median wall time and its ratio to the
# first command's (the baseline). Alternating cancels most of a shared machine's drift; each
# command's output goes to /dev/null, and a command that fails stops the comparison.
#
#   bench/compare_wall.sh 5 'build/spikems-torch --version' 'build/spikems --version'
set -euo pipefail
usage() { sed -n '2,7p' "$0" | sed 's/^# \{0,1\}//'; }
if [[ ${1:-} == -h || ${1:-} == --help ]]; then
  usage
  exit 0
fi
if [[ $# -lt 3 ]]; then
  usage >&2
  exit 2
fi
reps=$1
shift
if ! [[ $reps =~ ^[1-9][0-9]*$ ]]; then
  echo "compare_wall: REPS must be a positive integer, not '$reps'" >&2
  exit 2
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for ((r = 0; r < reps; ++r)); do
  for ((i = 1; i <= $#; ++i)); do
    cmd=${!i}
    t0=$(date +%s.%N)
    bash -c "$cmd" >/dev/null 2>"$tmp/err" || {
      echo "compare_wall: failed: $cmd" >&2
      cat "$tmp/err" >&2
      exit 1
    }
    t1=$(date +%s.%N)
    echo "$i $t0 $t1" >>"$tmp/times"
    printf '.' >&2
  done
done
echo >&2
python3 - "$tmp/times" "$@" <<'PY'
import statistics, sys
rows = [l.split() for l in open(sys.argv[1])]
cmds = sys.argv[2:]
wall = {i + 1: [] for i in range(len(cmds))}
for i, a, b in rows:
    wall[int(i)].append(float(b) - float(a))
base = statistics.median(wall[1])
print("%-8s %10s %10s %10s  %s" % ("", "median s", "min s", "vs 1st", "command"))
for i, c in enumerate(cmds, 1):
    m = statistics.median(wall[i])
    print("%-8s %10.3f %10.3f %9.2fx  %s" % ("cmd %d" % i, m, min(wall[i]), base / m, c))
print("(%d alternated rounds; 'vs 1st': the first command's median time / this one's)" % len(wall[1]))
PY
