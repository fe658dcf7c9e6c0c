"""Figure ``fig: kernel`` and Theorem ``main-theorem``: the 2-D matched-filter kernel.

For the Gorham-Moore parameters (M = 512, φ = 30°, α_c = 10 GHz, B = 600 MHz, θ_c = 50°, 128 looks
over 3°, R = 5 m, N = 500: ``configs/three-points.yaml``) the kernel
``K(x) = Σ_θ H(ξ_θ·x)`` (eq. ``main-2D-conv``) is drawn on a log scale with
:func:`sarcli.analysis.psf.psf_kernel`. The theorem says the matched filter of a scene is ``f * K``; for
the three point targets it is the sum of three shifted kernels. We form the matched filter with
sarcli's exact ('direct') former from far-field data simulated by :func:`sarcli.simulate` and
compare it with that sum.
"""

from __future__ import annotations

import numpy as np

import sarcli
from sarcli.analysis import psf

from _common import Result, acquisition, db, fmt

KEY, LABEL = "fig04_kernel", "fig: kernel"


def farfield_three_points(pixels: int = 500, **changes):
    """The three-points acquisition in the far-field model (the theorem's model), ``pixels`` across."""
    return acquisition("three-points", model="farfield", geometry={"path": "farfield"},
                       image={"pixels": pixels}, **changes)


def superposition_error(acq) -> dict:
    """Direct matched filter of the config's points vs Σ_s a_s K(x - x_s)/(MP) (relative L2 and max)."""
    ph = sarcli.simulate(acq, snr_db=None, dtype=np.complex128)   # an identity to 1e-10: no float32 rounding
    mf = sarcli.form_image(ph, "direct").image
    pos, amp = ph.truth.point_position_m, ph.truth.point_amplitude
    ref = sum(a * psf.psf_kernel(acq, acq.grid, center=p[:2], method="theorem") for p, a in zip(pos, amp))
    return dict(mf=mf, ref=ref, rel_l2=float(np.linalg.norm(mf - ref) / np.linalg.norm(ref)),
                max_abs=float(np.max(np.abs(mf - ref))), points=pos)


def spherical_comparison(pixels: int = 250) -> float:
    """The actual (spherical, 10 km stand-off) Gorham-Moore demo: backprojection vs the sum of kernels.

    Returns the relative L2 difference between sarcli's backprojection image of the spherical data
    and ``Σ_s a_s K(x - x_s)/(MP)`` of the far-field theorem.
    """
    acq = acquisition("three-points", image={"pixels": pixels})
    ph = sarcli.simulate(acq, snr_db=None)
    img = sarcli.form_image(ph, "backprojection").image
    ref = sum(a * psf.psf_kernel(acq, acq.grid, center=p[:2], method="theorem")
              for p, a in zip(ph.truth.point_position_m, ph.truth.point_amplitude))
    return float(np.linalg.norm(img - ref) / np.linalg.norm(ref))


def plot(kern, grid, sup, sup_grid):
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, 3, figsize=(13, 4.4), layout="constrained")
    ext = [grid.x[0], grid.x[-1], grid.y[0], grid.y[-1]]
    im = axs[0].imshow(db(kern, -60), origin="lower", extent=ext, cmap="gray")
    axs[0].set_title("|K| / (MP) (dB), Gorham-Moore parameters")
    r = np.abs(grid.x) < 0.3
    axs[1].imshow(db(kern[np.ix_(r, r)], -60), origin="lower", extent=[-0.3, 0.3, -0.3, 0.3], cmap="gray")
    axs[1].set_title("centre of K (dB)")
    ext2 = [sup_grid.x[0], sup_grid.x[-1], sup_grid.y[0], sup_grid.y[-1]]
    axs[2].imshow(db(sup["mf"], -60), origin="lower", extent=ext2, cmap="gray")
    axs[2].set_title(f"direct MF of 3 points; vs ΣK: rel. err {sup['rel_l2']:.1e}")
    for ax in axs:
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    fig.colorbar(im, ax=axs, shrink=0.8, label="dB")
    return fig


def run(out_dir=None) -> Result:
    acq = farfield_three_points(500)
    kern = psf.psf_kernel(acq, acq.grid, method="theorem")
    sacq = farfield_three_points(250)  # 4 cm pixels: the exact O(MPN²) former on 62 500 pixels
    sup = superposition_error(sacq)
    sph = spherical_comparison(250)
    peak = float(np.abs(kern).max())
    ok = sup["rel_l2"] < 1e-10 and abs(peak - 1) < 1e-12 and sph < 0.1
    return Result(
        KEY, LABEL, "the 2-D kernel of Theorem main-theorem",
        claim=("Theorem `main-theorem`: the matched filter (eq. `mf`) is f * K with "
               "K(x) = Σ_θ H(ξ_θ·x; K_c, M, Δk) (eq. `main-2D-conv`), H = e^{iK_c t} D_{(M-1)/2}(Δk t) "
               "(eq. `H-kernel`). `fig: kernel` draws K for the Gorham-Moore parameters on a dB scale; "
               "the three-point image of Gorham and Moore is 'a superposition of three kernels'."),
        measured=[
            f"K/(MP) on the 500 × 500 grid (2 cm pixels): peak {peak:.15f} at the origin (bound |peak - 1| < 1e-12).",
            f"Three unit points (0,0), (-3,2), (1,4) m, far-field data, sarcli's exact ('direct') matched filter on "
            f"250 × 250 pixels (4 cm) vs Σ_s K(x - x_s)/(MP): relative L2 error {fmt(sup['rel_l2'])}, "
            f"max abs error {fmt(sup['max_abs'])} (bound 1e-10).",
            f"The Gorham-Moore demo itself (spherical data, 10 km stand-off, sarcli's backprojection, same 250 × 250 grid) "
            f"against the same sum of far-field kernels: relative L2 difference {fmt(sph)} — 'somewhat a superposition "
            f"of three kernels' (pass < 0.1).",
        ],
        passed=ok, headline=f"three targets = three kernels to {fmt(sup['rel_l2'])}; spherical demo within {fmt(sph)}", figure=plot(kern, acq.grid, sup, sacq.grid),
        notes=("The theorem is exact for the far-field model, so the 1e-10 check uses far-field data; the "
               "Gorham-Moore demo itself is spherical (far-field phase error about 0.5 rad at 5 m), hence "
               "the few-percent difference in the last line."))
