"""Automatic λ (``lam='auto'``) against the best λ of a sweep, on two families of scenes.

Family ``disk`` (the default; ``--family disk``): scenes that fill the alias-free disk, so no range
bin lies outside the scene and ``lam='auto'`` has no noise estimate: it uses generalised
cross-validation. 64 pulses x 64 frequencies, 10 GHz, 700 MHz, 4° aperture, 30° elevation (range
and cross-range alias-free radii 7.8 and 7.5 m); the image grid is the one derived from the
sampling (pixel = resolution / 2, half width = the alias-free radius: 124 x 124 pixels). Kinds:
'shapes' (random-phase piecewise constant: a disk of magnitude 0.35 filling the alias-free disk
with three shapes of 1, 0.65 and 0.15 in it), 'shepp' (Shepp-Logan filling the disk) and
'points' (40 unit scatterers at random positions in the disk, sparse); each synthesised as point
scatterers on a 4x finer grid (16 per pixel) with a uniform random phase per fine cell (the
paper's model, section ``sec:rand``); the truth is the block mean of the fine magnitudes. Far-field
data (type-2 NUFFT of the fine grid) or spherical data (exact sum, 1 km stand-off, so
``operator='auto'`` takes the spherical pair). SNR 5, 10, 20 dB. Error: ``min_g ‖g |f| − t‖ / ‖t‖``
(magnitude error after the best scalar gain: each pixel of the truth is a sum of 16 random phasors,
so images differ in scale by how they spread that speckle, not by anything λ controls).
Seeds 1000 + scene index: never used while the method was set up.

Family ``grid`` (``--family grid``), the earlier benchmark, scenes (generated here, seeded): random-phase piecewise-constant (three shapes) and Shepp-Logan,
each pixel a scatterer of the scene's magnitude and a uniform random phase; SNR 5, 10 and 20 dB
(noise power σ² = mean|d|² / 10^(SNR/10)); far-field data (NUFFT of the pixel model, eps 1e-12)
and spherical data (1 km stand-off: far-field phase error ≫ 0.1 rad at the grid corner, so
``operator='auto'`` picks the spherical pair). The noise power is NOT given to the regulariser
(``attrs`` empty): ``lam='auto'`` estimates it from the data.

For each scene: magnitude error ``‖|f| − |t|‖ / ‖t‖`` of the matched filter and of ptv, tv and
l1 with default settings (λ auto), the λ chosen, and the best λ and its error over a sweep of
λ values; prints one markdown table. Small grids (40 pixels far-field, 24 spherical; the spherical sweep for ptv only) keep it to a few minutes on two
cores. No assertions; ``tests/test_regparam.py`` asserts a reduced version.

The disk table also gives the pixel floor: the error of each pixel's coherent sum of its fine
scatterers (a perfect, noiseless pixel-model image) over the matched filter's. Below it only an
image that averages magnitudes across pixels (despeckles) can go.

Usage: ``python bench/bench_lam.py [--family disk|grid|shepp-study] [--quick] [--priors ptv,tv,l1] [--no-sweep]
[--geometry far-field] [--kinds shapes,shepp,points] [--snrs 5,10,20|none] [--lams 1,0.1,...]
[--reestimate-every N]``
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from sarcli.core.acquisition import Acquisition
from sarcli.core.grid import Grid, derive_grid
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


def disk_acquisition(P: int = 64, M: int = 64, aperture_deg: float = 4.0, *, spherical: bool = False,
                     fc: float = 10e9, bw: float = 700e6) -> Acquisition:
    """The ``disk`` family's collection; grid derived from the sampling (module docstring)."""
    freq = np.linspace(fc - bw / 2, fc + bw / 2, M)
    az = np.deg2rad(np.linspace(-aperture_deg / 2, aperture_deg / 2, P))
    el = np.full(P, np.deg2rad(30.0))
    grid = derive_grid(freq, az, el)
    if not spherical:
        return Acquisition(freq, az, el, grid)
    r0 = 1000.0
    pos = r0 * np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)
    return Acquisition(freq, az, el, grid, antenna_position_m=pos, model="spherical")


