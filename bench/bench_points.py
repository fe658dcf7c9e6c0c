"""Backprojection at 3-D pixel positions (a map grid on terrain, ``bp_points``) beside the tiled
kernel on the plane (no assertions).

One collection: X band, 30° elevation, 10 km, ±3° of azimuth, 256 pulses x 256 frequencies, onto
192² pixels of 0.3 m; the points kernel's pixels carry a 5 m sinusoidal relief, the tiled kernel's
lie on the plane. Both at float32, Keys cubic, upsample 16, one thread, timed alternately A B A B; the median of the ratios is printed. Usage::

    python bench/bench_points.py [--repeat 5] [--n 192] [--pulses 256]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sarcli.core import geometry
from sarcli.core.grid import Grid
from sarcli.formers.backprojection import backproject
from sarcli.formers.points import backproject_points
from sarcli.core.collection import Collection
from sarcli.formers.options import BackprojectionOptions


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--n", type=int, default=192)
    ap.add_argument("--pulses", type=int, default=256)
    args = ap.parse_args()
    P, M, n = args.pulses, 256, args.n
    f = 9.6e9 + 1e6 * np.arange(M)
    az = np.radians(np.linspace(-3, 3, P))
    a = geometry.antenna_positions_circle(az, np.radians(30), 10e3)
    r0 = np.linalg.norm(a, axis=1)
    rng = np.random.default_rng(0)
    d = rng.standard_normal((P, M)) + 1j * rng.standard_normal((P, M))
    g = Grid(n, n, 0.3, 0.3)
    pts = g.points()
    pts[..., 2] = 5 * np.sin(pts[..., 0] / 7)
    col, kw = Collection(f, a, r0), BackprojectionOptions(upsample=16, interp="cubic", precision="float32")
    backproject(d, col, g, kw, nthreads=1)
    backproject_points(d, col, pts, kw, nthreads=1)
    ta, tb = [], []
    for _ in range(args.repeat):
        t = time.perf_counter()
        backproject(d, col, g, kw, nthreads=1)
        ta.append(time.perf_counter() - t)
        t = time.perf_counter()
        backproject_points(d, col, pts, kw, nthreads=1)
        tb.append(time.perf_counter() - t)
    ratio = float(np.median(np.array(tb) / np.array(ta)))
    print(f"tiled plane {np.median(ta):.3f} s, 3-D points {np.median(tb):.3f} s: points / tiled = {ratio:.2f}")


if __name__ == "__main__":
    main()
