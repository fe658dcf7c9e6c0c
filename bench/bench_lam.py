"""Automatic λ (``lam='auto'``, discrepancy principle) against the best λ of a sweep.

Scenes (generated here, seeded): random-phase piecewise-constant (three shapes) and Shepp-Logan,
each pixel a scatterer of the scene's magnitude and a uniform random phase; SNR 5, 10 and 20 dB
(noise power σ² = mean|d|² / 10^(SNR/10)); far-field data (NUFFT of the pixel model, eps 1e-12)
and spherical data (1 km stand-off: far-field phase error ≫ 0.1 rad at the grid corner, so
``operator='auto'`` picks the spherical pair). The noise power is NOT given to the regulariser
(``attrs`` empty): ``lam='auto'`` estimates it from the data.

For each scene: magnitude error ``‖|f| − |t|‖ / ‖t‖`` of the matched filter and of ptv, tv and
l1 with default settings (λ auto), the λ chosen, and the best λ and its error over a sweep of
λ values; prints one markdown table. Small grids (40 pixels far-field, 24 spherical; the spherical sweep for ptv only) keep it to a few minutes on two
cores. No assertions; ``tests/test_regparam.py`` asserts a reduced version.

Usage: ``python bench/bench_lam.py [--quick] [--priors ptv,tv,l1] [--no-sweep] [--geometry far-field]
[--kinds shapes,shepp,points] [--reestimate-every N]``
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from sarcli.core.acquisition import Acquisition
from sarcli.core.grid import Grid
from sarcli.core.types import PhaseHistory
from sarcli.simulation.scenes import shepp_logan

SWEEP = tuple(float(v) for v in np.geomspace(1.0, 1e-3, 7))


def acquisition(n: int = 40, pixel_m: float = 0.25, spherical: bool = False) -> Acquisition:
    """10 GHz, 300 MHz, 6° aperture, 48 frequencies, 64 pulses (spherical: 32, to keep the
    backprojection pair cheap), n × n pixels of ``pixel_m``."""
    grid = Grid.square(n * pixel_m / 2, n)
    fc, bw, M, P = 10e9, 300e6, 48, (32 if spherical else 64)
    freq = np.linspace(fc - bw / 2, fc + bw / 2, M)
    az = np.deg2rad(np.linspace(-3, 3, P))
    el = np.full(P, np.deg2rad(30.0))
    if not spherical:
        return Acquisition(freq, az, el, grid)
    r0 = 1000.0
    pos = r0 * np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)
    return Acquisition(freq, az, el, grid, antenna_position_m=pos, model="spherical")


def magnitude(kind: str, grid: Grid) -> np.ndarray:
    """Magnitude on the pixel centres: 'shapes', 'shepp' (piecewise constant) or 'points' (sparse)."""
    X, Y = np.meshgrid(grid.x, grid.y)
    h = 0.5 * grid.nx * grid.dx
    u, v = X / h, Y / h
    if kind == "shepp":
        return shepp_logan(u / 0.95, v / 0.95)
    if kind == "points":  # sparse: 12 unit scatterers on pixel centres (the scene l1 suits)
        mag = np.zeros(X.shape)
        idx = np.random.default_rng(99).choice(X.size, 12, replace=False)
        mag.flat[idx] = 1.0
        return mag
    mag = np.zeros(X.shape)
    mag[(np.abs(u + 0.4) < 0.4) & (np.abs(v - 0.3) < 0.3)] = 1.0
    mag[(u - 0.45) ** 2 + (v + 0.4) ** 2 < 0.45**2] = 0.6
    mag[(np.abs(u - 0.25) < 0.2) & (np.abs(v - 0.7) < 0.2)] = 0.3
    return mag


def scene(kind: str = "shapes", snr_db: float = 10.0, *, spherical: bool = False, n: int = 40,
          seed: int = 0, noise_attr: bool = False):
    """(PhaseHistory, truth magnitude) of a random-phase piecewise-constant scene."""
    from sarcli.linops import NufftOperator, SphericalOperator

    acq = acquisition(n, spherical=spherical)
    grid = acq.grid
    rng = np.random.default_rng(seed)
    mag = magnitude(kind, grid)
    values = mag * np.exp(1j * rng.uniform(-np.pi, np.pi, grid.shape))
    if spherical:
        d = SphericalOperator.from_acquisition(acq, grid).forward(values)
    else:
        kx, ky = acq.kspace()
        d = NufftOperator(kx, ky, grid, eps=1e-12).forward(values)
    sigma2 = float(np.mean(np.abs(d) ** 2)) / 10 ** (snr_db / 10)
    d = d + np.sqrt(sigma2 / 2) * (rng.standard_normal(d.shape) + 1j * rng.standard_normal(d.shape))
    attrs = {"noise_power": sigma2} if noise_attr else {}
    return PhaseHistory(d, acq, attrs=attrs), mag


def mag_error(f, truth) -> float:
    return float(np.linalg.norm(np.abs(f) - truth) / np.linalg.norm(truth))


def evaluate(ph, truth, priors=("ptv", "tv", "l1"), sweep=SWEEP, reestimate_every=0, sweep_priors=None):
    """Errors of the matched filter and of each prior at λ auto and over the sweep."""
    from sarcli.errors import ConvergenceWarning
    from sarcli.regularize import matched_filter, regularize

    op = "spherical" if ph.model == "spherical" else "nufft"
    out = {"mf": mag_error(matched_filter(ph, operator=op), truth)}
    for prior in priors:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            t0 = time.perf_counter()
            img = regularize(ph, prior=prior, reestimate_every=reestimate_every)
            secs = time.perf_counter() - t0
            sel = img.parameters.get("lam_selection", {})
            row = {"err": mag_error(img.image, truth), "lam": img.parameters["lam"], "s": secs,
                   "status": sel.get("status"), "sigma2": sel.get("noise_power")}
            if sweep and (sweep_priors is None or prior in sweep_priors):
                errs = [mag_error(regularize(ph, prior=prior, lam=lam, reestimate_every=reestimate_every).image,
                                  truth) for lam in sweep]
                i = int(np.argmin(errs))
                row.update(best_lam=sweep[i], best_err=errs[i])
        out[prior] = row
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="10 dB only, 32 pixels")
    ap.add_argument("--priors", default="ptv,tv,l1")
    ap.add_argument("--no-sweep", action="store_true")
    ap.add_argument("--reestimate-every", type=int, default=0, help="ptv: re-estimate Θ every N iterations")
    ap.add_argument("--geometry", choices=("both", "far-field", "spherical"), default="both")
    ap.add_argument("--kinds", default="shapes,shepp,points")
    a = ap.parse_args(argv)
    priors = tuple(a.priors.split(","))
    snrs = (10.0,) if a.quick else (5.0, 10.0, 20.0)
    n = 32 if a.quick else 40
    sweep = () if a.no_sweep else SWEEP
    hdr = "| scene | geometry | SNR dB | MF | " + " | ".join(
        f"{p} auto (λ) | {p} best of sweep (λ)" for p in priors) + " | ptv/MF |"
    print(hdr)
    print("|" + "---|" * (hdr.count("|") - 1))
    t0 = time.perf_counter()
    geoms = {"both": (False, True), "far-field": (False,), "spherical": (True,)}[a.geometry]
    for kind in a.kinds.split(","):
        for spherical in geoms:
            for snr in snrs:
                ph, truth = scene(kind, snr, spherical=spherical, n=24 if spherical else n)
                # the spherical pair costs ~20x the Toeplitz form: sweep ptv only there
                r = evaluate(ph, truth, priors, sweep, a.reestimate_every, ("ptv",) if spherical else None)
                cells = []
                for p in priors:
                    cells.append(f"{r[p]['err']:.3f} ({r[p]['lam']:.3g})")
                    cells.append(f"{r[p]['best_err']:.3f} ({r[p]['best_lam']:.3g})" if "best_err" in r[p] else "–")
                ratio = f"{r['ptv']['err'] / r['mf']:.2f}" if "ptv" in r else "–"
                print(f"| {kind} | {'spherical' if spherical else 'far-field'} | {snr:g} | {r['mf']:.3f} | "
                      + " | ".join(cells) + f" | {ratio} |", flush=True)
    print(f"\n{time.perf_counter() - t0:.0f} s in all")


if __name__ == "__main__":
    main()
