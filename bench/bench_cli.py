"""Whole-process start-up cost of `sar`, as ratios against minimal baselines measured in the same run.

What a user pays per command is imports, compiled-kernel loads and file I/O, not only the
formation itself. Two pairs, each run alternately (A B A B ...) so a drifting machine load hits
both sides, medians of wall time reported with their ratio:

1. ``sar --help`` against ``python -c "import numpy, h5py"`` (target ≤ 2x);
2. ``sar form-image PH.h5 --method nufft --eps 1e-6`` against a minimal script doing the same read,
   the same finufft call and an HDF5 write (target ≤ 1.5x).

    python bench/bench_cli.py [--runs N]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
SAR = str(BIN / "sar")

MINIMAL = r'''
import sys, h5py, numpy as np, finufft
with h5py.File(sys.argv[1], "r") as f:
    d = f["phase_history"][()]; fr = f["frequency_hz"][()]; az = f["azimuth_rad"][()]; el = f["elevation_rad"][()]
    g = dict(f["grid"].attrs)
k = 4 * np.pi * fr[None, :] * np.cos(el)[:, None] / 299792458.0
kx, ky = k * np.cos(az)[:, None], k * np.sin(az)[:, None]
w = lambda t: t - 2 * np.pi * np.floor((t + np.pi) / (2 * np.pi))
img = finufft.nufft2d1(w(ky * g["dy"]).ravel(), w(kx * g["dx"]).ravel(), d.astype(complex).ravel(),
                       (int(g["ny"]), int(g["nx"])), eps=1e-6, isign=1) / d.size
with h5py.File(sys.argv[2], "w") as f:
    f["image"] = img
'''


def _time(cmd) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def pair(a, b, runs):
    """Alternate A and B ``runs`` times after one warm-up each; medians and the median ratio."""
    _time(a), _time(b)
    ta, tb = [], []
    for _ in range(runs):
        ta.append(_time(a))
        tb.append(_time(b))
    ratios = [x / y for x, y in zip(ta, tb)]
    return statistics.median(ta), statistics.median(tb), statistics.median(ratios)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7)
    args = ap.parse_args(argv)
    env_note = f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}"
    print(f"# bench_cli: whole-process wall time, medians of {args.runs} alternating runs ({env_note})")
    with tempfile.TemporaryDirectory() as tmp:
        ph, out1, out2 = Path(tmp) / "ph.h5", Path(tmp) / "img.h5", Path(tmp) / "min.h5"
        script = Path(tmp) / "minimal.py"
        script.write_text(MINIMAL)
        subprocess.run([SAR, "-q", "simulate", str(REPO / "configs" / "three-points.yaml"), "-o", str(ph),
                        "--model", "farfield"], check=True)
        rows = [
            ("sar --help", "python -c 'import numpy, h5py'", 2.0,
             pair([SAR, "--help"], [sys.executable, "-c", "import numpy, h5py"], args.runs)),
            ("sar form-image --method nufft --eps 1e-6", "minimal read + finufft + write", 1.5,
             pair([SAR, "-q", "form-image", str(ph), "-o", str(out1), "--method", "nufft", "--eps", "1e-6"],
                  [sys.executable, str(script), str(ph), str(out2)], args.runs)),
        ]
    print(f"{'command':<42} {'median s':>9} {'baseline':<34} {'median s':>9} {'ratio':>6} {'target':>7}")
    for a, b, target, (ta, tb, r) in rows:
        print(f"{a:<42} {ta:9.3f} {b:<34} {tb:9.3f} {r:6.2f} {'<= ' + str(target):>7}"
              f"  {'met' if r <= target else 'MISSED'}")


if __name__ == "__main__":
    main()
