"""Backprojection's AVX-512 and AVX2 copies against their yardsticks in one run: the C anchor at every range, FastSAR on GOTCHA and the orbit (no assertions).

One thread throughout (``OMP_NUM_THREADS=1`` for this process and FastSAR's), CPU seconds, and
every comparison timed alternately A B A B within the same instruction set, so that each ratio
compares two programs under the same load. Per instruction set (sarcli's kernels capped by
``$SARCLI_BP_ISA``: 2 AVX-512, 1 AVX2; the anchor compiled with ``-march=native`` or
``-march=x86-64-v3``; FastSAR compiled with its default flags, ``-march=native``, or with
``FFBP_CPU_FLAGS="-O3 -march=x86-64-v3"``, which its build takes in place of them):

- ranges: the collection of ``bench_bp_range.py`` (X band, 512 pulses onto 512² pixels) at 50 m
  to 1,000 km; the anchor's pixel-pulses per CPU second (``bp_anchor.c``, its process's CPU time)
  against sarcli's default (float32, cubic Lagrange, upsample 12) and float32 linear upsample 4;
- peers: the GOTCHA and 740 km orbit cases of ``bench_bp_peer.py``; FastSAR's ``ExactFormer``
  (cpu, cubic, upsample 8, no window; in its own virtual environment) against sarcli's default;
  both images against the exact matched filter (``direct``) on a strided sub-grid, FastSAR's after
  the one complex scale ``bench_bp_peer.fit_scale`` fits.

The machine's load is printed with the tables; ratios are the meaningful numbers. Usage::

    SARCLI_FASTSAR_PYTHON=/path/to/venv/bin/python python bench/bench_bp_isa.py \
        [--isa 2,1] [--ranges 50,200,1e3,1e4,7.4e5,1e6] [--rounds 3] [--case gotcha,orbit] [--files 4]
"""

from __future__ import annotations

import argparse
import os

os.environ["OMP_NUM_THREADS"] = "1"   # before numpy and the kernels load; FastSAR's worker inherits it

import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_bp_peer as peer  # noqa: E402
from bench_backprojection import build_anchor  # noqa: E402
from bench_bp_range import DEFAULT, problem  # noqa: E402

from sarcli import _native  # noqa: E402
from sarcli._native import using_threads  # noqa: E402
from sarcli.analysis.accuracy import reference_grid  # noqa: E402
from sarcli.formers.backprojection import backproject  # noqa: E402
from sarcli.formers.direct import direct_spherical  # noqa: E402
from sarcli.formers.formation import image_error  # noqa: E402
from sarcli.core.collection import Collection  # noqa: E402
from sarcli.formers.options import BackprojectionOptions  # noqa: E402

LINEAR = BackprojectionOptions(precision="float32", interp="linear", upsample=4)
ISA_NAME = {2: "AVX-512", 1: "AVX2", 0: "baseline"}
MARCH = {2: "native", 1: "x86-64-v3"}
FASTSAR_FLAGS = {2: None, 1: "-O3 -march=x86-64-v3"}


def set_isa(level: int) -> None:
    """Cap sarcli's kernels (read on every call) and pick FastSAR's flags for ``level``."""
    os.environ["SARCLI_BP_ISA"] = str(level)
    if FASTSAR_FLAGS[level] is None:
        os.environ.pop("FFBP_CPU_FLAGS", None)
    else:
        os.environ["FFBP_CPU_FLAGS"] = FASTSAR_FLAGS[level]


def cpu_seconds(fn) -> float:
    t = time.process_time()
    fn()
    return time.process_time() - t


def ranges_table(levels, ranges, n, pulses, rounds, anchors):
    """{(level, range): (anchor rate, default rate, linear rate)}, best of ``rounds`` A B C rounds."""
    out = {}
    for rng in ranges:
        data, freq, a, r0, grid, _ = problem(rng, n, pulses)
        args = (data, Collection(freq, a, r0), grid)
        for level in levels:
            set_isa(level)
            best = [0.0, 0.0, 0.0]
            with using_threads(1):
                backproject(*args, DEFAULT, nthreads=1)   # first call of this copy
                for _ in range(rounds):
                    best[0] = max(best[0], peer.anchor_cpu_rate(anchors[level], n, pulses))
                    for k, kw in ((1, DEFAULT), (2, LINEAR)):
                        t = cpu_seconds(lambda: backproject(*args, kw, nthreads=1))  # noqa: B023
                        best[k] = max(best[k], n * n * pulses / t)
            out[level, rng] = tuple(best)
    return out


