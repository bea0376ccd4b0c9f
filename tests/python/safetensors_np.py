"""A numpy reader of the safetensors layout (docs/model-format.md), independent of spikems' C++
reader and of the `safetensors` package: 8-byte little-endian header length N, N bytes of JSON,
then the tensors' bytes at their data_offsets. docs/python.md shows the same code."""
import json
import struct

import numpy as np

DTYPES = {"F32": "<f4", "F64": "<f8", "I32": "<i4", "I64": "<i8", "U8": "u1", "U16": "<u2"}


def read_safetensors(path):
    """(tensors: name -> numpy array, metadata: dict of strings)."""
    with open(path, "rb") as f:
        data = f.read()
    (n,) = struct.unpack("<Q", data[:8])
    header = json.loads(data[8:8 + n])
    meta = header.pop("__metadata__", {})
    body = memoryview(data)[8 + n:]
    tensors = {}
    for name, t in header.items():
        begin, end = t["data_offsets"]
        a = np.frombuffer(body[begin:end], dtype=DTYPES[t["dtype"]])
        tensors[name] = a.reshape(t["shape"])
    return tensors, meta
