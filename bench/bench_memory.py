"""Peak memory of one image formation as a multiple of the image (and phase-history) bytes.

Runs in its own process per method (peak resident set above the level after a warm-up call,
from /proc/self/status VmHWM after resetting it), so the allocations of compiled libraries
(FINUFFT's fine grid, FFT work arrays) count, which tracemalloc cannot see. Target (issue 13):
every method <= 3 x (phase history + image) bytes.

    python bench/bench_memory.py N METHOD ["{'eps': 1e-9}"]      # one measurement
    python bench/bench_memory.py                                 # the table at 2048² and 4096²
"""

from __future__ import annotations

import gc
import subprocess
import sys

import sarcli
from sarcli.core.grid import Grid


def _status(key: str) -> float:
    """A /proc/self/status memory figure in MiB (VmRSS now, VmHWM the high-water mark)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key):
                return int(line.split()[1]) / 1024
    raise RuntimeError(f"{key} not in /proc/self/status")


def one(n, method, kw):
    from pathlib import Path

    cfg = Path(__file__).resolve().parents[1] / "configs" / "three-points.yaml"
    acq = sarcli.load_acquisition(cfg).with_(grid=Grid.square(5.0, n))
    ph = sarcli.simulate(acq, seed=1, model="farfield", snr_db=None)
    sarcli.form_image(ph, method, grid=Grid.square(1.0, 64), **kw)   # warm: kernels, plans
    gc.collect()
    # reset the high-water mark
    open("/proc/self/clear_refs", "w").write("5")
    base = _status("VmRSS")
    img = sarcli.form_image(ph, method, **kw)
    peak = _status("VmHWM") - base
    imgb, phb = img.image.nbytes / 2**20, ph.data.nbytes / 2**20
    print(f"{method} {kw} {n}²: peak above start {peak:.0f} MiB = {peak/imgb:.2f} x image ({imgb:.0f} MiB), "
          f"{peak/(imgb+phb):.2f} x (PH {phb:.0f} + image)")


if __name__ == "__main__":
    import ast

    if len(sys.argv) > 2:
        one(int(sys.argv[1]), sys.argv[2], ast.literal_eval(sys.argv[3]) if len(sys.argv) > 3 else {})
    else:
        for n in (2048, 4096):
            for method, kw in (("pfa", "{}"), ("nufft", "{'eps': 1e-9}"), ("nufft", "{'eps': 1e-3}")):
                subprocess.run([sys.executable, __file__, str(n), method, kw], check=True)
