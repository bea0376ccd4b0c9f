#!/usr/bin/env python3
"""Window-weighted figures over all datasets of `spikems eval` results.json files (the 48
held-out rooms: seeds 6001 and 6002), one line per file: IoU and detection at each window
length, event precision / recall from the summed event counts.
Usage: runs/lookalike39/combine.py out/eval39/NAME/rooms/results.json ..."""
import json
import sys

for path in sys.argv[1:]:
    d = json.load(open(path))
    parts = []
    for wl in d["windows_ms"]:
        n = iou = det = 0.0
        tp = fp = fn = 0
        for m in d["models"]:
            for ds in m["datasets"]:
                for w in ds["windows"]:
                    if w["window_ms"] != wl or w["windows"] == 0:
                        continue
                    n += w["windows"]
                    iou += w["iou_mean"] * w["windows"]
                    det += w["detection_rate"] * w["windows"]
                    c = w["event_counts"]
                    tp, fp, fn = tp + c["tp"], fp + c["fp"], fn + c["fn"]
        if n:
            parts.append(f"{wl:g} ms: IoU {iou / n:.1f} det {det / n:.1f} "
                         f"P/R {100 * tp / max(tp + fp, 1):.1f}/{100 * tp / max(tp + fn, 1):.1f} "
                         f"({int(n)} windows)")
    print(path + ": " + "; ".join(parts))