def disk_magnitude(kind: str, u, v, rng) -> np.ndarray:
    """Magnitude at normalised positions (u, v) (1 = the alias-free radius)."""
    r2 = u**2 + v**2
    if kind == "shepp":
        return shepp_logan(u / 0.98, v / 0.98)
    if kind == "points":
        mag = np.zeros(u.shape)
        inside = np.flatnonzero(r2.ravel() < 0.95**2)
        mag.flat[rng.choice(inside, 40, replace=False)] = 1.0
        return mag
    mag = np.where(r2 < 1.0, 0.35, 0.0)
    mag[(np.abs(u + 0.35) < 0.3) & (np.abs(v - 0.25) < 0.3)] = 1.0
    mag[(u - 0.4) ** 2 + (v + 0.35) ** 2 < 0.35**2] = 0.65
    mag[(np.abs(u - 0.3) < 0.15) & (np.abs(v - 0.6) < 0.15)] = 0.15
    return mag


def disk_scene(kind: str = "shapes", snr_db: float = 10.0, *, spherical: bool = False, seed: int = 0,
               upsample: int = 4, noise_attr: bool = False, coherent: bool = False, **acq_kw):
    """(PhaseHistory, truth magnitude, σ²) of a scene filling the alias-free disk (module docstring).

    ``snr_db`` None: noiseless. ``acq_kw`` go to :func:`disk_acquisition`. ``coherent``: a fourth
    element, each pixel's coherent sum of its fine scatterers (the complex reflectivity a perfect,
    noiseless pixel-model image would hold; its magnitude is speckled, the truth is not).
    """
    from sarcli.simulation.simulator import _farfield_extended, _spherical_extended

    acq = disk_acquisition(spherical=spherical, **acq_kw)
    g, up = acq.grid, int(upsample)
    radius = min(acq.alias_free_radii())
    fine = Grid(g.nx * up, g.ny * up, g.dx / up, g.dy / up, g.cx - g.dx / 2 + g.dx / up / 2,
                g.cy - g.dy / 2 + g.dy / up / 2)
    X, Y = np.meshgrid(fine.x / radius, fine.y / radius)
    rng = np.random.default_rng(seed)
    mag = disk_magnitude(kind, X, Y, rng)
    if kind == "points":
        mag *= up * up  # a unit point: one fine cell of amplitude 1 after the division below
    values = mag * np.exp(1j * rng.uniform(-np.pi, np.pi, X.shape)) / up**2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = _spherical_extended(acq, values, fine) if spherical else _farfield_extended(acq, values, fine)
    truth = np.abs(values).reshape(g.ny, up, g.nx, up).sum(axis=(1, 3))
    sigma2 = 0.0 if snr_db is None else float(np.mean(np.abs(d) ** 2)) / 10 ** (snr_db / 10)
    if sigma2 > 0:
        d = d + np.sqrt(sigma2 / 2) * (rng.standard_normal(d.shape) + 1j * rng.standard_normal(d.shape))
    out = PhaseHistory(d, acq, attrs={"noise_power": sigma2} if noise_attr else {}), truth, sigma2
    if coherent:
        out += (values.reshape(g.ny, up, g.nx, up).sum(axis=(1, 3)),)
    return out


def gain_error(f, truth) -> float:
    """Magnitude error after the best scalar gain, ``min_g ‖g |f| − t‖ / ‖t‖``."""
    a, t = np.abs(f).ravel(), np.asarray(truth, np.float64).ravel()
    aa = float(a @ a)
    g = float(a @ t) / aa if aa > 0 else 0.0
    return float(np.linalg.norm(g * a - t) / np.linalg.norm(t))


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


