"""Figure ``fig: final-reg``: matched filter vs regularised GOTCHA images and their 2-D FFTs.

The four one-degree AFRL GOTCHA files in ``../shared/data/gotcha`` (pass 1, HH) are read with
:func:`sarcli.io.gotcha.read_gotcha`, imaged with the spherical matched filter
(:func:`sarcli.regularize.matched_filter`, the same operator the regulariser uses, so both images
share one scale) and with :func:`sarcli.regularize.regularize` (TV and phase-corrected TV,
spherical operator). The paper's claim is read off the FFTs of the images: the matched filter's
spectrum is dark where no data were collected, the regularised images 'fill in these k-space
regions'. We measure it as the share of the image spectrum's energy outside the data's
(aliased) k-space support, rasterised from :func:`sarcli.core.geometry.dimensionless_frequencies`.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import binary_dilation

from sarcli.core import geometry
from sarcli.core.grid import Grid

from _common import GOTCHA_DIR, Result, db, fmt

KEY, LABEL = "fig10_gotcha", "fig: final-reg"


def gotcha_files(n_files: int = 4):
    return sorted(GOTCHA_DIR.glob("data_3dsar_pass1_az00*_HH.mat"))[:n_files]


def support_mask(acq, grid: Grid, dilate: int = 2) -> np.ndarray:
    """FFT bins (fftshift order, [row=k2, col=k1]) hit by the data's wrapped pixel frequencies."""
    k1, k2 = geometry.dimensionless_frequencies(acq.frequency_hz, acq.azimuth_rad, acq.elevation_rad,
                                                (grid.dx, grid.dy), wrap=True)
    c = np.floor((k1.ravel() + np.pi) / (2 * np.pi) * grid.nx).astype(int) % grid.nx
    r = np.floor((k2.ravel() + np.pi) / (2 * np.pi) * grid.ny).astype(int) % grid.ny
    mask = np.zeros(grid.shape, bool)
    mask[r, c] = True
    return binary_dilation(mask, iterations=dilate)


def spectrum(img) -> np.ndarray:
    """``fftshift(fft2)`` with the sign that puts a matched filter's energy on its k-space samples."""
    return np.fft.fftshift(np.fft.fft2(img))


def outside_share(img, mask) -> float:
    p = np.abs(spectrum(img)) ** 2
    return float(p[~mask].sum() / p.sum())


def compute(*, n_files: int = 4, extent_m: float = 40.0, pixel_m: float = 0.25, iters: int = 50, priors=("tv", "ptv")) -> dict:
    from sarcli.io.gotcha import read_gotcha
    from sarcli.regularize import matched_filter, regularize

    files = gotcha_files(n_files)
    ph = read_gotcha(files)
    grid = Grid.from_extent(extent_m, pixel_m)
    mf = matched_filter(ph, grid, operator="spherical")
    mask = support_mask(ph.acquisition, grid)
    out = dict(grid=grid, mf=mf, mask=mask, files=[f.name for f in files], n_pulses=ph.acquisition.n_pulses,
               mask_share=float(mask.mean()), outside={"mf": outside_share(mf, mask)}, images={}, iters=iters)
    for prior in priors:
        img = regularize(ph, prior=prior, operator="spherical", grid=grid, iters=iters, tol=1e-12)
        out["images"][prior] = img.image
        out["outside"][prior] = outside_share(img.image, mask)
        out[f"{prior}_lam"] = img.parameters.get("lam")
        obj = img.history["objective"]
        out[f"{prior}_objective"] = (float(obj[0]), float(obj[-1]))
    return out


