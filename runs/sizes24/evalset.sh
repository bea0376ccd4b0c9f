#!/usr/bin/env bash
# evalset.sh NAME MODEL: real poster (10, 20 ms), the 240 x 180 flat posters and 240 x 180 rooms.
set -u
S=${SPIKEMS:-build/spikems}
n=$1; m=$2
$S eval --model "$m" --data ../shared/data/formats/poster_translation.npz --static-scene --windows 10,20 --threads 1 --quiet --out out/e24/$n-poster > /dev/null 2>&1 || echo "fail poster $n"
$S eval --model "$m" --data data/posterflat240-sim601 --split all --static-scene --windows 20 --threads 1 --quiet --out out/e24/$n-pf240 > /dev/null 2>&1 || echo "fail pf240 $n"
$S eval --model "$m" --data data/mod240-val604 --split all --windows 20 --threads 1 --quiet --out out/e24/$n-m240 > /dev/null 2>&1 || echo "fail m240 $n"
echo "done $n"
