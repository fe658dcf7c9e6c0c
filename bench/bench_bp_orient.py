"""Backprojection's kernel rows across and along the look direction, and its pulse block against
the core's L2 cache, in one run (no assertions).

The kernels run along rows (tiles of up to 64 pixels, 16-lane groups each reading a 4-tap
stencil of the pulse's profile); :func:`sarcli.formers.backprojection._rows.orient` runs them on
the transposed problem when that puts the rows across the look direction. Per case, one thread,
CPU seconds, best of ``--repeat``, every configuration timed in turn within each round (A B C A B C):

- ``along, 640 KiB``: rows along the look direction and 640 KiB of profiles a pass (the reference);
- ``across, f x L2`` and ``along, f x L2`` for the fractions ``--fractions`` of the L2 size
  :func:`sarcli.formers.backprojection._rows.l2_cache_bytes` reads.

Cases: ``gotcha`` and ``orbit`` (bench_bp_peer.py's: GOTCHA 4 files onto 800² of 0.125 m, the 740 km
orbit onto 1024² of 0.5 m) and ``r<metres>`` (bench_bp_range.py's collection at that slant range,
``--n`` pixels a side and ``--pulses``). All use ``form_image``'s default (float32, cubic, upsample
16); every collection here looks along x (antennas near azimuth 0), so the rows across the look
direction are the transposed problem, the one :class:`~sarcli.formers.backprojection.Setup` picks. Usage::

    python bench/bench_bp_orient.py [--cases gotcha,orbit,r50,r1000,r10000] [--repeat 3]
                                    [--fractions 0.25,0.5,0.75,1,2] [--n 512] [--pulses 512]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_bp_peer as peer  # noqa: E402
import bench_bp_range as brange  # noqa: E402

import sarcli.formers.backprojection._rows as bp_rows  # noqa: E402
import sarcli.formers.backprojection._setup as bp_setup  # noqa: E402
from sarcli.core.collection import Collection  # noqa: E402
from sarcli.formers.backprojection import backproject  # noqa: E402
from sarcli.formers.options import BackprojectionOptions  # noqa: E402

DEFAULT = BackprojectionOptions()
REFERENCE_BYTES = 640 * 1024


def case(name, n, pulses):
    """(label, data, Collection, grid) of a case name."""
    if name == "gotcha":
        c = peer.gotcha_case(4)
        if c is None:
            return None
    elif name == "orbit":
        c = peer.orbit_case()
    else:
        data, freq, a, r0, grid, _ = brange.problem(float(name[1:]), n, pulses)
        c = (f"{float(name[1:]):g} m, {pulses} pulses onto {n}²", data, freq, a, r0, grid)
    label, data, freq, a, r0, grid = c
    return label, data, Collection(freq, a, r0), grid


def run(data, col, grid, across, cache_bytes):
    """CPU seconds of one call with the rows across (or along) the look direction."""
    bp_setup._CACHE_BYTES = int(cache_bytes)
    steps = bp_rows.row_steps(col.antenna_position_m, col.antenna_position_m, grid)
    along_x = steps[0] >= steps[1]                  # the x rows run along the look direction
    transposed = along_x if across else not along_x
    bp_setup.row_steps = (lambda a, b, g: (1.0, 0.0)) if transposed else (lambda a, b, g: (0.0, 1.0))
    try:
        t = time.process_time()
        backproject(data, col, grid, DEFAULT, nthreads=1)
        return time.process_time() - t
    finally:
        bp_setup.row_steps = bp_rows.row_steps


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="gotcha,orbit,r50,r1000,r10000")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--fractions", default="0.25,0.5,0.75,1,2", help="pulse block sizes as fractions of L2")
    ap.add_argument("--n", type=int, default=512)
    ap.add_argument("--pulses", type=int, default=512)
    opts = ap.parse_args(argv)
    l2 = bp_rows.l2_cache_bytes()
    chosen = bp_setup._CACHE_BYTES
    fractions = [float(f) for f in opts.fractions.split(",") if f]
    print(f"L2 {l2 // 1024} KiB a core; the pulse block fills {bp_rows.CACHE_FRACTION:g} of it "
          f"({chosen // 1024} KiB); one thread, CPU s, best of {opts.repeat}; load average "
          f"{os.getloadavg()[0]:.1f} at start")
    for name in opts.cases.split(","):
        c = case(name, opts.n, opts.pulses)
        if c is None:
            print(f"\n{name}: no GOTCHA files, skipped")
            continue
        label, data, col, grid = c
        st = bp_setup.Setup(data.shape, col, grid, DEFAULT.upsample, DEFAULT.interp, DEFAULT.precision)
        sx, sy = bp_rows.row_steps(col.antenna_position_m, col.antenna_position_m, grid)
        confs = [("along", REFERENCE_BYTES)] + [(o, f * l2) for f in fractions for o in ("across", "along")]
        best = {}
        for _ in range(opts.repeat):
            for across, nbytes in confs:
                t = run(data, col, grid, across == "across", nbytes)
                best[(across, nbytes)] = min(best.get((across, nbytes), np.inf), t)
        ref = best[confs[0]]
        print(f"\n{label}: range step a pixel along x {sx:.3g} m, along y {sy:.3g} m; the former runs "
              f"{'transposed' if st.transposed else 'as is'} ({st.model}, {st.width}; a lane group spans "
              f"{st.orientation.lines:.2g} lines of profile)")
        print("| rows | profiles a pass | CPU s | speed-up over along, 640 KiB |")
        print("|---|---|---|---|")
        for across, nbytes in confs:
            frac = "" if (across, nbytes) == confs[0] else f" ({nbytes / l2:g} L2)"
            print(f"| {across} | {int(nbytes) // 1024} KiB{frac} | {best[(across, nbytes)]:.3f} | "
                  f"{ref / best[(across, nbytes)]:.3f} |")
    bp_setup._CACHE_BYTES = chosen
    print(f"\nload average {os.getloadavg()[0]:.1f} at end")


if __name__ == "__main__":
    main()
