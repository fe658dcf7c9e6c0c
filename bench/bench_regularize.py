"""Cost of regularised reconstruction against FFT and NUFFT baselines (no assertions).

Prints markdown tables of, in one run (median of ``--repeat`` calls after a warm-up each):

1. one ADMM iteration (ptv, pre-gridded Toeplitz operator) vs two FFTs of size 2N × 2N
   (``scipy.fft``, complex128, same workers) at N = 512 and 1024 — target ratio ≤ 1.35;
2. the Toeplitz ``AᴴA`` vs a FINUFFT type-2 + type-1 pair at the same tolerance, with both
   errors against a tight (eps 1e-12) NUFFT pair — target speed-up ≥ 10;
3. iterations and seconds for ptv to reach relative change 1e-3 on ``configs/shepp-logan.yaml``.

The Toeplitz form costs two (3/4-size) FFTs of 2N × 2N whatever the number of samples; the NUFFT
pair's spreading grows with the samples, so the speed-up is reported for two sample counts.

Usage: ``python bench/bench_regularize.py [--sizes 512,1024] [--samples 512x512,2048x1024] [--eps 1e-6]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
import warnings
from pathlib import Path

import numpy as np
import scipy.fft

from sarcli.core import geometry
from sarcli.errors import ConvergenceWarning
from sarcli.core.grid import Grid
from sarcli.linops import NufftOperator, normal_equations, sparsifying_operator
from sarcli.regularize import DEFAULT_BETA_RATIO, DEFAULT_LAM, scale_problem
from sarcli.solvers import ADMM

REPO = Path(__file__).resolve().parents[1]
WORKERS = max(1, os.cpu_count() or 1)


def median_seconds(fn, repeat):
    """The median wall time of ``repeat`` calls of ``fn`` after one warm-up call."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _operator(n, P, M, eps):
    fc, bw = 10e9, 600e6
    freq = np.linspace(fc - bw / 2, fc + bw / 2, M)
    az = np.deg2rad(np.linspace(-2, 2, P))
    el = np.full(P, np.deg2rad(30.0))
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    rho_r, rho_cr = geometry.resolutions(freq, az, el)
    grid = Grid.square(n * min(rho_r, rho_cr) / 4, n)  # ~2 pixels per resolution cell
    return NufftOperator(kx, ky, grid, eps=eps), grid


def admm_vs_fft(sizes, P, M, eps, repeat):
    rows = []
    for n in sizes:
        op, grid = _operator(n, P, M, 1e-9)  # regularize's default: complex128 Toeplitz FFTs
        rng = np.random.default_rng(0)
        f_true = rng.standard_normal(grid.shape) + 1j * rng.standard_normal(grid.shape)
        b = op.forward(f_true)
        normal = normal_equations(op, b, form="toeplitz")
        scaled, _, _ = scale_problem(normal)
        lam = DEFAULT_LAM["ptv"]
        T = sparsifying_operator("ptv", grid.shape, f0=normal.atb)
        solver = ADMM(scaled, T, lam, DEFAULT_BETA_RATIO * lam, max_iter=10**6)
        solver.step()
        t_iter = median_seconds(solver.step, repeat)
        x = rng.standard_normal((2 * n, 2 * n)) + 1j * rng.standard_normal((2 * n, 2 * n))
        t_fft = median_seconds(lambda: scipy.fft.ifft2(scipy.fft.fft2(x, workers=WORKERS), workers=WORKERS), repeat)
        rows.append((n, t_iter, t_fft, t_iter / t_fft))
    print("\n### One ADMM iteration (ptv, Toeplitz, complex128) vs two 2N×2N complex128 FFTs\n")
    print("| N | ADMM iteration (ms) | two FFTs 2N×2N (ms) | ratio (target ≤ 1.35) |")
    print("|---|---|---|---|")
    for n, a, f, r in rows:
        print(f"| {n} | {1e3 * a:.1f} | {1e3 * f:.1f} | {r:.2f} |")


def toeplitz_vs_nufft(sizes, samples, eps, repeat):
    print(f"\n### AᴴA: Toeplitz embedding vs FINUFFT type-2 + type-1 pair (eps = {eps:g})\n")
    print("Toeplitz FFTs in complex64 (the default at eps ≥ 1e-6); complex128 column for reference.\n")
    print("| N | samples P×M | Toeplitz (ms) | NUFFT pair (ms) | speed-up (target ≥ 10) | err Toeplitz "
          "| err NUFFT pair | Toeplitz complex128 (ms) | kernel set-up (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n, (P, M) in ((n, pm) for pm in samples for n in sizes):
        op, grid = _operator(n, P, M, eps)
        rng = np.random.default_rng(1)
        f = rng.standard_normal(grid.shape) + 1j * rng.standard_normal(grid.shape)
        t0 = time.perf_counter()
        gram_t = op.toeplitz_gram()
        t_setup = time.perf_counter() - t0
        gram_n = op.gram()
        gram_d = op.toeplitz_gram(fft_dtype=np.complex128)
        t_t = median_seconds(lambda: gram_t.forward(f), repeat)
        t_d = median_seconds(lambda: gram_d.forward(f), repeat)
        t_n = median_seconds(lambda: gram_n.forward(f), repeat)
        ref_op, _ = _operator(n, P, M, 1e-12)
        ref = ref_op.adjoint(ref_op.forward(f))
        e_t = np.linalg.norm(gram_t.forward(f) - ref) / np.linalg.norm(ref)
        e_n = np.linalg.norm(gram_n.forward(f) - ref) / np.linalg.norm(ref)
        print(f"| {n} | {P}×{M} | {1e3 * t_t:.1f} | {1e3 * t_n:.1f} | {t_n / t_t:.1f} | {e_t:.1e} | {e_n:.1e} | {1e3 * t_d:.1f} | {t_setup:.2f} |")


def shepp_logan(tol):
    from sarcli.io.config import load_acquisition
    from sarcli.regularize import regularize
    from sarcli.simulation.simulator import simulate

    acq = load_acquisition(REPO / "configs" / "shepp-logan.yaml")
    ph = simulate(acq)
    rows = []
    for operator in ("toeplitz", "nufft"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            img = regularize(ph, prior="ptv", tol=tol, iters=1000, operator=operator)
        rel = img.history["relative_change"]
        reached = int(np.argmax(rel < tol)) + 1 if np.any(rel < tol) else None
        rows.append((operator, reached, img.history["elapsed_s"][reached - 1] if reached else np.nan,
                     img.runtime_s))
    print(f"\n### ptv on configs/shepp-logan.yaml ({acq.grid.nx}×{acq.grid.ny}): "
          f"iterations to relative change {tol:g}\n")
    print("| operator | iterations | solver seconds | total seconds (set-up + solve) |")
    print("|---|---|---|---|")
    for op, it, t, total in rows:
        print(f"| {op} | {it} | {t:.2f} | {total:.2f} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="512,1024")
    ap.add_argument("--samples", default="512x512,2048x1024",
                    help="pulses x frequencies, comma-separated (the first also for the ADMM timing)")
    ap.add_argument("--eps", type=float, default=1e-6)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--tol", type=float, default=1e-3)
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    samples = [tuple(int(v) for v in s.split("x")) for s in args.samples.split(",")]
    P, M = samples[0]
    print(f"workers: {WORKERS} (scipy.fft), FINUFFT default threads")
    admm_vs_fft(sizes, P, M, args.eps, args.repeat)
    toeplitz_vs_nufft(sizes, samples, args.eps, args.repeat)
    shepp_logan(args.tol)


if __name__ == "__main__":
    main()
