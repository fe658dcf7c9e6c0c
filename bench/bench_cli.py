"""Whole-process start-up cost of `sar`, as ratios against minimal baselines measured in the same run.

What a user pays per command is imports, compiled-kernel loads and file I/O, not only the
formation itself. Two pairs, each run alternately (A B A B ...) so a drifting machine load hits
both sides, medians of wall time reported with their ratio:

1. ``sar --help`` against ``python -c "import numpy, h5py"`` (target ≤ 2x);
2. ``sar form-image PH.h5 --method nufft --eps 1e-6`` against a minimal script doing the same read,
   the same finufft call and an HDF5 write (target ≤ 1.5x);
3. with the AFRL GOTCHA files (pass 1 HH, 4 files, 100 m at 0.125 m: 800²), ``sar form-image``
   with ``--method auto`` and ``--method backprojection``: the whole process's wall time less the
   image's own ``runtime_s`` (imports, kernel loads, planning, I/O) against
   ``python -c "import numpy, h5py"`` (target ≤ 2x); and the very first of those runs, before any
   warm-up, against the median of the later ones (nothing is compiled at run time: target ≤ 1.2x);
4. auto's planning on the same GOTCHA grid at the default tolerance, in a fresh process (its
   modules imported first, the planning timed alone; minimum over the runs): target ≤ 20 ms; its
   CPU time too (``time.process_time``), which a loaded machine inflates less than wall time.

    python bench/bench_cli.py [--runs N]

GOTCHA files: ``sarcli.io.gotcha.gotcha_dir()`` ($SARCLI_GOTCHA_DIR, else ../shared/data/gotcha beside the
repository); rows 3 are skipped with a note without them.
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

from sarcli.io.gotcha import gotcha_dir, gotcha_files

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


GOTCHA_DIR = gotcha_dir()


#: The children run as a user's commands do: bytecode caches written and read (a shell that sets
#: PYTHONDONTWRITEBYTECODE would have every sarcli module compiled from source at every command).
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def _time(cmd) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=ENV)
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


def overhead_pair(cmd, out, base, runs):
    """``cmd`` (writing the image ``out``) less its image's ``runtime_s`` against ``base``, alternated:
    medians of both and of their ratio, and the first run (no warm-up) over the median full run."""
    import h5py

    def once():
        wall = _time(cmd)
        with h5py.File(out, "r") as f:
            return wall, wall - float(f.attrs["runtime_s"])

    first, _ = once()
    _time(base)
    walls, over, tb = [], [], []
    for _ in range(runs):
        w, o = once()
        walls.append(w)
        over.append(o)
        tb.append(_time(base))
    ratio = statistics.median([x / y for x, y in zip(over, tb)])
    return statistics.median(over), statistics.median(tb), ratio, first / statistics.median(walls)


PLAN = r'''
import sys, time
import sarcli
from sarcli.core.grid import Grid
from sarcli.formers import ffbp, subimage, backprojection
from sarcli.formers.planning import planner
ph = sarcli.read_phase_history(sys.argv[1])
grid = Grid.from_extent(100, 0.125)
t, c = time.perf_counter(), time.process_time()
planner.recommend(ph, grid, 1e-3)
print(time.perf_counter() - t, time.process_time() - c)
'''


def planning_row(ph, runs):
    """Auto's planning in fresh processes: the minima over ``runs`` of its wall and CPU times (s)."""
    ts = [subprocess.run([sys.executable, "-c", PLAN, str(ph)], check=True, capture_output=True, text=True,
                         env=ENV).stdout.split()[-2:] for _ in range(runs)]
    return min(float(w) for w, _ in ts), min(float(c) for _, c in ts)


def gotcha_rows(tmp, runs):
    files = gotcha_files(GOTCHA_DIR)[:4]
    if len(files) < 4:
        print(f"(no GOTCHA files in {GOTCHA_DIR}: set SARCLI_GOTCHA_DIR; GOTCHA rows skipped)")
        return []
    ph, out = Path(tmp) / "gotcha.h5", Path(tmp) / "gotcha-img.h5"
    subprocess.run([SAR, "-q", "import", "gotcha", *map(str, files), "-o", str(ph)], check=True, env=ENV)
    base = [sys.executable, "-c", "import numpy, h5py"]
    rows = []
    for method in ("auto", "backprojection"):
        cmd = [SAR, "-q", "form-image", str(ph), "-o", str(out), "--method", method, "--extent", "100",
               "--pixel-size", "0.125"]
        over, tb, ratio, first = overhead_pair(cmd, out, base, runs)
        rows.append((f"GOTCHA 800² --method {method}: wall - runtime_s", "python -c 'import numpy, h5py'", 2.0,
                     (over, tb, ratio)))
        rows.append((f"  its first run / later runs (whole process)", "", 1.2, (first, 1.0, first)))
    plan_s, plan_cpu = planning_row(ph, runs)
    rows.append(("GOTCHA 800² auto's planning (s, min)", "20 ms", 1.0, (plan_s, 0.02, plan_s / 0.02)))
    rows.append(("  its CPU time (s, min)", "20 ms", 1.0, (plan_cpu, 0.02, plan_cpu / 0.02)))
    return rows


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
        rows += gotcha_rows(tmp, args.runs)
    print(f"{'command':<42} {'median s':>9} {'baseline':<34} {'median s':>9} {'ratio':>6} {'target':>7}")
    for a, b, target, (ta, tb, r) in rows:
        print(f"{a:<42} {ta:9.3f} {b:<34} {tb:9.3f} {r:6.2f} {'<= ' + str(target):>7}"
              f"  {'met' if r <= target else 'MISSED'}")


if __name__ == "__main__":
    main()
