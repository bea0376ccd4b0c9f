#!/usr/bin/env bash
# Compares two builds of bench_runtime on a machine whose speed drifts (shared VMs): runs A,
# then B, REPS times, and prints the medians of each and of the per-pair differences (B - A)
# of every layer's µs per step and of the whole step. Differences of runs taken a few seconds
# apart cancel most of the drift that separate runs of A and B would carry.
#
#   bench/compare_runtime.sh 6 /tmp/bench_runtime_old build/bench_runtime \
#       'StreamingSegmentSparseIir/10/'
set -euo pipefail
usage() { sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//'; }
if [[ ${1:-} == -h || ${1:-} == --help ]]; then
  usage
  exit 0
fi
if [[ $# -lt 3 ]]; then
  usage >&2
  exit 2
fi
reps=$1 a=$2 b=$3 filter=${4:-StreamingSegmentSparseIir/10/}
if ! [[ $reps =~ ^[1-9][0-9]*$ ]]; then
  echo "compare_runtime: REPS must be a positive integer, not '$reps'" >&2
  exit 2
fi
for f in "$a" "$b"; do [[ -x $f ]] || { echo "compare_runtime: $f is not an executable" >&2; exit 1; }; done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for ((r = 0; r < reps; ++r)); do
  for f in "$a" "$b"; do
    "$f" --benchmark_filter="$filter" --benchmark_format=json >"$tmp/run.json" 2>/dev/null
    python3 - "$tmp/run.json" >>"$tmp/rows.txt" <<'PY'
import json, sys
runs = json.load(open(sys.argv[1]))["benchmarks"]
if not runs or "realtime_x" not in runs[0]:
    sys.exit("compare_runtime: the filter must select one pipeline benchmark "
             "(BM_StreamingSegment...), which reports realtime_x")
x = runs[0]
layers = [x.get("us_step_L%d" % k, 0.0) for k in range(1, 7)]
print(" ".join("%.3f" % v for v in layers + [1000.0 / x["realtime_x"]]))
PY
    printf '.' >&2
  done
done
echo >&2
python3 - "$tmp/rows.txt" "$a" "$b" <<'PY'
import statistics, sys
rows = [list(map(float, l.split())) for l in open(sys.argv[1])]
A, B = rows[0::2], rows[1::2]
names = ["L1", "L2", "L3", "L4", "L5", "L6", "step"]
def line(label, cols, fmt):
    print("%-10s" % label + "".join(("%8s" % n) + (fmt % statistics.median(c)).rjust(8) for n, c in zip(names, cols)))
print("µs per step, medians of %d alternated runs" % len(A))
line("A", zip(*A), "%.1f")
line("B", zip(*B), "%.1f")
line("B - A", zip(*[[y - x for x, y in zip(ra, rb)] for ra, rb in zip(A, B)]), "%+.1f")
sa, sb = statistics.median(r[-1] for r in A), statistics.median(r[-1] for r in B)
print("real time factor: A %.2fx, B %.2fx (B/A %.3f)   A = %s, B = %s" % (1000 / sa, 1000 / sb, sa / sb, sys.argv[2], sys.argv[3]))
PY