def evaluate_disk(ph, truth, priors=("ptv",), sweep=SWEEP, sweep_priors=None):
    """Gain errors of the matched filter and of each prior at λ auto (with its criterion, status,
    warnings other than convergence, and the cost against one fixed-λ solve at the chosen λ) and
    over the sweep."""
    from sarcli.errors import AliasingWarning, ConvergenceWarning
    from sarcli.regularize import matched_filter, regularize

    op = "spherical" if ph.model == "spherical" else "nufft"
    out = {"mf": gain_error(matched_filter(ph, operator=op), truth)}
    for prior in priors:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            # CPU seconds of this process: on a shared machine they vary far less than wall seconds
            t0 = time.process_time()
            img = regularize(ph, prior=prior)
            secs = time.process_time() - t0
            t0 = time.process_time()
            fixed_img = regularize(ph, prior=prior, lam=img.parameters["lam"])
            fixed = time.process_time() - t0
        sel = img.parameters["lam_selection"]
        # AᴴA applications (machine-independent cost), as regularize counts them: the scaling's power
        # iterations, both path solvers, the final solve
        grams = img.parameters["gram_products"]["total"]
        grams_fixed = fixed_img.parameters["gram_products"]["total"]
        row = {"err": gain_error(img.image, truth), "lam": img.parameters["lam"], "s": secs, "fixed_s": fixed,
               "grams": grams / grams_fixed,
               "criterion": sel["criterion"], "status": sel["status"], "sigma2": sel["noise_power"],
               "warnings": sorted({str(w.message) for w in caught
                                    if not issubclass(w.category, (ConvergenceWarning, AliasingWarning))})}
        if sweep and (sweep_priors is None or prior in sweep_priors):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)
                errs = [gain_error(regularize(ph, prior=prior, lam=lam).image, truth) for lam in sweep]
            i = int(np.argmin(errs))
            row.update(best_lam=sweep[i], best_err=errs[i])
        out[prior] = row
    return out


def main_disk(a):
    priors = tuple(a.priors.split(","))
    snrs = tuple(None if v.strip() == "none" else float(v) for v in a.snrs.split(","))
    geoms = {"both": (False, True), "far-field": (False,), "spherical": (True,)}[a.geometry]
    sweep = () if a.no_sweep else a.sweep
    print("| scene | geometry | SNR dB | MF | pixel floor / MF | " + " | ".join(
        f"{p} auto (λ, criterion) | {p}/MF | {p} best of sweep (λ) | {p} auto / best | "
        f"{p} auto / fixed-λ: AᴴA products, CPU time" for p in priors)
        + " | σ̂²/σ² | warnings |")
    print("|" + "---|" * (5 + 5 * len(priors) + 2))
    from sarcli.regularize import regularize

    warm, _, _ = disk_scene("shapes", 10.0, P=16, M=16)  # compile and load kernels before timing
    for p in priors:
        regularize(warm, prior=p, iters=5)
    t0 = time.perf_counter()
    index = 0
    for kind in a.kinds.split(","):
        for spherical in geoms:
            for snr in snrs:
                kw = {"P": 32, "M": 32} if a.quick else {}
                ph, truth, sigma2, coh = disk_scene(kind, snr, spherical=spherical, seed=1000 + index,
                                                    coherent=True, **kw)
                index += 1
                r = evaluate_disk(ph, truth, priors, sweep, ("ptv",) if spherical else None)
                cells, warns, s2 = [], [], "–"
                for p in priors:
                    q = r[p]
                    cells += [f"{q['err']:.3f} ({q['lam']:.3g}, {q['criterion']})", f"{q['err'] / r['mf']:.2f}",
                              f"{q['best_err']:.3f} ({q['best_lam']:.3g})" if "best_err" in q else "–",
                              f"{q['err'] / q['best_err']:.2f}" if "best_err" in q else "–",
                              f"{q['grams']:.2f}, {q['s'] / q['fixed_s']:.2f} ({q['s']:.3g} s / {q['fixed_s']:.3g} s)"]
                    warns += q["warnings"]
                    s2 = f"{q['sigma2'] / sigma2:.2f}" if (q["sigma2"] and sigma2) else s2
                floor = gain_error(coh, truth) / r["mf"]
                snr_txt = "noiseless" if snr is None else f"{snr:g}"
                print(f"| {kind} | {'spherical' if spherical else 'far-field'} | {snr_txt} | {r['mf']:.3f} | "
                      f"{floor:.2f} | " + " | ".join(cells) + f" | {s2} | {'; '.join(warns)[:120] or 'none'} |",
                      flush=True)
    print(f"\n{time.perf_counter() - t0:.0f} s in all")


