"""The whole GOTCHA scene regularised, beside its matched filter: a figure and a table row.

    python scripts/regularize_gotcha.py PH.h5 REG.h5 [FIGURE.png]

PH.h5 is the imported collection (``sar import gotcha``), REG.h5 a ``sar regularize`` image of it.
The matched filter is the exact pair's ``Aᴴb / (P M)`` on REG's grid. Prints, for each image, the
ENL (median over 8 × 8 blocks of mean(I)²/var(I), I = |f|²: the median picks the homogeneous
blocks) and the edge sharpness (mean gradient magnitude of |f| over the steepest 1 % of pixels,
over mean |f|), and the regularisation's parameters (operator, sub-apertures, λ, iterations, time).
"""

from __future__ import annotations

import sys

import numpy as np


def enl(f, block=8) -> float:
    i = np.abs(f) ** 2
    ny, nx = (s // block * block for s in i.shape)
    b = i[:ny, :nx].reshape(ny // block, block, nx // block, block).transpose(0, 2, 1, 3).reshape(-1, block * block)
    v = b.var(axis=1)
    ok = v > 0
    return float(np.median(b.mean(axis=1)[ok] ** 2 / v[ok]))


def sharpness(f) -> float:
    a = np.abs(f)
    gy, gx = np.gradient(a)
    g = np.hypot(gx, gy).ravel()
    top = np.sort(g)[-max(1, g.size // 100):]
    return float(top.mean() / a.mean())


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    from sarcli.io.hdf5 import read_image, read_phase_history
    from sarcli.regularize import matched_filter

    ph = read_phase_history(argv[0])
    reg = read_image(argv[1])
    mf = matched_filter(ph, reg.grid, operator="spherical")
    p = reg.parameters
    print("| image | ENL | edge sharpness |")
    print("|---|---|---|")
    for name, f in (("matched filter", mf), (f"{p['prior']} (λ {p['lam']:.3g})", reg.image)):
        print(f"| {name} | {enl(f):.3g} | {sharpness(f):.3g} |")
    print(f"operator {p['operator']}, sub-apertures {p.get('subapertures')}, iterations {p.get('iterations')}, "
          f"{reg.runtime_s:.0f} s; lam selection {p.get('lam_selection', {}).get('status')}")
    if len(argv) > 2:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(1, 2, figsize=(11, 5.6), constrained_layout=True)
        ext = [reg.grid.x[0], reg.grid.x[-1], reg.grid.y[0], reg.grid.y[-1]]
        for a, (title, f) in zip(ax, (("matched filter", mf), (f"ptv, λ {p['lam']:.3g}", reg.image))):
            db = 20 * np.log10(np.abs(f) / np.abs(f).max() + 1e-12)
            a.imshow(db, origin="lower", extent=ext, cmap="gray", vmin=-45, vmax=0)
            a.set_title(f"{title}: ENL {enl(f):.3g}, sharpness {sharpness(f):.3g}")
            a.set_xlabel("x (m)")
        ax[0].set_ylabel("y (m)")
        fig.savefig(argv[2], dpi=90)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
