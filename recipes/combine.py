#!/usr/bin/env python3
"""One line per `spikems eval` results.json: the figures pooled over all its data sets.

Rooms (the held-out rooms of two seeds): IoU and detection per window length, each data set's
mean weighted by its windows, and event precision / recall from the summed event counts.
Static scenes (`eval --static-scene`, every event background): the share of events called
moving per scene and window length, and over all scenes weighted by their events.

Usage: recipes/combine.py RESULTS.json ...
"""
import json
import sys


def rooms(d):
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
    return "; ".join(parts)


def static(d):
    parts = []
    for wl in d["windows_ms"]:
        called = total = 0
        scenes = []
        for m in d["models"]:
            for ds in m["datasets"]:
                name = ds["data"].rsplit("/", 1)[-1]
                for w in ds["windows"]:
                    c = w.get("event_counts")
                    if w["window_ms"] != wl or not c or c["fp"] + c["tn"] == 0:
                        continue
                    called, total = called + c["fp"], total + c["fp"] + c["tn"]
                    scenes.append(f"{name} {100 * c['fp'] / (c['fp'] + c['tn']):.1f}")
        if total:
            parts.append(f"{wl:g} ms: " + ", ".join(scenes) +
                         f"; all weighted by their events {100 * called / total:.1f} % moving")
    return "; ".join(parts)


if __name__ == "__main__":
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
        sys.exit(__doc__)
    for path in sys.argv[1:]:
        d = json.load(open(path))
        print(path + ": " + (static(d) if d.get("static_scene") else rooms(d)))
