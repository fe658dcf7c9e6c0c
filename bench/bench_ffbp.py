"""Fast formers for spherical data against backprojection, in one run (no assertions).

For each case, forms the image with backprojection at its default knobs (the baseline, timed in the
same run), ffbp at two settings, the sub-image NUFFT and ``--method auto`` at tolerances 1e-2,
1e-3, 1e-4, and prints a markdown table of

- the relative error against the exact matched filter (``direct``), on a strided sub-grid of pixels
  over the whole image when the full reference would be too slow (the stride is printed),
- the predicted error (each former's error model), the median wall time of ``--repeat`` runs after
  a warm-up, and the speed-up ``t(backprojection) / t(method)``.

Cases: the four GOTCHA files (100 m at 0.125 m, when ``sarcli.io.gotcha.gotcha_dir()`` holds them),
and a simulated circular collection at r0 = 10 km (``--synthetic NxP``, default 512x1024: N² pixels from
P pulses; the issue's 2048x2048 takes many minutes per backprojection on a loaded 2-core machine).

Usage::

    python bench/bench_ffbp.py [--synthetic 512x1024] [--no-gotcha] [--repeat 1] [--calibrate] [--skip subimage]

``--calibrate`` first re-measures the planner's reference cost model, the one shipped with the
package (``sarcli/formers/planning/cost_model.json``; a user's machine measures its own on first `sar plan`).
Runs as ``sar`` does: numpy's huge-page advice off (:func:`sarcli.cli.main.no_huge_pages`).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

from sarcli.cli.main import no_huge_pages

no_huge_pages()   # as `sar` runs, and as `sar plan --calibrate` measures (numpy reads it when first imported)

import numpy as np  # noqa: E402

from sarcli.analysis.accuracy import reference_grid  # noqa: E402
from sarcli.core import geometry  # noqa: E402
from sarcli.core.acquisition import Acquisition  # noqa: E402
from sarcli.core.grid import Grid  # noqa: E402
from sarcli.core.types import PhaseHistory  # noqa: E402
from sarcli.formers.formation import form_image, image_error  # noqa: E402
from sarcli.io.gotcha import gotcha_files  # noqa: E402



def timed(fn, repeat):
    out = fn()                                      # warm-up (compilation, plans)
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
    return out, statistics.median(ts)


def synthetic(n, p, seed=0):
    """N² pixels of 0.25 m from P pulses, r0 = 10 km, 30° elevation; frequency and pulse spacing
    alias-free over the grid's half-diagonal, bandwidth and aperture for ~0.3 m resolution."""
    half_diag = n * 0.25 / np.sqrt(2) * 1.1
    dalpha = geometry.C / (4 * half_diag)
    m = int(np.ceil(560e6 / dalpha))
    freq = 9.6e9 + dalpha * np.arange(m)
    span_rad = geometry.C / (4 * 9.9e9 * np.cos(np.radians(30)) * 0.3) * 2
    span_rad = min(span_rad, p * geometry.C / (4 * 9.9e9 * np.cos(np.radians(30)) * half_diag))
    az = np.linspace(-span_rad / 2, span_rad / 2, p)
    el = np.full(p, np.radians(30))
    a = geometry.antenna_positions_circle(az, el, 10e3)
    r0 = np.linalg.norm(a, axis=1)
    rng = np.random.default_rng(seed)
    half = 0.45 * n * 0.25
    pts = np.column_stack([rng.uniform(-half, half, 40), rng.uniform(-half, half, 40), np.zeros(40)])
    amp = rng.normal(size=40) + 1j * rng.normal(size=40)
    d = np.zeros((p, m), complex)
    for i in range(0, p, 64):
        dr = geometry.differential_range(a[i:i + 64], r0[i:i + 64], pts)
        d[i:i + 64] = (np.exp(-1j * 4 * np.pi / geometry.C * freq[None, :, None] * dr[:, None, :]) * amp).sum(-1)
    acq = Acquisition(freq, az, el, Grid(n, n, 0.25, 0.25), antenna_position_m=a, range_to_center_m=r0,
                      model="spherical", name=f"synthetic {n}x{p}")
    return PhaseHistory(d, acq), acq.grid


