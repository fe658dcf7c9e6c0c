"""Backprojection's 4-tap range-profile interpolators, Keys cubic and cubic Lagrange, against each other (no assertions).

For each case and each ``(interp, upsample)``: the relative error against the exact matched filter
(``direct``) on a strided sub-grid (:func:`sarcli.analysis.accuracy.reference_grid`, ``--max-cost``:
3e8 as in ``bench/bench_bp_peer.py``, 17² to 48² pixels here; 3e9 makes it 93² to 128², where a few
pixels near the point targets no longer carry most of the error), and the CPU seconds of a float32 ``backproject`` on one thread, the best of
``--rounds`` rounds that run every setting in turn (forwards, then backwards), with its speed as the
ratio of the first setting's seconds (Keys at 16, the default) to its own. The cases:

- ``gotcha``, ``orbit``: those of ``bench/bench_bp_peer.py`` (GOTCHA 4 files onto 800² at 0.125 m;
  a 740 km orbit, 1024 x 1024 samples onto 1024² at 0.5 m);
- a slant range in metres (``50``, ``1000``, ``10000``): ``bench/bench_bp_range.py``'s collection,
  512 pulses x 256 frequencies onto 512², its scene of 24 point targets for the error.

``SARCLI_BP_ISA=1`` runs the AVX2 copy. Usage::

    python bench/bench_bp_interp.py [--case gotcha,orbit,50,1000,10000] [--settings cubic:16,lagrange:12,...]
                                    [--rounds 5] [--max-cost 3e8]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from sarcli._native import using_threads  # noqa: E402
from sarcli.analysis.accuracy import reference_grid  # noqa: E402
from sarcli.core.collection import Collection  # noqa: E402
from sarcli.formers.backprojection import backproject  # noqa: E402
from sarcli.formers.direct import direct_spherical  # noqa: E402
from sarcli.formers.formation import image_error  # noqa: E402
from sarcli.formers.options import BackprojectionOptions  # noqa: E402

SETTINGS = "cubic:16,cubic:12,lagrange:16,lagrange:13,lagrange:12,lagrange:10,lagrange:8"


def case_data(name: str):
    """(data, freq, antenna positions, r0, grid) of ``name``; None where GOTCHA's files are absent."""
    if name in ("gotcha", "orbit"):
        import bench_bp_peer as peer

        case = peer.gotcha_case(4) if name == "gotcha" else peer.orbit_case()
        return None if case is None else case[1:]
    import bench_bp_range as br

    _, freq, a, r0, grid, points = br.problem(float(name), 512, 512)
    return points, freq, a, r0, grid


def run(name: str, settings, rounds: int, max_cost: float) -> None:
    got = case_data(name)
    if got is None:
        print(f"{name}: no GOTCHA files, skipped")
        return
    data, freq, a, r0, grid = got
    sub, rows, cols, _ = reference_grid(SimpleNamespace(data=data), grid, max_cost=max_cost)
    ref = direct_spherical(data, freq, a, r0, sub)
    col = Collection(freq, a, r0)
    seconds = {s: np.inf for s in settings}
    errors = {}
    with using_threads(1):
        for r in range(rounds):
            for s in settings if r % 2 == 0 else settings[::-1]:
                opts = BackprojectionOptions(interp=s[0], upsample=s[1], precision="float32")
                t = time.process_time()
                img = backproject(data, col, grid, opts, nthreads=1)
                seconds[s] = min(seconds[s], time.process_time() - t)
                errors[s] = image_error(img[np.ix_(rows, cols)], ref)
    print(f"{name}: reference sub-grid {len(rows)} x {len(cols)}")
    base = seconds[settings[0]]
    isa = os.environ.get("SARCLI_BP_ISA", "best")
    for s in settings:
        print(f"{name:7s} isa {isa:4s} {s[0]:8s} u={s[1]:<4g} error {errors[s]:.3e}  cpu {seconds[s]:.3f} s"
              f"  {settings[0][0]} {settings[0][1]:g} / this {base / seconds[s]:.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="gotcha,orbit,50,1000,10000")
    ap.add_argument("--settings", default=SETTINGS, help="interp:upsample, comma separated; the first is the baseline")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--max-cost", type=float, default=3e8, help="the reference sub-grid's P·M·pixels")
    args = ap.parse_args()
    settings = [(s.split(":")[0], float(s.split(":")[1])) for s in args.settings.split(",")]
    for name in args.case.split(","):
        run(name, settings, args.rounds, args.max_cost)


if __name__ == "__main__":
    main()
