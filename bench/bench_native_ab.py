"""The hot compiled kernels of two builds of sarcli, timed alternately in one run (no assertions).

Each round runs this script once under each interpreter (A B A B ...: two virtual environments
with their own builds of ``src/native``), one thread, ``$SARCLI_BP_ISA`` set for both; each run
reports every kernel's best CPU seconds of a few calls. The table is the median over rounds of
A's and B's seconds and the median of the rounds' ratios B/A. Usage::

    python bench/bench_native_ab.py A/.venv/bin/python B/.venv/bin/python [--rounds 5] [--isa 2,1] [--only bp/,points]

``$SARCLI_BP_ISA`` caps the backprojection family's copies only; the other families pick theirs by
the CPU.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

#: Kernel name -> (function of the prepared inputs), each a call of the public API.
CASES = ("bp/f32/cubic", "bp/f32/linear", "bp/f64/cubic", "bp/f32/lanczos", "bp-near/f32/cubic", "rp/f32/cubic",
         "points/f32/cubic", "ffbp/optimal", "ffbp/cubic", "ffbp/lanczos", "direct")


def _measure(repeat: int, only: str) -> dict[str, float]:
    from sarcli.core import geometry
    from sarcli.core.collection import Collection
    from sarcli.core.grid import Grid
    from sarcli.formers.backprojection import backproject, reproject
    from sarcli.formers.direct import direct_spherical
    from sarcli.formers.ffbp import ffbp
    from sarcli.formers.options import BackprojectionOptions
    from sarcli.formers.points import backproject_points

    freq = 9.7e9 + 2e6 * np.arange(256)

    def circle(P, r0, deg):
        az = np.radians(np.linspace(-deg / 2, deg / 2, P))
        a = geometry.antenna_positions_circle(az, np.radians(35), r0)
        return a, np.linalg.norm(a, axis=1)

    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(-20, 20, 8), rng.uniform(-20, 20, 8), np.zeros(8)])

    def data(a, r0):
        dr = geometry.differential_range(a, r0, pts)
        return np.exp(-1j * 4 * np.pi / geometry.C * freq[None, :, None] * dr[:, None, :]).sum(-1)

    grid = Grid(384, 384, 0.15, 0.15)
    a, r0 = circle(384, 5e3, 6.0)
    d = data(a, r0)
    an, rn = circle(128, 150.0, 20.0)
    dn = data(an, rn)
    col, f32 = Collection(freq, a, r0), BackprojectionOptions(precision="float32", interp="cubic")
    img = backproject(d, col, grid, f32)
    xyz = np.concatenate([np.stack(np.meshgrid(grid.x[::2], grid.y[::2]), -1),
                          np.zeros(grid.shape)[::2, ::2, None]], -1)
    calls = {
        "bp/f32/cubic": lambda: backproject(d, col, grid, f32),
        "bp/f32/linear": lambda: backproject(d, col, grid, BackprojectionOptions(precision="float32", interp="linear",
                                                                                 upsample=4)),
        "bp/f64/cubic": lambda: backproject(d, col, grid, BackprojectionOptions(precision="float64", interp="cubic")),
        "bp/f32/lanczos": lambda: backproject(d, col, grid, BackprojectionOptions(precision="float32", interp="lanczos")),
        "bp-near/f32/cubic": lambda: backproject(dn, Collection(freq, an, rn), grid, f32),
        "rp/f32/cubic": lambda: reproject(img, col, grid, f32),
        "points/f32/cubic": lambda: backproject_points(d, col, xyz, f32),
        "ffbp/optimal": lambda: ffbp(d, col, grid),
        "ffbp/cubic": lambda: ffbp(d, col, grid, interp="cubic", os_range=3, os_angle=3, upsample=8),
        "ffbp/lanczos": lambda: ffbp(d, col, grid, interp="lanczos", os_range=3, os_angle=2),
        "direct": lambda: direct_spherical(d[:, ::8], freq[::8], a, r0, Grid(64, 64, 0.8, 0.8)),
    }
    out = {}
    for name in _cases(only):
        calls[name]()   # warm-up
        best = np.inf
        for _ in range(repeat):
            t0 = time.process_time()
            calls[name]()
            best = min(best, time.process_time() - t0)
        out[name] = best
    return out


def _cases(only: str) -> list[str]:
    return [c for c in CASES if not only or any(c.startswith(o) for o in only.split(","))]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("python", nargs="*")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--isa", default="2,1")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", default="", help="the cases whose names start with one of these (comma-separated)")
    ap.add_argument("--child", action="store_true")
    args = ap.parse_args()
    if args.child:
        print(json.dumps(_measure(args.repeat, args.only)))
        return
    a, b = args.python
    print(f"A: {a}\nB: {b}\nload average at start: {os.getloadavg()[0]:.2f}")
    for isa in args.isa.split(","):
        env = {**os.environ, "OMP_NUM_THREADS": "1", "SARCLI_BP_ISA": isa}
        runs = {a: [], b: []}
        for _ in range(args.rounds):
            for py in (a, b):
                res = subprocess.run([py, __file__, "--child", "--repeat", str(args.repeat), "--only", args.only], env=env,
                                     capture_output=True, text=True, check=True)
                runs[py].append(json.loads(res.stdout.strip().splitlines()[-1]))
        print(f"\nSARCLI_BP_ISA={isa} ({args.rounds} rounds, best of {args.repeat} calls a run, CPU s)")
        print(f"{'kernel':20s} {'A s':>9s} {'B s':>9s} {'B/A':>7s} {'B/A range':>15s}")
        for name in _cases(args.only):
            ta = np.array([r[name] for r in runs[a]])
            tb = np.array([r[name] for r in runs[b]])
            q = tb / ta
            print(f"{name:20s} {np.median(ta):9.4f} {np.median(tb):9.4f} {np.median(q):7.3f} "
                  f"{q.min():7.3f}-{q.max():.3f}")
    print(f"\nload average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    sys.exit(main())
