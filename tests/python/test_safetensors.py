"""The shipped model, read by the 20-line numpy reader of the safetensors layout
(safetensors_np.py, docs/model-format.md), has exactly the weights spikems loads."""
import json
import os
import subprocess

import common

args = common.parse_args()
(np,) = common.require("numpy")
from safetensors_np import read_safetensors  # noqa: E402 (needs numpy)

path = os.path.join(args.source, "models", "spikems-default.safetensors")
tensors, meta = read_safetensors(path)
assert meta["format"] == "spikems-model" and meta["version"] == "1", meta
spec = json.loads(meta["spec"])
layers = spec["layers"]
assert len(layers) >= 2

# Shapes from the spec: PyTorch layouts (conv [out, in, k, k], conv_transpose [in, out, k, k]).
for k, l in enumerate(layers):
    w = tensors[f"layers.{k}.weight"]
    a, b = l["out_channels"], l["in_channels"]
    if l["kind"] == "conv_transpose":
        a, b = b, a
    assert w.shape == (a, b, l["kernel"], l["kernel"]), (k, w.shape)
    assert w.dtype == np.float32 and np.isfinite(w).all() and np.abs(w).max() > 0
# Channels chain from layer to layer (a skip connection adds its source layer's channels after
# the predecessor's); the network takes the 2 polarities and gives one map or one per polarity
# (docs/model.md, docs/model-format.md).
assert layers[0]["in_channels"] == 2, layers[0]
assert layers[-1]["out_channels"] in (1, 2), layers[-1]
for k, (l0, l1) in enumerate(zip(layers, layers[1:])):
    skip = l1.get("skip_from")
    extra = layers[skip]["out_channels"] if skip is not None and skip >= 0 else 0
    assert l0["out_channels"] + extra == l1["in_channels"], (k + 1, l1)

# The same tensors, bit for bit, as spikems' loader gives them.
dump = json.loads(subprocess.run([args.dump_model, path], check=True, capture_output=True,
                                 text=True).stdout)
assert set(dump) == set(tensors), (sorted(dump), sorted(tensors))
for name, d in dump.items():
    ours = np.array(d["values"], dtype=np.float32).reshape(d["shape"])
    theirs = tensors[name]
    assert ours.shape == theirs.shape, name
    assert np.array_equal(ours.view(np.uint32), theirs.view(np.uint32)), name

# The reader is not fooled by a file it was not given: flipping one weight byte is seen.
tmp_flip = bytearray(open(path, "rb").read())
n = int.from_bytes(tmp_flip[:8], "little")
tmp_flip[8 + n + 4 * 7] ^= 0x40
with common.Scratch() as tmp:
    p2 = os.path.join(tmp, "flipped.safetensors")
    open(p2, "wb").write(tmp_flip)
    flipped, _ = read_safetensors(p2)
    changed = [k for k in tensors if not np.array_equal(tensors[k].view(np.uint32),
                                                        flipped[k].view(np.uint32))]
    assert len(changed) == 1, changed
count = sum(tensors[f"layers.{k}.weight"].size for k in range(len(layers)))
print(f"ok: {len(tensors)} tensors ({count} weights) equal spikems' own reading")
