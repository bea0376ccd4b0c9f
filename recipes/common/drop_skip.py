#!/usr/bin/env python3
"""Removes one decoder layer's skip input from a spikems model file (docs/model-format.md):
the layer keeps the input channels of the layer before it (the first in_channels - C_skip rows
of its weight: the concatenation puts the previous layer first, then the skip) and loses
`skip_from`. The recipes cut the output layer's skip from the first layer (LAYER 11, 0-based)
before the `full-noskip` and `half-noskip` stages.

Usage: recipes/common/drop_skip.py IN.safetensors OUT.safetensors LAYER   (LAYER 0-based)
"""
import json
import os
import struct
import sys


def main(src, dst, layer):
    raw = open(src, 'rb').read()
    n = struct.unpack('<Q', raw[:8])[0]
    header = json.loads(raw[8:8 + n])
    body = raw[8 + n:]
    spec = json.loads(header['__metadata__']['spec'])
    lay = spec['layers'][layer]
    skip = lay.get('skip_from')
    if skip is None:
        sys.exit(f'layer {layer} has no skip input')
    c_skip = spec['layers'][skip]['out_channels']
    keep = lay['in_channels'] - c_skip
    lay['in_channels'] = keep
    del lay['skip_from']
    header['__metadata__']['spec'] = json.dumps(spec, separators=(',', ':'))
    # Tensors in their file order; the edited one cut to its first `keep` rows (dim 0 is the
    # input channel of a transposed convolution, [in, out, k, k], and the output channel of a
    # convolution, [out, in, k, k]: only the transposed case is handled here).
    if lay['kind'] != 'conv_transpose':
        sys.exit('only a transposed convolution layer is handled')
    name = f'layers.{layer}.weight'
    out, offset = {}, 0
    tensors = sorted((k for k in header if k != '__metadata__'),
                     key=lambda k: header[k]['data_offsets'][0])
    chunks = []
    for k in tensors:
        t = header[k]
        b, e = t['data_offsets']
        data = body[b:e]
        if k == name:
            row = len(data) // t['shape'][0]
            data = data[:keep * row]
            t['shape'][0] = keep
        t['data_offsets'] = [offset, offset + len(data)]
        offset += len(data)
        chunks.append(data)
        out[k] = t
    out['__metadata__'] = header['__metadata__']
    h = json.dumps(out, separators=(',', ':')).encode()
    h += b' ' * ((8 - len(h) % 8) % 8)
    tmp = dst + '.tmp'
    with open(tmp, 'wb') as f:  # a temporary file, then a rename: never a half-written model
        f.write(struct.pack('<Q', len(h)) + h + b''.join(chunks))
    os.replace(tmp, dst)


if __name__ == '__main__':
    if len(sys.argv) != 4 or sys.argv[1] in ('-h', '--help'):
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]))
