"""Draw docs/autofocus/gotcha.png and print the numbers of docs/autofocus.md.

The four GOTCHA pass-1 HH files (one degree each), backprojected on a 100 m grid of 0.25 m
pixels: as delivered, with AFRL's stored autofocus solution, with sarcli's minimum-entropy
autofocus, and with a known error injected (quadratic + smooth random + jitter) before and after
sarcli's autofocus. Usage: ``python scripts/autofocus_figure.py GOTCHA_DIR OUT.png``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from sarcli.analysis.speckle import image_entropy, peak_to_mean
from sarcli.autofocus import autofocus, remove_linear_phase
from sarcli.autofocus._common import form, synthetic_phase_error
from sarcli.io.gotcha import read_gotcha


def injected_error(P, seed=0):
    """The error of tests/test_autofocus.py: quadratic (4 rad) + smooth random + 0.15 rad jitter."""
    return synthetic_phase_error(P, seed)


def main(folder, out):
    files = sorted(Path(folder).glob("data_3dsar_pass1_az00[1-4]_HH.mat"))
    raw = read_gotcha(files)
    afrl = read_gotcha(files, autofocus=True)
    grid = raw.acquisition.grid
    panels = [("as delivered", form(raw, grid))]
    panels.append(("AFRL's stored autofocus", form(afrl, grid)))
    t0 = time.perf_counter()
    focused, res = autofocus(raw, "min-entropy")
    print(f"min-entropy on the raw data: {time.perf_counter() - t0:.1f} s, {res.summary()}")
    panels.append(("sarcli min-entropy", form(focused, grid)))
    err = injected_error(raw.data.shape[0])
    from sarcli.core.types import PhaseHistory

    bad = PhaseHistory(raw.data * np.exp(1j * err)[:, None], raw.acquisition, attrs=raw.attrs)
    panels.append(("error injected", form(bad, grid)))
    for method in ("pga", "min-entropy"):
        t0 = time.perf_counter()
        fixed, res = autofocus(bad, method)
        resid = remove_linear_phase(err - res.phase_rad, raw.acquisition.azimuth_rad)
        print(f"{method} on the injected error: {time.perf_counter() - t0:.1f} s, residual "
              f"{np.sqrt(np.mean(resid ** 2)):.3f} rad rms (injected "
              f"{np.sqrt(np.mean(remove_linear_phase(err, raw.acquisition.azimuth_rad) ** 2)):.3f})")
        panels.append((f"injected, then {method}", form(fixed, grid)))
    fig = Figure(figsize=(15, 10), layout="constrained")
    axes = fig.subplots(2, 3)
    ext = [grid.x[0], grid.x[-1], grid.y[0], grid.y[-1]]
    for ax, (title, img) in zip(axes.ravel(), panels):
        h, m = image_entropy(img), peak_to_mean(img)
        print(f"{title:28s} entropy {h:.4f}  peak-to-mean {m:.5g}")
        db = 20 * np.log10(np.abs(img) / np.abs(img).max() + 1e-12)
        ax.imshow(db, origin="lower", extent=ext, vmin=-50, vmax=0, cmap="gray")
        ax.set_title(f"{title}\nentropy {h:.3f}, peak/mean {m:.0f}", fontsize=10)
        ax.set_xlabel("x east (m)")
        ax.set_ylabel("y north (m)")
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=60)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
