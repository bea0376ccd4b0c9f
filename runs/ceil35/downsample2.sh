#!/usr/bin/env bash
# data/NAME -> data/NAME-ds2: every sequence at half resolution (spikems convert --downsample 2),
# the manifest copied with the halved sensor. Usage: runs/ceil35/downsample2.sh NAME...
set -euo pipefail
cd "$(dirname "$0")/../.."
for d in "$@"; do
  S=data/$d; D=data/$d-ds2; mkdir -p $D
  for f in $S/*.h5; do build/spikems convert $f $D/$(basename $f) --downsample 2 -q; done
  python3 - "$S" "$D" <<'PY'
import json,sys
s,d=sys.argv[1:]
m=json.load(open(f'{s}/manifest.json'))
w,h=m['sensor']; nw,nh=w//2,h//2
m['sensor']=[nw,nh]
for q in m.get('sequences',[]): q['sensor']=[nw,nh]
m['config']=str(m.get('config',''))+'; convert --downsample 2'
json.dump(m,open(f'{d}/manifest.json','w'),indent=1)
PY
done
