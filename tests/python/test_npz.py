"""An .npz written by `spikems convert` loads in numpy with the arrays docs/formats.md names:
a hand-written text file (exact values) and, with h5py, a simulated sequence (equal arrays)."""
import os

import common

args = common.parse_args()
(np,) = common.require("numpy")

with common.Scratch() as tmp:
    # Five events by hand, sensor 8 x 6; polarity 0/1, times in microseconds.
    txt = os.path.join(tmp, "ev.txt")
    with open(txt, "w") as f:
        f.write("# sensor 8 6\n1000 0 0 1\n1500 7 5 0\n2000 3 2 1\n2000 4 2 1\n9000 1 1 0\n")
    for compression in ("deflate", "none"):
        out = os.path.join(tmp, f"ev_{compression}.npz")
        common.run(args.spikems, "convert", txt, out, "--time-unit", "us", "--compression",
                   compression, "-q")
        with np.load(out) as z:
            assert {"t", "x", "y", "p", "sensor"} <= set(z.files), z.files
            assert z["t"].dtype == np.int64 and z["x"].dtype == np.uint16
            assert z["y"].dtype == np.uint16 and z["p"].dtype == np.uint8
            assert z["t"].tolist() == [1000, 1500, 2000, 2000, 9000]
            assert z["x"].tolist() == [0, 7, 3, 4, 1]
            assert z["y"].tolist() == [0, 5, 2, 2, 1]
            assert z["p"].tolist() == [1, 0, 1, 1, 0]
            assert z["sensor"].tolist() == [8, 6]

    # `segment --labels x.npy`: one uint8 per event, equal to the label column of --out x.npz.
    model = os.path.join(args.source, "models", "spikems-default.safetensors")
    ds = os.path.join(tmp, "seg")
    common.run(args.spikems, "simulate", "--preset", "tiny", "--sequences", "1", "--seed", "5",
               "--threads", "1", "--no-progress", "--out", ds)
    seq = os.path.join(ds, "seq_0000.h5")
    col, full = os.path.join(tmp, "col.npy"), os.path.join(tmp, "full.npz")
    common.run(args.spikems, "segment", "--quiet", "--model", model, "--input", seq,
               "--labels", col, "--out", full)
    c = np.load(col)
    with np.load(full) as z:
        assert c.dtype == np.uint8 and c.shape == z["label"].shape, (c.dtype, c.shape)
        assert np.array_equal(c, z["label"]) and c.size > 0

    try:
        import h5py
    except ImportError:
        print("note: h5py missing, the simulated-sequence case is skipped")
        h5py = None
    if h5py:
        ds = os.path.join(tmp, "ds")
        common.run(args.spikems, "simulate", "--preset", "tiny", "--sequences", "1", "--seed",
                   "3", "--threads", "1", "--no-progress", "--out", ds)
        h5 = os.path.join(ds, "seq_0000.h5")
        out = os.path.join(tmp, "seq.npz")
        common.run(args.spikems, "convert", h5, out, "-q")
        with h5py.File(h5, "r") as f, np.load(out) as z:
            for k in ("t", "x", "y", "p", "label"):
                a, b = f["events"][k][:], z[k]
                assert a.dtype == b.dtype and np.array_equal(a, b), k
            assert z["sensor"].tolist() == [int(f.attrs["sensor_width"]),
                                            int(f.attrs["sensor_height"])]
print("ok: spikems .npz files load in numpy with the documented arrays")
