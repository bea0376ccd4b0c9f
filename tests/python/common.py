"""Shared by the interop tests: arguments from ctest, skipping, running spikems."""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

SKIP = 77  # ctest SKIP_RETURN_CODE (cmake/packaging.cmake)


def parse_args():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spikems", required=True)
    ap.add_argument("--dump-model", required=True)
    ap.add_argument("--source", required=True)
    return ap.parse_args()


def require(*modules):
    """Imports each module or exits with SKIP and says what to install."""
    got = []
    for m in modules:
        try:
            got.append(__import__(m))
        except ImportError:
            print(f"SKIPPED: Python module '{m}' missing for {sys.executable}; install "
                  f"python3-numpy python3-h5py (scripts/setup)")
            sys.exit(SKIP)
    return got


def run(*cmd):
    """Runs a command; its stdout, or a failure that shows the command and its stderr."""
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if r.returncode != 0:
        raise AssertionError(f"{' '.join(map(str, cmd))} exited {r.returncode}:\n{r.stderr}")
    return r.stdout


def info_json(spikems, path):
    return json.loads(run(spikems, "info", path, "--json"))[0]


class Scratch:
    """A temporary folder, removed on exit unless SPIKEMS_KEEP_SCRATCH is set."""

    def __enter__(self):
        self.path = tempfile.mkdtemp(prefix="spikems_py_")
        return self.path

    def __exit__(self, *exc):
        if not os.environ.get("SPIKEMS_KEEP_SCRATCH"):
            shutil.rmtree(self.path, ignore_errors=True)
