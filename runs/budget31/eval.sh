#!/usr/bin/env bash
# Scores a candidate of the thirty-first session's runs (runs/budget31/README.md) as the
# thirtieth session's were (runs/long30/eval.sh), into out/eval31.
# Usage: runs/budget31/eval.sh NAME MODEL [FACTOR] [FACTORS]
set -euo pipefail
cd "$(dirname "$0")/../.."
EVAL_OUT=out/eval31 exec runs/long30/eval.sh "$@"
