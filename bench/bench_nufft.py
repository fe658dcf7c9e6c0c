"""Overhead of :func:`sarcli.formers.nufft.nufft_farfield` over the raw FINUFFT call it wraps.

Times the whole former (weighting, centre phase, wrapping, plan, transform, normalisation) and
``finufft.nufft2d1`` alone on the same prepared points with the same eps, in the same run
(medians of ``--repeat`` runs after a warm-up, the two calls alternating so load drift hits both), and prints a markdown table.

Usage: ``python bench/bench_nufft.py [--pulses 512] [--freqs 512] [--n 512] [--eps 1e-9]``
"""

from __future__ import annotations

import argparse
import statistics
import time

import finufft
import numpy as np

from sarcli.core import geometry
from sarcli.formers.nufft import FFTW_FLAGS, _wrap, nufft_farfield
from sarcli.core.grid import Grid


def _interleaved_medians(fa, fb, repeat):
    """Median times of two calls measured alternately, so load drift hits both equally."""
    fa(), fb()  # warm-up
    ta, tb = [], []
    for _ in range(repeat):
        for fn, acc in ((fa, ta), (fb, tb)):
            t0 = time.perf_counter()
            fn()
            acc.append(time.perf_counter() - t0)
    return statistics.median(ta), statistics.median(tb)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pulses", type=int, default=512)
    ap.add_argument("--freqs", type=int, default=512)
    ap.add_argument("--n", type=int, default=512, help="image side in pixels")
    ap.add_argument("--eps", type=float, default=1e-9)
    ap.add_argument("--repeat", type=int, default=21)
    ap.add_argument("--nthreads", type=int, default=None)
    args = ap.parse_args(argv)

    p, m = args.pulses, args.freqs
    az = np.deg2rad(50 + np.linspace(-1.5, 1.5, p))
    el = np.full(p, np.deg2rad(30))
    freq = 1e10 + np.linspace(-3e8, 3e8, m)
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    radius = 0.9 * min(geometry.alias_free_radii(freq, az, el))
    grid = Grid.square(radius, args.n, center=(1.0, -0.5))
    rng = np.random.default_rng(0)
    data = rng.standard_normal((p, m)) + 1j * rng.standard_normal((p, m))

    opts = {"fftw": FFTW_FLAGS["estimate"]}
    if args.nthreads is not None:
        opts["nthreads"] = args.nthreads
    k1 = np.ascontiguousarray(_wrap(kx.ravel() * grid.dx))
    k2 = np.ascontiguousarray(_wrap(ky.ravel() * grid.dy))
    c = np.ascontiguousarray(data.ravel())

    raw = lambda: finufft.nufft2d1(k2, k1, c, (grid.ny, grid.nx), eps=args.eps, isign=1, **opts)  # noqa: E731
    ours = lambda: nufft_farfield(data, kx, ky, grid, eps=args.eps, nthreads=args.nthreads)  # noqa: E731
    t_raw, t_sar = _interleaved_medians(raw, ours, args.repeat)
    print(f"## nufft_farfield vs raw finufft.nufft2d1 ({p} pulses x {m} freqs -> {grid.ny} x {grid.nx}, "
          f"eps {args.eps:g}, median of {args.repeat})\n")
    print("| call | median time (s) |")
    print("|---|---|")
    print(f"| finufft.nufft2d1 (plan included) | {t_raw:.4f} |")
    print(f"| sarcli nufft_farfield | {t_sar:.4f} |")
    print(f"\nratio sarcli / raw: {t_sar / t_raw:.2f}")


if __name__ == "__main__":
    main()
