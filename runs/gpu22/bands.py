#!/usr/bin/env python3
"""Mean IoU of `spikems eval` per room band: rooms split by the share of their events on the
moving objects (truly moving events / all events of the room, from results.csv's per-sequence
rows): < 2 %, 2-10 %, >= 10 %. Each room's IoU is its windows' mean; a band's figure is the
mean over its rooms (the earlier sessions' per-band figures; docs/results.md).

    python3 runs/gpu22/bands.py out/e22/NAME-m5/results.csv [WINDOW_MS]
"""
import csv
import sys

path = sys.argv[1]
window = float(sys.argv[2]) if len(sys.argv) > 2 else 20.0
rows = [r for r in csv.DictReader(open(path)) if r["level"] == "sequence"
        and float(r["window_ms"]) == window and r["iou_mean"] not in ("", None)
        and r["filter"] == ""]
bands = {"<2": [], "2-10": [], ">=10": []}
for r in rows:
    total = sum(int(r[k]) for k in ("events_tp", "events_fp", "events_fn", "events_tn"))
    share = 100.0 * (int(r["events_tp"]) + int(r["events_fn"])) / total if total else 0.0
    key = "<2" if share < 2 else ("2-10" if share < 10 else ">=10")
    bands[key].append(float(r["iou_mean"]))
print(" / ".join(f"{k}: {sum(v) / len(v):.1f} ({len(v)})" if v else f"{k}: - (0)"
                 for k, v in bands.items()))