def peers_table(levels, cases, rounds, max_cost, tmp):
    """[(case, level, FastSAR CPU s, sarcli CPU s, FastSAR error, sarcli error, note)]."""
    rows = []
    for name, data, freq, a, r0, grid in cases:
        sub, rr, cc, _ = reference_grid(type("PH", (), {"data": data})(), grid, max_cost=max_cost)
        ref = direct_spherical(data, freq, a, r0, sub)
        pick = np.ix_(rr, cc)
        for level in levels:
            set_isa(level)
            fs_best, ours_best, fimg, img, note = np.inf, np.inf, None, None, ""
            with using_threads(1):
                col = Collection(freq, a, r0)
                backproject(data[:2], col.pulses(slice(0, 2)), grid.__class__(16, 16, grid.dx, grid.dy))
                for _ in range(rounds):
                    res = peer.run_fastsar(tmp, data, freq, a, r0, grid, repeat=2)
                    if res is not None:
                        fimg, _, fcpu, info = res
                        fs_best = min(fs_best, fcpu)
                        note = f"FastSAR {info['version']}, tile {info['tile']}"
                    for _ in range(2):
                        t0 = time.process_time()
                        img = backproject(data, col, grid, DEFAULT, nthreads=1)
                        ours_best = min(ours_best, time.process_time() - t0)
            f_err = float("nan")
            if fimg is not None:
                f_err = image_error(peer.fit_scale(fimg[pick], ref) * fimg[pick], ref)
            rows.append((name, level, fs_best, ours_best, f_err, image_error(img[pick], ref), note))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--isa", default="2,1", help="instruction sets: 2 AVX-512, 1 AVX2")
    ap.add_argument("--ranges", default="50,200,1e3,1e4,7.4e5,1e6", help="slant ranges (m)")
    ap.add_argument("--n", type=int, default=512, help="image side of the range rows (pixels)")
    ap.add_argument("--pulses", type=int, default=512)
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds (best of)")
    ap.add_argument("--case", default="gotcha,orbit", help="peer cases ('' for none)")
    ap.add_argument("--files", type=int, default=4, help="GOTCHA files")
    ap.add_argument("--max-cost", type=float, default=3e8, help="P·M·pixels of the direct reference")
    opts = ap.parse_args(argv)
    have = _native.load("backprojection").isa_level()
    levels = [v for v in (int(s) for s in opts.isa.split(",")) if v <= have and v in MARCH]
    ranges = [float(r) for r in opts.ranges.split(",") if r]
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        anchors = {}
        for level in levels:
            os.environ["SARCLI_ANCHOR_MARCH"] = MARCH[level]
            d = Path(tmp) / f"anchor{level}"
            d.mkdir()
            anchors[level] = build_anchor(d)
        os.environ.pop("SARCLI_ANCHOR_MARCH", None)
        table = ranges_table(levels, ranges, opts.n, opts.pulses, opts.rounds, anchors) if ranges else {}
        cases = []
        for which in filter(None, opts.case.split(",")):
            c = peer.gotcha_case(opts.files) if which == "gotcha" else peer.orbit_case()
            if c is None:
                print(f"no GOTCHA files in {peer.GOTCHA_DIR}: set SARCLI_GOTCHA_DIR")
            else:
                cases.append(c)
        rows = peers_table(levels, cases, opts.rounds, opts.max_cost, tmp)
    print(f"one thread, CPU seconds; {os.cpu_count()} cores, load average {load0:.1f} at start, "
          f"{os.getloadavg()[0]:.1f} at end; best of {opts.rounds} alternating rounds\n")
    if table:
        print(f"## Against the C anchor ({opts.n}² pixels x {opts.pulses} pulses; pixel-pulses per CPU second)\n")
        print("| slant range | " + " | ".join(
            f"{ISA_NAME[v]}: anchor | default | default / anchor | linear u=4 / anchor" for v in levels) + " |")
        print("|---|" + "---|---|---|---|" * len(levels))
        for rng in ranges:
            cells = []
            for v in levels:
                an, d, lin = table[v, rng]
                cells.append(f"{an:.3g} | {d:.3g} | {d / an:.2f} | {lin / an:.2f}")
            print(f"| {rng:g} m | " + " | ".join(cells) + " |")
    if rows:
        print("\n## Against FastSAR's exact former (CPU seconds, one thread)\n")
        print("| case | copies | FastSAR s | sarcli default s | FastSAR / sarcli | FastSAR error | sarcli error |")
        print("|---|---|---|---|---|---|---|")
        for name, v, fs, ours, fe, oe, note in rows:
            print(f"| {name} | {ISA_NAME[v]} | {fs:.3f} | {ours:.3f} | {fs / ours:.2f} | {fe:.2e} | {oe:.2e} |")
        notes = sorted({r[6] for r in rows if r[6]})
        print("\n" + ("; ".join(notes) if notes else f"FastSAR skipped: no {peer.FASTSAR_PY}"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
