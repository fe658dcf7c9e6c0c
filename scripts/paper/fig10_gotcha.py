"""Figure ``fig: final-reg``: matched filter vs regularised GOTCHA images and their 2-D FFTs.

The four one-degree AFRL GOTCHA files (pass 1, HH; ``$SARCLI_GOTCHA_DIR``, see docs/conventions.md) are read with
:func:`sarcli.io.gotcha.read_gotcha`, imaged with the spherical matched filter
(:func:`sarcli.regularize.matched_filter`, the same operator the regulariser uses, so both images
share one scale) and with :func:`sarcli.regularize.regularize` (TV and phase-corrected TV,
spherical operator). The paper's claim is checked by what it says the images show: less speckle
(higher equivalent number of looks, lower intensity contrast in homogeneous regions, chosen as the
blocks of fully developed speckle in the matched filter) and sharper targets (lower entropy, higher
peak-to-mean), :mod:`sarcli.analysis.speckle`. The share of the image spectrum's energy outside the
data's k-space support is reported too, but not as a pass criterion (any image that is not the
matched filter has some). The CV-domes column is a simulated analogue: ℓ1 on a sparse scene.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import binary_dilation

from sarcli.core import geometry
from sarcli.core.grid import Grid
from sarcli.io.gotcha import gotcha_files as pass_files

from _common import GOTCHA_DIR, Result, db, fmt

KEY, LABEL = "fig10_gotcha", "fig: final-reg"


def gotcha_files(n_files: int = 4):
    return pass_files(GOTCHA_DIR)[:n_files]


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


BLOCK = 16


def homogeneous_blocks(mf, block: int = BLOCK, tol: float = 0.15):
    """Blocks (tuples of slices) of fully developed speckle in the matched filter: intensity contrast
    std(I)/mean(I) within ``tol`` of 1 (distributed clutter, no dominant point target)."""
    from sarcli.analysis.speckle import contrast

    ny, nx = mf.shape
    out = []
    for i in range(0, ny - block + 1, block):
        for j in range(0, nx - block + 1, block):
            sl = (slice(i, i + block), slice(j, j + block))
            if abs(contrast(mf, sl) - 1.0) < tol:
                out.append(sl)
    return out


def speckle_summary(img, blocks) -> dict:
    """Median ENL and contrast over the homogeneous blocks; entropy and peak/mean of the image."""
    from sarcli.analysis.speckle import contrast, equivalent_number_of_looks, image_entropy, peak_to_mean

    return {"enl": float(np.median([equivalent_number_of_looks(img, b) for b in blocks])),
            "contrast": float(np.median([contrast(img, b) for b in blocks])),
            "entropy": image_entropy(img), "peak_to_mean": peak_to_mean(img)}


def compute(*, n_files: int = 4, extent_m: float = 40.0, pixel_m: float = 0.25, iters: int = 50,
            priors=("ptv", "tv"), lams=None) -> dict:
    from sarcli.io.gotcha import read_gotcha
    from sarcli.regularize import matched_filter, regularize

    lams = {p: "auto" for p in priors} | (lams or {})
    files = gotcha_files(n_files)
    ph = read_gotcha(files)
    grid = Grid.from_extent(extent_m, pixel_m)
    mf = matched_filter(ph, grid, operator="spherical")
    mask = support_mask(ph.acquisition, grid)
    blocks = homogeneous_blocks(mf)
    out = dict(grid=grid, mf=mf, mask=mask, files=[f.name for f in files], n_pulses=ph.acquisition.n_pulses,
               mask_share=float(mask.mean()), outside={"mf": outside_share(mf, mask)}, images={}, iters=iters,
               blocks=blocks, speckle={"mf": speckle_summary(mf, blocks)})
    for prior in priors:
        img = regularize(ph, prior=prior, operator="spherical", grid=grid, iters=iters, tol=1e-12, lam=lams[prior])
        out["images"][prior] = img.image
        out["outside"][prior] = outside_share(img.image, mask)
        out["speckle"][prior] = speckle_summary(img.image, blocks)
        out[f"{prior}_lam"] = img.parameters.get("lam")
        out[f"{prior}_lam_by"] = (img.parameters.get("lam_selection") or {}).get("criterion", "given")
        obj = img.history["objective"]
        out[f"{prior}_objective"] = (float(obj[0]), float(obj[-1]))
    return out


def claim_holds(res, prior) -> bool:
    """The paper's claim for one regularised image: less speckle (ENL up, contrast down in the
    homogeneous blocks) and sharper targets (entropy down, peak-to-mean up)."""
    m, r = res["speckle"]["mf"], res["speckle"][prior]
    return bool(res["blocks"] and r["enl"] > m["enl"] and r["contrast"] < m["contrast"]
                and r["entropy"] < m["entropy"] and r["peak_to_mean"] > m["peak_to_mean"])


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
    cv = cv_analogue()
    cv_ok = bool(cv["err"]["l1"] < 0.2 * cv["err"]["mf"] and cv["entropy"]["l1"] < cv["entropy"]["mf"]
                 and np.all(np.abs(cv["peaks"] - 1) < 0.1))
    cv_lines = [
        f"Right-hand (CV-domes, ℓ1) column as a simulated ANALOGUE (the CV-domes data are not available): "
        f"{cv['n_points']} unit point scatterers on a {cv['grid'].nx}² grid of 0.25 m, far-field, SNR {cv['snr_db']:g} dB, "
        f"`regularize(prior='l1')` with λ auto ({fmt(cv['lam'])}): magnitude error {fmt(cv['err']['l1'])} vs the "
        f"matched filter's {fmt(cv['err']['mf'])}; entropy {fmt(cv['entropy']['l1'])} vs {fmt(cv['entropy']['mf'])} nats "
        f"(sharper); the points' magnitudes {fmt(cv['peaks'].min())}-{fmt(cv['peaks'].max())} (truth 1); spectral energy "
        f"outside the data support {fmt(100 * cv['outside']['l1'])} % vs {fmt(100 * cv['outside']['mf'])} % "
        f"(pass: error < 0.2 × MF's, entropy lower, peaks within 10 %): {'PASS' if cv_ok else 'FAIL'}."]
    claim = ("`fig: final-reg` (section `sec: reg`): 'The NUFFT solutions clearly exhibit speckle and ringing artifacts, "
             "and these effects are significantly reduced in the regularized solutions, without degrading the true image "
             "features'; the regularised images' spectra 'fill in these k-space regions void of data'. Left: GOTCHA, TV; "
             "right: CV domes, ℓ1.")
    if not gotcha_files():
        return Result(KEY, LABEL, "GOTCHA: matched filter vs regularised", claim=claim,
                      measured=[f"GOTCHA column not reproduced: no GOTCHA files in {GOTCHA_DIR}"] + cv_lines,
                      passed=None)
    res = compute()
    o, sp = res["outside"], res["speckle"]
    # the paper's GOTCHA column is TV; ptv is reported beside it
    ok = claim_holds(res, "tv") and cv_ok
    return Result(
        KEY, LABEL, "GOTCHA: matched filter vs regularised images (speckle, sharpness, spectra); CV column as analogue",
        claim=claim,
        measured=[
            f"{len(res['files'])} GOTCHA files (pass 1 HH, azimuths 1-4°, {res['n_pulses']} pulses), "
            f"{res['grid'].nx} × {res['grid'].ny} pixels of {res['grid'].dx} m, spherical operator, "
            f"{res['iters']} ADMM iterations per prior, λ chosen automatically ("
            + ", ".join(f"{p}: {fmt(res[p + '_lam'])} by {res[p + '_lam_by']}" for p in res["images"]) + ").",
            f"Homogeneous regions: the {len(res['blocks'])} blocks of {BLOCK}² pixels whose matched-filter intensity "
            f"contrast is within 0.15 of 1 (fully developed speckle). Median over them — ENL: matched filter "
            f"{fmt(sp['mf']['enl'])}, " + ", ".join(f"{p} {fmt(sp[p]['enl'])}" for p in res["images"])
            + "; contrast: matched filter " + f"{fmt(sp['mf']['contrast'])}, "
            + ", ".join(f"{p} {fmt(sp[p]['contrast'])}" for p in res["images"]) + " (pass: ENL up, contrast down).",
            "Sharper targets — image entropy (nats, lower = sharper): matched filter "
            + f"{fmt(sp['mf']['entropy'])}, " + ", ".join(f"{p} {fmt(sp[p]['entropy'])}" for p in res["images"])
            + "; peak/mean: matched filter " + f"{fmt(sp['mf']['peak_to_mean'])}, "
            + ", ".join(f"{p} {fmt(sp[p]['peak_to_mean'])}" for p in res["images"]) + " (pass: entropy down, peak/mean up).",
            "Verdict on TV (the paper's prior for this column): " + ("holds" if claim_holds(res, "tv") else "FAILS")
            + "; ptv (reported, not judged): " + ("all four criteria hold" if claim_holds(res, "ptv") else
            "speckle reduced and peak/mean up, but the entropy criterion fails (its flat, despeckled background "
            "spreads the energy evenly, which raises the entropy)") + ".",
            f"Spectra (reported, not a pass criterion: any image that is not the matched filter has energy there): share "
            f"of the image spectrum's energy outside the data's aliased k-space support ({fmt(100 * res['mask_share'])} % "
            f"of the bins): matched filter {fmt(100 * o['mf'])} %, " + ", ".join(f"{p} {fmt(100 * o[p])} %" for p in res["images"]) + ".",
            "ADMM objective first → last: " + ", ".join(
                f"{p} {fmt(res[p + '_objective'][0])} → {fmt(res[p + '_objective'][1])}" for p in res["images"]) + ".",
        ] + cv_lines,
        passed=ok, headline=f"GOTCHA ENL {fmt(sp['mf']['enl'])} → " + ", ".join(f"{p} {fmt(sp[p]['enl'])}" for p in res['images']) + f"; entropy {fmt(sp['mf']['entropy'])} → " + ", ".join(f"{p} {fmt(sp[p]['entropy'])}" for p in res['images']) + f"; CV analogue ℓ1 error {fmt(cv['err']['l1'])} vs {fmt(cv['err']['mf'])}", kind="reproduced (GOTCHA) + analogue (CV column)", figure=plot(res),
        notes=("λ is the default `lam='auto'` (docs/regularize.md): the noise level comes from the range bins beyond "
               "the patch, which hold the clutter of the rest of the scene, so the choice smooths more than the "
               "receiver noise alone would ask. The regulariser runs a limited number of iterations to keep "
               "`make paper` to minutes on two cores."))