def cv_analogue(*, n: int = 40, n_points: int = 12, snr_db: float = 20.0, seed: int = 5) -> dict:
    """The right-hand (CV-domes, ℓ1) column as a simulated analogue: ℓ1 on a sparse scene.

    ``n_points`` unit scatterers with random phases on pixel centres of an n × n grid of 0.25 m,
    far-field data (10 GHz, 300 MHz, 6°, 64 looks × 48 frequencies) with noise at ``snr_db`` (its
    power recorded in the file attributes, as the simulator does), imaged by the matched filter
    and by ``regularize(prior='l1')`` with λ chosen automatically.
    """
    from sarcli.analysis.speckle import image_entropy, peak_to_mean
    from sarcli.core.acquisition import Acquisition
    from sarcli.core.types import PhaseHistory
    from sarcli.linops import NufftOperator
    from sarcli.regularize import matched_filter, regularize

    grid = Grid.square(n * 0.25 / 2, n)
    P, M = 64, 48
    acq = Acquisition(np.linspace(9.85e9, 10.15e9, M), np.deg2rad(np.linspace(-3, 3, P)),
                      np.full(P, np.deg2rad(30.0)), grid)
    rng = np.random.default_rng(seed)
    truth = np.zeros(grid.shape, complex)
    idx = rng.choice(grid.nx * grid.ny, n_points, replace=False)
    truth.flat[idx] = np.exp(1j * rng.uniform(-np.pi, np.pi, n_points))
    kx, ky = acq.kspace()
    d = NufftOperator(kx, ky, grid, eps=1e-12).forward(truth)
    sigma2 = float(np.mean(np.abs(d) ** 2)) / 10 ** (snr_db / 10)
    d = d + np.sqrt(sigma2 / 2) * (rng.standard_normal(d.shape) + 1j * rng.standard_normal(d.shape))
    ph = PhaseHistory(d, acq, attrs={"noise_power": sigma2})
    mf = matched_filter(ph)
    img = regularize(ph, prior="l1")
    mask = support_mask(acq, grid)
    err = {k: float(np.linalg.norm(np.abs(v) - np.abs(truth)) / np.linalg.norm(truth))
           for k, v in (("mf", mf), ("l1", img.image))}
    return dict(grid=grid, mf=mf, l1=img.image, mask=mask, lam=img.parameters["lam"], err=err,
                entropy={"mf": image_entropy(mf), "l1": image_entropy(img.image)},
                peak_to_mean={"mf": peak_to_mean(mf), "l1": peak_to_mean(img.image)},
                outside={"mf": outside_share(mf, mask), "l1": outside_share(img.image, mask)},
                peaks=np.abs(img.image).flat[idx], n_points=n_points, snr_db=snr_db)


def plot(res):
    import matplotlib.pyplot as plt

    g = res["grid"]
    ext = [g.x[0], g.x[-1], g.y[0], g.y[-1]]
    cols = [("mf", res["mf"], "matched filter")] + [(p, im, f"regularised ({p})") for p, im in res["images"].items()]
    fig, axs = plt.subplots(2, len(cols), figsize=(4.2 * len(cols), 8.4), layout="constrained")
    for j, (key, img, title) in enumerate(cols):
        axs[0, j].imshow(db(img, -50), origin="lower", extent=ext, cmap="gray")
        axs[0, j].set_title(f"{title} (dB)", fontsize=9)
        axs[1, j].imshow(db(spectrum(img), -60), origin="lower", extent=[-np.pi, np.pi, -np.pi, np.pi], cmap="gray")
        axs[1, j].contour(np.linspace(-np.pi, np.pi, g.nx), np.linspace(-np.pi, np.pi, g.ny), res["mask"].astype(float),
                          levels=[0.5], colors="C1", linewidths=0.6)
        axs[1, j].set_title(f"log |FFT|; energy outside data support {100 * res['outside'][key]:.1f} %", fontsize=9)
    return fig


def run(out_dir=None) -> Result:
    if not gotcha_files():
        return Result(KEY, LABEL, "GOTCHA: matched filter vs regularised",
                      claim="`fig: final-reg`: regularisation fills in k-space where no data were collected.",
                      measured=[f"not reproduced: no GOTCHA files in {GOTCHA_DIR}"], passed=None)
    res = compute()
    o = res["outside"]
    ok = all(o[p] > 2 * o["mf"] for p in res["images"])
    return Result(
        KEY, LABEL, "GOTCHA: matched filter vs regularised images and their spectra",
        claim=("`fig: final-reg` (section `sec: reg`): on the GOTCHA data the regularised (TV) image has less speckle "
               "and ringing than the NUFFT matched filter; 'the Fourier transforms of the NUFFT solutions clearly show "
               "us the location of the aliased Fourier data, and the dark regions ... indicate where no data was "
               "located', while the regularised solutions 'are able to fill in these k-space regions void of data'."),
        measured=[
            f"{len(res['files'])} GOTCHA files (pass 1 HH, azimuths 1-4°, {res['n_pulses']} pulses), "
            f"{res['grid'].nx} × {res['grid'].ny} pixels of {res['grid'].dx} m, spherical operator, "
            f"{res['iters']} ADMM iterations per prior, default λ ("
            + ", ".join(f"{p}: {res[p + '_lam']}" for p in res["images"]) + ").",
            f"The data's aliased k-space support (dilated by 2 bins) covers {100 * res['mask_share']:.1f} % of the FFT bins.",
            "Share of the image spectrum's energy outside that support: matched filter "
            + f"{fmt(100 * o['mf'])} %, " + ", ".join(f"{p} {fmt(100 * o[p])} %" for p in res["images"])
            + " (pass: each regularised image more than twice the matched filter's).",
            "ADMM objective first → last: " + ", ".join(
                f"{p} {fmt(res[p + '_objective'][0])} → {fmt(res[p + '_objective'][1])}" for p in res["images"]) + ".",
        ],
        passed=ok, figure=plot(res),
        notes=("The paper's right-hand column (CV dome data with an ℓ1 prior) is not reproduced: that data set is "
               "not in `../shared/data`. The regulariser runs a limited number of iterations here to keep "
               "`make paper` to minutes on two cores."))
