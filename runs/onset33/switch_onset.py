#!/usr/bin/env python3
"""Writes a copy of a spikems model file with every layer's neuron `srm_onset` set
(docs/model-format.md), the weights untouched, and a note of the switch in its training
metadata. The thirty-third session's tool for trying a trained model with same-step neurons
without retraining (runs/onset33/README.md); `spikems train --set model.srm_onset=...` does the
same for a training run.
Usage: runs/onset33/switch_onset.py IN OUT same_step|next_step"""
import json
import os
import struct
import sys

if len(sys.argv) != 4 or sys.argv[3] not in ("same_step", "next_step"):
    sys.exit(__doc__)
src, dst, onset = sys.argv[1:]
raw = open(src, "rb").read()
if len(raw) < 8:
    sys.exit(f"{src}: not a safetensors file (shorter than its 8-byte header length)")
n = struct.unpack("<Q", raw[:8])[0]
if 8 + n > len(raw):
    sys.exit(f"{src}: truncated header ({n} bytes announced, {len(raw) - 8} present)")
header = json.loads(raw[8:8 + n])
meta = header.get("__metadata__", {})
if meta.get("format") != "spikems-model" or "spec" not in meta:
    sys.exit(f"{src}: not a spikems model file")
spec = json.loads(meta["spec"])
for layer in spec["layers"]:
    if onset == "next_step":
        layer["neuron"].pop("srm_onset", None)
    else:
        layer["neuron"]["srm_onset"] = onset
spec.setdefault("training", {})["srm_onset_switched"] = {
    "to": onset, "from_file": os.path.basename(src), "tool": "runs/onset33/switch_onset.py"}
meta["spec"] = json.dumps(spec)
body = json.dumps(header).encode()
body += b" " * ((8 - len(body) % 8) % 8)  # keep the tensors 8-byte aligned
tmp = dst + ".tmp"
with open(tmp, "wb") as f:  # atomic: a temporary file, then a rename
    f.write(struct.pack("<Q", len(body)) + body + raw[8 + n:])
os.replace(tmp, dst)
print(f"{dst}: {len(spec['layers'])} layers, srm_onset {onset}")
