"""The planner's picks on GOTCHA, the demo data and synthetic geometries, as JSON, to compare two
versions of the planner.

For every case and tolerance (1e-2, 1e-3, 1e-4), with this machine's cost model and with the
reference constants: ``recommend``'s pick, the full ``candidates`` list (method, knobs, predicted
error, time, memory, meets), the pruned list's ffbp pick and ``ffbp_knobs``. Floats are written
exactly (``repr``), so two versions that plan alike give identical files.

Usage::

    python scripts/planner_picks.py OUT.json [--compare REF.json] [--gotcha DIR]

With ``--compare``, prints the cases whose entries differ from ``REF.json`` and exits 1 if any do.
GOTCHA (pass 1 HH, 4 files): ``--gotcha``, else $SARCLI_GOTCHA_DIR, else ../shared/data/gotcha
beside the repository (skipped with a note when absent).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

from sarcli import read_phase_history
from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.core.grid import Grid
from sarcli.core.types import PhaseHistory
from sarcli.formers.planning import planner
from sarcli.formers.planning.calibration import DEFAULT_COSTS

REPO = Path(__file__).resolve().parents[1]
TOLERANCES = (1e-2, 1e-3, 1e-4)


def synthetic(P, M, r0, span_deg, grid, el=30.0, climb=0.0, bistatic=False):
    """Zero data on a circular path (geometry is all the planner reads): ``P`` pulses over
    ``span_deg`` at range ``r0``, ``M`` frequencies, optionally climbing by ``±climb`` m, or with
    a receiver 3° behind and 10 % farther."""
    az = np.radians(np.linspace(-span_deg / 2, span_deg / 2, P))
    a = geometry.antenna_positions_circle(az, np.radians(el), r0)
    a[:, 2] += climb * np.linspace(-1, 1, P)
    kw = {}
    if bistatic:
        kw = dict(transmit_position_m=a,
                  receive_position_m=geometry.antenna_positions_circle(az + np.radians(3), np.radians(el), 1.1 * r0))
    acq = Acquisition(9.6e9 + 4e6 * np.arange(M), az, np.full(P, np.radians(el)), grid, antenna_position_m=a,
                      range_to_center_m=np.linalg.norm(a, axis=1), model="spherical", **kw)
    return PhaseHistory(np.zeros((P, M), complex), acq)


def cases(gotcha_dir):
    files = sorted(Path(gotcha_dir).glob("data_3dsar_pass1_az00*_HH.mat"))[:4]
    if len(files) == 4:
        from sarcli.io.gotcha import read_gotcha

        ph = read_gotcha(files, grid=Grid.from_extent(100, 0.125))
        yield "gotcha-800", ph, Grid.from_extent(100, 0.125)
        yield "gotcha-200", ph, Grid.from_extent(50, 0.25)
    else:
        print(f"(no GOTCHA files in {gotcha_dir}: GOTCHA cases skipped)", file=sys.stderr)
    for name in ("three-points-small", "shepp-logan-small"):
        ph = read_phase_history(REPO / "data" / "synthetic" / f"{name}.h5")
        yield name, ph, ph.acquisition.grid
    for name, args in (("circle-96", (96, 96, 10e3, 5, Grid(48, 48, 0.5, 0.5))),
                       ("circle-256", (256, 256, 10e3, 6, Grid(256, 256, 0.25, 0.25))),
                       ("circle-1024", (1024, 512, 8e3, 10, Grid(512, 512, 0.3, 0.3))),
                       ("near-climb", (600, 300, 2e3, 20, Grid(300, 300, 0.2, 0.2), 45, 50)),
                       ("bistatic", (400, 200, 6e3, 8, Grid(200, 200, 0.3, 0.3), 30, 0, True)),
                       ("wide-3000", (3000, 256, 20e3, 30, Grid(400, 400, 0.5, 0.5), 20))):
        yield name, synthetic(*args), args[4]


def as_dict(c):
    return {"method": c.method, "knobs": c.knobs, "err": repr(c.predicted_error), "s": repr(c.seconds),
            "meets": c.meets, "mem": repr(float(c.memory))}


def picks(gotcha_dir) -> dict:
    out = {}
    for name, ph, grid in cases(gotcha_dir):
        for tol in TOLERANCES:
            for label, costs in (("this machine", None), ("reference", dict(DEFAULT_COSTS))):
                pruned = planner.candidates(ph, grid, tol, costs=costs, prune=True)
                entry = {"recommend": as_dict(planner.recommend(ph, grid, tol, costs=costs)),
                         "candidates": [as_dict(c) for c in planner.candidates(ph, grid, tol, costs=costs)],
                         "pruned_ffbp": [as_dict(c) for c in pruned if c.method == "ffbp" and c.meets]}
                if costs is None:
                    entry["ffbp_knobs"] = planner.ffbp_knobs(ph, grid, tol)
                out[f"{name} {tol:g} {label}"] = entry
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--compare")
    ap.add_argument("--gotcha", default=os.environ.get("SARCLI_GOTCHA_DIR") or REPO.parent / "shared" / "data" / "gotcha")
    args = ap.parse_args(argv)
    got = picks(args.gotcha)
    Path(args.out).write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")
    if args.compare:
        ref = json.loads(Path(args.compare).read_text())
        differ = [k for k in sorted(set(ref) | set(got)) if ref.get(k) != got.get(k)]
        for k in differ:
            print(f"differs: {k}")
        print(f"{len(got)} entries, {len(differ)} differ from {args.compare}")
        return 1 if differ else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