def main_shepp_study(a):
    """Why Shepp-Logan filling the disk stays near the matched filter: for each SNR (far-field, the
    disk family's seeds of its Shepp-Logan rows), the share of ‖t‖² in the skull (t > 0.5), the pixel
    floor, and the best gain error over the sweep of ptv variants (order 1 and 2, phase re-estimation
    every 20 iterations, anisotropic shrinkage) and of ptv at 300 and 1,000 iterations (tol 1e-6)."""
    from sarcli.errors import ConvergenceWarning
    from sarcli.regularize import matched_filter, regularize

    variants = {"ptv": {}, "ptv order 2": {"order": 2}, "ptv re-estimated every 20": {"reestimate_every": 20},
                "ptv anisotropic": {"isotropic": False}}
    snrs = tuple(None if v.strip() == "none" else float(v) for v in a.snrs.split(","))
    print("| SNR dB | MF | skull share of ‖t‖² (pixels) | pixel floor / MF | "
          + " | ".join(f"{v}: best / MF (λ)" for v in variants) + " | ptv 300 vs 1000 iterations at the best λ |")
    print("|" + "---|" * (4 + len(variants) + 1))
    for j, snr in enumerate(snrs):
        seed = 1003 + j  # the seeds of the Shepp-Logan rows of `--geometry far-field` (5, 10, 20 dB)
        ph, truth, _, coh = disk_scene("shepp", snr, seed=seed, coherent=True)
        mf = gain_error(matched_filter(ph), truth)
        skull = truth > 0.5
        share = float((truth[skull] ** 2).sum() / (truth**2).sum())
        cells = []
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            for kw in variants.values():
                errs = [gain_error(regularize(ph, prior="ptv", lam=lam, **kw).image, truth) for lam in a.sweep]
                i = int(np.argmin(errs))
                cells.append(f"{errs[i] / mf:.2f} ({a.sweep[i]:.3g})")
                if not kw:
                    best = a.sweep[i]
            long = [gain_error(regularize(ph, prior="ptv", lam=best, iters=n, tol=1e-6).image, truth)
                    for n in (300, 1000)]
        print(f"| {'noiseless' if snr is None else f'{snr:g}'} | {mf:.3f} | {share:.2f} ({int(skull.sum())} of "
              f"{truth.size}) | {gain_error(coh, truth) / mf:.2f} | " + " | ".join(cells)
              + f" | {long[0]:.3f}, {long[1]:.3f} |", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="10 dB only, 32 pixels")
    ap.add_argument("--priors", default="ptv,tv,l1")
    ap.add_argument("--no-sweep", action="store_true")
    ap.add_argument("--reestimate-every", type=int, default=0, help="ptv: re-estimate Θ every N iterations")
    ap.add_argument("--geometry", choices=("both", "far-field", "spherical"), default="both")
    ap.add_argument("--kinds", default=None, help="default: shapes,shepp (disk), shapes,shepp,points (grid)")
    ap.add_argument("--family", choices=("disk", "grid", "shepp-study"), default="disk")
    ap.add_argument("--snrs", default="5,10,20", help="disk family: SNRs in dB, 'none' for noiseless data")
    ap.add_argument("--lams", default=None, help="λ values of the sweep (default 1, 0.32, ..., 0.001)")
    a = ap.parse_args(argv)
    a.sweep = SWEEP if a.lams is None else tuple(float(v) for v in a.lams.split(","))
    if a.family == "shepp-study":
        return main_shepp_study(a)
    if a.family == "disk":
        a.priors = a.priors if a.priors != "ptv,tv,l1" else "ptv"
        a.kinds = a.kinds or "shapes,shepp"
        return main_disk(a)
    a.kinds = a.kinds or "shapes,shepp,points"
    priors = tuple(a.priors.split(","))
    snrs = (10.0,) if a.quick else (5.0, 10.0, 20.0)
    n = 32 if a.quick else 40
    sweep = () if a.no_sweep else a.sweep
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
