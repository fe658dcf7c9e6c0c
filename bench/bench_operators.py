"""The regulariser's operators for spherical data, in one run (no assertions).

For each collection, one ``AᴴA`` product of

- the warped sub-aperture NUFFTs (``--operator warped``, sub-apertures chosen for ``--tolerance``),
- the exact reprojection/backprojection pair (``--operator spherical``),
- the far-field Toeplitz form (``--operator toeplitz``, fast but wrong on these grids),

median of ``--repeat`` products after a warm-up (the exact pair: one product), with each one's
relative difference from the exact pair's ``AᴴA x`` on a random image, the warped operator's
predicted error and its set-up time (fit, plans, kernels), and the far-field phase error at the
grid's corner. Collections: GOTCHA pass 1 HH, 4 files, 800² pixels of 0.125 m (skipped without the
files), a 1 km circle (X band, 4°, 512² of 0.1 m) and a 740 km orbit (X band, 2 s, 512² of 0.25 m).

    python bench/bench_operators.py [--tolerance 1e-3] [--repeat 3] [--only gotcha,near,orbit] [--images]

``--images``: also, per collection, ``regularize`` at a fixed λ (ptv, 0.02, 30 iterations, every
other option default) with the default operator and with the exact pair, and their images'
relative difference (the data: the exact model of a speckled disk with points, 10 dB noise; GOTCHA:
its own data).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.core.grid import Grid
from sarcli.io.gotcha import gotcha_files, read_gotcha
from sarcli.linops import NufftOperator, SphericalOperator
from sarcli.linops.warped import WarpedNufftOperator

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_regularize import median_seconds  # noqa: E402


def _acq(positions, freq, grid):
    az, el, r0 = geometry.angles_from_positions(positions)
    return Acquisition(freq, az, el, grid, antenna_position_m=positions, range_to_center_m=r0, model="spherical")


def near():
    R, e, P = 1000.0, np.radians(30.0), 1024
    th = np.radians(np.linspace(-2, 2, P))
    a = np.stack([R * np.cos(e) * np.cos(th), R * np.cos(e) * np.sin(th), np.full(P, R * np.sin(e))], 1)
    return _acq(a, np.linspace(9.7e9, 10.3e9, 512), Grid.square(25.6, 512)), "1 km circle, 4°, 1024 x 512 -> 512² of 0.1 m"


def orbit():
    R, e, P = 740e3, np.radians(45.0), 1024
    t = np.linspace(-1, 1, P)
    a = np.stack([np.full(P, R * np.cos(e)), 7500 * t, np.full(P, R * np.sin(e))], 1)
    return (_acq(a, np.linspace(9.45e9, 10.05e9, 1024), Grid.square(64.0, 512)),
            "740 km orbit, 2 s, 1024 x 1024 -> 512² of 0.25 m")


def gotcha():
    files = gotcha_files()[:4]
    if len(files) < 4:
        return None, "GOTCHA: skipped (files not found)"
    grid = Grid.from_extent(100, 0.125)
    return read_gotcha(files, grid=grid).acquisition, "GOTCHA pass 1 HH, 4 files -> 800² of 0.125 m"


def run(acq, label, tolerance, repeat):
    grid = acq.grid
    x = np.random.default_rng(0).standard_normal(grid.shape) + 1j * np.random.default_rng(1).standard_normal(grid.shape)
    t0 = time.perf_counter()
    warped = WarpedNufftOperator(acq, grid, tolerance=tolerance)
    gram_w = warped.gram()
    setup = time.perf_counter() - t0
    t_w = median_seconds(lambda: gram_w.forward(x), repeat)
    exact = SphericalOperator.from_acquisition(acq, grid)
    t0 = time.perf_counter()
    ref = exact.adjoint(exact.forward(x))
    t_s = time.perf_counter() - t0
    kx, ky = geometry.kspace_coordinates(acq.frequency_hz, acq.azimuth_rad, acq.elevation_rad)
    far = NufftOperator(kx, ky, grid, eps=1e-6).toeplitz_gram()
    t_f = median_seconds(lambda: far.forward(x), repeat)

    def diff(y):
        return float(np.linalg.norm(y - ref) / np.linalg.norm(ref))
    print(f"| {label} | {acq.farfield_phase_error(grid.half_diagonal):.3g} | {warped.subapertures} | "
          f"{warped.predicted_error:.2g} | {diff(gram_w.forward(x)):.2g} | {setup:.2f} | {t_w:.3f} | {t_s:.3f} | "
          f"**{t_s / t_w:.1f}** | {t_f:.3f} | {diff(far.forward(x)):.2g} |", flush=True)


def images(acq, label, data=None):
    """The default operator's fixed-λ image against the exact pair's (module docstring)."""
    from sarcli.core.types import PhaseHistory
    from sarcli.regularize import regularize

    grid = acq.grid
    if data is None:
        rng = np.random.default_rng(7)
        yy, xx = np.meshgrid(grid.y, grid.x, indexing="ij")
        r = np.hypot(xx, yy) / (0.4 * grid.half_diagonal)
        scene = np.where(r < 1, 0.3, 0.0) * np.exp(2j * np.pi * rng.random(grid.shape))
        scene[grid.ny // 3, grid.nx // 4] = scene[grid.ny // 2, 2 * grid.nx // 3] = 3.0
        data = SphericalOperator.from_acquisition(acq, grid).forward(scene)
        noise = rng.standard_normal(data.shape) + 1j * rng.standard_normal(data.shape)
        data = data + 0.1 * np.sqrt(np.mean(np.abs(data) ** 2) / 2) * noise
    ph = PhaseHistory(np.asarray(data), acq)
    kw = dict(prior="ptv", lam=0.02, iters=30, tol=1e-12)
    t0 = time.perf_counter()
    fast = regularize(ph, **kw)
    t_fast = time.perf_counter() - t0
    t0 = time.perf_counter()
    ref = regularize(ph, operator="spherical", **kw)
    t_ref = time.perf_counter() - t0
    p = fast.parameters
    d = float(np.linalg.norm(fast.image - ref.image) / np.linalg.norm(ref.image))
    print(f"| {label} | {p['operator']} ({p.get('subapertures', '-')}) | {d:.2g} | {t_fast:.1f} | {t_ref:.1f} |",
          flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerance", type=float, default=1e-3)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", default="gotcha,near,orbit")
    ap.add_argument("--images", action="store_true", help="also the fixed-λ images against the exact pair's")
    args = ap.parse_args(argv)
    print("| collection | far-field error at the corner (rad) | sub-apertures | predicted AᴴA error | warped vs exact "
          "| warped set-up s | warped AᴴA s | exact AᴴA s | exact / warped | Toeplitz AᴴA s | Toeplitz vs exact |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    makers = {"gotcha": gotcha, "near": near, "orbit": orbit}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in args.only.split(","):
            acq, label = makers[name]()
            if acq is None:
                print(f"| {label} | | | | | | | | | | |")
                continue
            run(acq, label, args.tolerance, args.repeat)
        if args.images:
            print("\n| collection | default operator (sub-apertures) | image vs exact pair's | default s | exact pair s |")
            print("|---|---|---|---|---|")
            for name in args.only.split(","):
                acq, label = makers[name]()
                if acq is None:
                    continue
                data = read_gotcha(gotcha_files()[:4], grid=acq.grid).data if name == "gotcha" else None
                images(acq, label, data)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
