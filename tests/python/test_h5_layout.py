"""A dataset simulated by spikems opens in h5py with the layout docs/formats.md (spikems-h5)
and docs/simulator.md document, and its event counts are those `spikems info` reports."""
import json
import os

import common

args = common.parse_args()
np, h5py = common.require("numpy", "h5py")

with common.Scratch() as tmp:
    out = os.path.join(tmp, "ds")
    common.run(args.spikems, "simulate", "--preset", "tiny", "--sequences", "2", "--seed", "7",
               "--threads", "1", "--no-progress", "--out", out)
    manifest = json.load(open(os.path.join(out, "manifest.json")))
    files = sorted(f for f in os.listdir(out) if f.endswith(".h5"))
    assert files == ["seq_0000.h5", "seq_0001.h5"], files
    for name in files:
        path = os.path.join(out, name)
        info = common.info_json(args.spikems, path)
        with h5py.File(path, "r") as f:
            # Root attributes.
            assert f.attrs["format"] == "spikems-h5", f.attrs["format"]
            assert int(f.attrs["format_version"]) == 1
            W, H = int(f.attrs["sensor_width"]), int(f.attrs["sensor_height"])
            assert (W, H) == (64, 48), (W, H)  # configs/sim/tiny.toml
            meta = json.loads(f.attrs["metadata_json"])
            assert meta["preset"] == "tiny", meta.get("preset")

            # Events: names, dtypes, one length, sorted, inside the sensor.
            ev = f["events"]
            want = {"t": np.int64, "x": np.uint16, "y": np.uint16, "p": np.uint8,
                    "label": np.uint16}
            for k, dt in want.items():
                assert ev[k].dtype == dt, (name, k, ev[k].dtype)
                assert ev[k].ndim == 1
            t, x, y, p, label = (ev[k][:] for k in ("t", "x", "y", "p", "label"))
            n = len(t)
            assert n > 1000, n
            assert all(len(a) == n for a in (x, y, p, label))
            assert (np.diff(t) >= 0).all(), "events not sorted by time"
            assert x.max() < W and y.max() < H
            assert set(np.unique(p)) <= {0, 1}

            # The same counts as spikems info and the manifest.
            assert info["format"] == "spikems-h5" and info["events"] == n, (info["events"], n)
            assert (info["width"], info["height"]) == (W, H)
            assert info["t_first_us"] == t[0] and info["t_last_us"] == t[-1]
            ids, counts = np.unique(label, return_counts=True)
            assert {str(int(i)): int(c) for i, c in zip(ids, counts)} == \
                {str(k): int(v) for k, v in info["events_per_label"].items()}, \
                info["events_per_label"]
            entry = [s for s in manifest["sequences"] if s["file"] == name]
            assert len(entry) == 1 and entry[0]["events"] == n, entry

            # Masks: one (H, W) uint16 frame per mask period (1 ms over 0.2 s).
            mt, masks = f["masks/t"][:], f["masks/ids"]
            assert mt.dtype == np.int64 and masks.dtype == np.uint16
            assert masks.shape == (len(mt), H, W), masks.shape
            assert 195 <= len(mt) <= 201, len(mt)
            assert (np.diff(mt) > 0).all()
            assert info["mask_frames"] == len(mt)
            # Every moving id is an object id of some event.
            moving = f["moving_ids"][:]
            assert moving.dtype == np.uint16 and len(moving) >= 1
            assert set(moving.tolist()) == set(info["moving_ids"])

            # Camera and poses (id 0 = camera).
            K = f["camera/intrinsics"][:]
            assert K.dtype == np.float64 and K.shape == (4,) and K[0] > 0 and K[1] > 0
            pt, pid = f["poses/t"][:], f["poses/id"][:]
            tr, rot = f["poses/translation"][:], f["poses/rotation"][:]
            P = len(pt)
            assert pt.dtype == np.int64 and pid.dtype == np.uint16
            assert tr.shape == (P, 3) and rot.shape == (P, 4) and 0 in pid
            assert np.allclose(np.linalg.norm(rot, axis=1), 1.0, atol=1e-9), "not unit quaternions"
print("ok: 2 simulated sequences match the documented spikems-h5 layout and spikems info")
