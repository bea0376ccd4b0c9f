#!/usr/bin/env bash
# Compares two spikems binaries on `spikems segment --stats` with a real model and event file
# (compare_runtime.sh does the same for bench_runtime's synthetic networks): runs A, then B,
# REPS times, one thread each, and prints the medians of each and of the per-pair
# differences (B - A) of every layer's µs per step and of the network's real-time factor.
# Differences of runs taken seconds apart cancel most of a shared machine's drift. The two
# must label every event alike (checked: a speed-up that changes the output is a bug).
#
#   bench/compare_segment.sh 6 /tmp/spikems-old build/spikems \
#       models/spikems-default.safetensors data/mod2-heldout/seq_0000.h5
set -euo pipefail
usage() { sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'; }
if [[ ${1:-} == -h || ${1:-} == --help ]]; then
  usage
  exit 0
fi
if [[ $# -ne 5 ]]; then
  usage >&2
  exit 2
fi
reps=$1 a=$2 b=$3 model=$4 input=$5
if ! [[ $reps =~ ^[1-9][0-9]*$ ]]; then
  echo "compare_segment: REPS must be a positive integer, not '$reps'" >&2
  exit 2
fi
for f in "$a" "$b"; do [[ -x $f ]] || { echo "compare_segment: $f is not an executable" >&2; exit 1; }; done
for f in "$model" "$input"; do [[ -r $f ]] || { echo "compare_segment: cannot read $f" >&2; exit 1; }; done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for ((r = 0; r < reps; ++r)); do
  for f in "$a" "$b"; do
    tag=$([[ $f == "$a" ]] && echo a || echo b)
    "$f" segment --model "$model" --input "$input" --stats --quiet --threads 1 \
      --out "$tmp/labels_$tag.txt" >"$tmp/stats.txt" 2>&1 ||
      { cat "$tmp/stats.txt" >&2; exit 1; }
    python3 - "$tmp/stats.txt" >>"$tmp/rows.txt" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
layers = [float(l.split()[-1]) for l in text.splitlines() if re.match(r"^\d+\s+\d+\s", l)]
m = re.search(r"network only ([0-9.]+)", text)
if not layers or not m:
    sys.exit("compare_segment: no per-layer table or real-time factor in --stats output")
print(" ".join("%.3f" % v for v in layers + [float(m.group(1))]))
PY
    printf '.' >&2
  done
  cmp -s "$tmp/labels_a.txt" "$tmp/labels_b.txt" ||
    { echo "compare_segment: A and B label the events differently" >&2; exit 1; }
done
echo >&2
python3 - "$tmp/rows.txt" "$a" "$b" <<'PY'
import statistics, sys
rows = [list(map(float, l.split())) for l in open(sys.argv[1])]
A, B = rows[0::2], rows[1::2]
n = len(A[0]) - 1
med = statistics.median
print("µs per step, medians of %d alternated runs (the last column: network real-time factor)" % len(A))
print("%-6s" % "" + "".join("%9s" % ("L%d" % (k + 1)) for k in range(n)) + "%9s" % "total" + "%9s" % "RT x")
for label, R in (("A", A), ("B", B)):
    cols = list(zip(*R))
    print("%-6s" % label + "".join("%9.1f" % med(c) for c in cols[:n]) +
          "%9.1f" % med([sum(r[:n]) for r in R]) + "%9.3f" % med(cols[n]))
d = [[y - x for x, y in zip(ra[:n], rb[:n])] for ra, rb in zip(A, B)]
print("%-6s" % "B - A" + "".join("%+9.1f" % med(c) for c in zip(*d)) +
      "%+9.1f" % med([sum(r) for r in d]))
ra, rb = med(r[n] for r in A), med(r[n] for r in B)
print("network real-time factor: A %.3fx, B %.3fx (B/A %.3f; median of pair ratios %.3f)"
      % (ra, rb, rb / ra, med(y[n] / x[n] for x, y in zip(A, B))))
print("A = %s, B = %s" % (sys.argv[2], sys.argv[3]))
PY