def run_case(name, ph, grid, repeat, max_ref_cost, skip=()):
    sub, rs, cs, cost = reference_grid(ph, grid, max_ref_cost)
    t0 = time.perf_counter()
    ref = form_image(ph, "direct", grid=sub).image
    t_ref = time.perf_counter() - t0
    stride = int(round(sub.dx / grid.dx))
    print(f"\n### {name}: {ph.data.shape[0]} pulses x {ph.data.shape[1]} frequencies -> {grid.nx} x {grid.ny} "
          f"pixels of {grid.dx:g} m\n")
    print(f"reference: direct on every {stride}th pixel ({sub.nx} x {sub.ny}), {t_ref:.3g} s\n")
    print("| method | knobs | error vs direct | predicted | seconds | speed-up vs backprojection |")
    print("|---|---|---|---|---|---|")
    settings = [("backprojection", {}), ("ffbp", {}), ("ffbp", {"os_range": 3, "os_angle": 3}),
                ("subimage", {"tolerance": 1e-2}),
                ("auto", {"tolerance": 1e-2}), ("auto", {"tolerance": 1e-3}), ("auto", {"tolerance": 1e-4})]
    t_bp = None
    for method, knobs in [s for s in settings if s[0] not in skip]:
        if method == "auto":   # a fall-back to direct is the reference itself (minutes to hours): reported, not run
            from sarcli.formers.planning.planner import recommend

            pick = recommend(ph, grid, knobs["tolerance"])
            if pick.method == "direct":
                print(f"| auto | tol {knobs['tolerance']:g} -> direct | not run | {pick.predicted_error:.2e} | "
                      f"{pick.seconds:.3g} (predicted) | |", flush=True)
                continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                img, sec = timed(lambda: form_image(ph, method, grid=grid, **knobs), repeat)
            except Exception as exc:  # noqa: BLE001 - a bench reports, it does not stop
                print(f"| {method} | {knobs} | failed: {exc} | | | |")
                continue
        err = image_error(img.image[np.ix_(rs, cs)], ref)
        t_bp = sec if method == "backprojection" else t_bp
        shown = dict(knobs)
        if method == "auto":
            shown = {"tol": knobs["tolerance"], "->": img.parameters["auto"]["choice"],
                     **img.parameters["auto"]["knobs"]}
            shown.pop("tolerance", None)
        pred = img.parameters.get("predicted_error", float("nan"))
        print(f"| {method} | {shown} | {err:.2e} | {pred:.2e} | {sec:.3g} | {t_bp / sec:.2f} |", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--synthetic", default="512x1024", help="NxP of the simulated case ('' to skip)")
    ap.add_argument("--no-gotcha", action="store_true")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--max-reference-cost", type=float, default=5e8)
    ap.add_argument("--calibrate", action="store_true", help="re-measure the planner's cost model first")
    ap.add_argument("--skip", default="", help="methods not to run, comma-separated (e.g. subimage: minutes on 2048^2)")
    args = ap.parse_args(argv)
    skip = tuple(m for m in args.skip.split(",") if m)
    from sarcli._native import simd_level, threads

    print(f"machine: {os.cpu_count()} cores, kernels on {threads()} threads ({simd_level()}); load average "
          f"{os.getloadavg()[0]:.1f} at start (a shared, loaded machine: compare ratios, not seconds)")
    if args.calibrate:
        from sarcli.formers.planning.calibration import COST_MODEL_PATH
        from sarcli.formers.planning.planner import calibrate

        print("cost model:", calibrate(COST_MODEL_PATH))
    files = gotcha_files()[:4]
    if files and not args.no_gotcha:
        from sarcli.io.gotcha import read_gotcha

        ph = read_gotcha([str(f) for f in files])
        run_case(f"GOTCHA, {len(files)} files, 100 m at 0.125 m", ph, Grid.from_extent(100.0, 0.125), args.repeat,
                 args.max_reference_cost, skip)
    if args.synthetic:
        n, p = (int(v) for v in args.synthetic.lower().split("x"))
        ph, grid = synthetic(n, p)
        run_case(f"simulated circle, r0 = 10 km, {n}^2 from {p} pulses", ph, grid, args.repeat,
                 args.max_reference_cost, skip)
    return 0


if __name__ == "__main__":
    sys.exit(main())
