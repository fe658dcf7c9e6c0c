"""Which phase sign do the GOTCHA files follow? Backproject both signs and compare focus.

The spherical convention (docs/conventions.md) is ``d = Σ a exp(-i 4π α Δr / c)``. Conjugating the
data flips the sign. Without autofocus both signs focus (the conjugate gives the scene mirrored
through the centre), so the test uses AFRL's autofocus, ``exp(+i ph_correct)``: it only
sharpens data of the sign it was estimated for.

Usage::

    python scripts/check_gotcha_sign.py [GOTCHA_DIR]   # default: sarcli.io.gotcha.gotcha_dir()

Prints, for each sign with and without autofocus, the peak-to-mean ratio of |f| (higher = more
focused) and the entropy of |f|² (lower = more focused) on the 100 m × 100 m, 0.25 m grid.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from sarcli.formers.backprojection import backproject
from sarcli.io.gotcha import default_gotcha_grid, gotcha_dir, gotcha_files, read_gotcha
from sarcli.core.collection import Collection
from sarcli.formers.options import BackprojectionOptions


def focus(img):
    p = np.abs(img) ** 2
    q = p / p.sum()
    return float(np.abs(img).max() / np.abs(img).mean()), float(-np.sum(q * np.log(q + 1e-300)))


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    folder = Path(argv[0]) if argv else gotcha_dir()
    files = gotcha_files(folder)
    if not files:
        sys.exit(f"no GOTCHA files in {folder}")
    grid = default_gotcha_grid()
    print(f"{len(files)} files, grid {grid.ny} x {grid.nx} of {grid.dx} m\n")
    print("| autofocus | sign | peak/mean abs f | entropy of abs f squared |")
    print("|---|---|---|---|")
    for af in (False, True):
        ph = read_gotcha(files, autofocus=af)
        acq = ph.acquisition
        col = Collection(acq.frequency_hz, acq.antenna_position_m, acq.range_to_center_m)
        for name, d in (("as stored", ph.data), ("conjugated", np.conj(ph.data))):
            pm, ent = focus(backproject(d, col, grid, BackprojectionOptions(precision="float32")))
            print(f"| {af} | {name} | {pm:.1f} | {ent:.3f} |")


if __name__ == "__main__":
    main()
