#!/usr/bin/env python3
"""Uniform average of spikems model files of one architecture (a weight "soup").

    python3 runs/gpu21/average_models.py OUT.safetensors IN1.safetensors IN2.safetensors ...

A research helper of the twenty-first session (docs/results.md): reads the safetensors layout
(8-byte little-endian header length, JSON header, raw tensors), averages every float32 tensor
and writes OUT with the first input's header, metadata included (its name and training record
describe the first input, not the average). Standard library only.
"""
import json
import os
import struct
import sys
from array import array


def read(path):
    with open(path, 'rb') as f:
        data = f.read()
    n = struct.unpack('<Q', data[:8])[0]
    return json.loads(data[8:8 + n]), data[8 + n:]


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    out, inputs = sys.argv[1], sys.argv[2:]
    header, body = read(inputs[0])
    tensors = {k: v for k, v in header.items() if k != '__metadata__'}
    sums = {}
    for path in inputs:
        h, b = read(path)
        if {k for k in h if k != '__metadata__'} != set(tensors):
            sys.exit(f'{path}: not the same tensors as {inputs[0]}')
        for k, v in tensors.items():
            if h[k]['dtype'] != 'F32' or h[k]['shape'] != v['shape']:
                sys.exit(f'{path}: tensor {k} is not float32 of shape {v["shape"]}')
            lo, hi = h[k]['data_offsets']
            a = array('f')
            a.frombytes(b[lo:hi])
            s = sums.setdefault(k, [0.0] * len(a))
            for i, x in enumerate(a):
                s[i] += x
    body = bytearray(body)
    for k, v in tensors.items():
        lo, hi = v['data_offsets']
        body[lo:hi] = array('f', [x / len(inputs) for x in sums[k]]).tobytes()
    raw = json.dumps(header).encode()
    tmp = out + '.tmp'
    with open(tmp, 'wb') as f:
        f.write(struct.pack('<Q', len(raw)) + raw + bytes(body))
    os.replace(tmp, out)  # atomic: an existing OUT is never half-written


if __name__ == '__main__':
    main()
