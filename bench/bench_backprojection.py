"""Backprojection speed against the C anchor ``bp_anchor.c`` of the shared benchmark folder (no assertions).

Builds the anchor into a temporary folder, runs it and :func:`sarcli.formers.backprojection.backproject`
at the same image side and pulse count, and prints a markdown table of

- pixel-pulses per second per core, and the ratio to the anchor (target >= 0.5),
- the 1 -> 2 thread speed-up as a fraction of linear (target >= 0.7), and, because a shared
  machine may not give the process two cores, the ratio of process CPU seconds with 1 and 2
  threads (the speed-up fraction two free cores would give: 1.0 = no parallel overhead),
- peak Python-heap memory of one call (tracemalloc; numpy buffers, not the kernels' small
  per-thread scratch) vs 3 x (phase history + image) bytes, the phase history complex64 and the
  image as returned (complex128),
- the first call in a fresh process (import and kernel load; the kernels are compiled when the
  package is installed).

Usage::

    python bench/bench_backprojection.py [--sizes 512x256,1024x512] [--repeat 3]

The anchor is a single-thread float32 linear-interpolation loop, so the like-for-like row is our
``precision='float32', interp='linear'``; the default settings (cubic, upsample 8) are listed too.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

from sarcli import _native
from sarcli.core import geometry
from sarcli.core.collection import Collection
from sarcli.formers.backprojection import backproject
from sarcli.formers.options import BackprojectionOptions
from sarcli.core.grid import Grid

#: The C yardstick, from the shared folder beside the repository (``$SARCLI_BP_ANCHOR`` overrides).
ANCHOR = Path(os.environ.get("SARCLI_BP_ANCHOR",
                            Path(__file__).resolve().parents[2] / "shared" / "bench" / "bp_anchor.c"))


def build_anchor(tmp: Path) -> Path | None:
    """Compile the anchor with the flags it documents; None if gcc or the source is missing.
    ``$SARCLI_ANCHOR_MARCH`` replaces ``-march=native`` (``x86-64-v3``: the AVX2 yardstick, to set
    beside sarcli's AVX2 copy, ``SARCLI_BP_ISA=1``)."""
    if not ANCHOR.exists() or shutil.which("gcc") is None:
        return None
    exe = tmp / "bp_anchor"
    subprocess.run(["gcc", "-O3", "-ffast-math", f"-march={os.environ.get('SARCLI_ANCHOR_MARCH', 'native')}", "-fopenmp-simd", str(ANCHOR),
                    "-o", str(exe), "-lm"], check=True, capture_output=True)
    return exe


def run_anchor(exe: Path, n: int, pulses: int, repeat: int) -> float:
    """Best pixel-pulses/s (one core) over ``repeat`` runs."""
    best = 0.0
    for _ in range(repeat):
        out = subprocess.run([str(exe), str(n), str(pulses)], check=True, capture_output=True,
                             text=True).stdout
        best = max(best, float(re.search(r"([0-9.eE+]+) pixel-pulses/s", out).group(1)))
    return best


def problem(n: int, pulses: int, m: int = 512):
    """An X-band circular-path collection whose unambiguous window covers the n x n, 0.25 m grid."""
    grid = Grid(n, n, 0.25, 0.25)
    half_diag = grid.half_diagonal
    el = np.radians(30.0)
    dalpha = geometry.C / (4.0 * 1.1 * half_diag * np.cos(el))   # window radius 1.1 x the corner
    freq = 10e9 - dalpha * m / 2 + dalpha * np.arange(m)
    az = np.radians(np.linspace(-1.5, 1.5, pulses))
    a = geometry.antenna_positions_circle(az, el, 10e3)
    r0 = np.linalg.norm(a, axis=1)
    rng = np.random.default_rng(1)
    data = (rng.normal(size=(pulses, m)) + 1j * rng.normal(size=(pulses, m))).astype(np.complex64)
    return data, freq, a, r0, grid


_COMPILE_SNIPPET = """
import time, numpy as np
t0 = time.perf_counter()
from sarcli.formers.backprojection import backproject
from sarcli.formers.options import BackprojectionOptions
from sarcli.core.collection import Collection
from sarcli.core.grid import Grid
t1 = time.perf_counter()
a = np.array([[-1e4, 0.0, 5e3], [-1e4, 10.0, 5e3]]); r0 = np.linalg.norm(a, axis=1)
f = 1e10 + 1e6 * np.arange(8); d = np.ones((2, 8), complex)
backproject(d, Collection(f, a, r0), Grid(8, 8, 0.5, 0.5), BackprojectionOptions(precision="{precision}"))
print(t1 - t0, time.perf_counter() - t1)
"""


def compile_seconds(precision: str, tmp: Path) -> float:
    """Seconds of the first call in a fresh process (after the import)."""
    out = subprocess.run([sys.executable, "-c", _COMPILE_SNIPPET.format(precision=precision)],
                         check=True, capture_output=True, text=True).stdout
    return float(out.split()[1])


def time_ours(args, options, threads: int, repeat: int):
    """Best wall seconds and best process CPU seconds over ``repeat`` calls."""
    best, best_cpu = np.inf, np.inf
    for _ in range(repeat):
        c = time.process_time()
        t = time.perf_counter()
        backproject(*args, options, nthreads=threads)
        best = min(best, time.perf_counter() - t)
        best_cpu = min(best_cpu, time.process_time() - c)
    return best, best_cpu


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="512x256,1024x512", help="image side x pulses, comma separated")
    ap.add_argument("--repeat", type=int, default=5, help="best of this many runs (shared machines are noisy)")
    opts = ap.parse_args(argv)
    sizes = [tuple(int(v) for v in s.split("x")) for s in opts.sizes.split(",")]
    cores = min(2, _native.threads(), os.cpu_count() or 1)
    variants = [("float32 linear u=4 (like the anchor)",
                 BackprojectionOptions(precision="float32", interp="linear", upsample=4)),
                ("float32 cubic u=8", BackprojectionOptions(precision="float32", interp="cubic", upsample=8)),
                ("default (float64 cubic)", BackprojectionOptions(precision="float64"))]
    rows = []
    load_start = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        exe = build_anchor(Path(tmp))
        compile_s = {p: compile_seconds(p, Path(tmp)) for p in ("float32", "float64")}
        for n, pulses in sizes:
            anchor = run_anchor(exe, n, pulses, opts.repeat) if exe else float("nan")
            data, freq, a, r0, grid = problem(n, pulses)
            args = (data, Collection(freq, a, r0), grid)
            # backproject returns complex128 whatever the working precision
            budget = 3 * (data.nbytes + n * n * np.dtype(np.complex128).itemsize)
            for name, kw in variants:
                d0, f0, a0, r00, _ = problem(16, 2)
                backproject(d0, Collection(f0, a0, r00), Grid(16, 16, 0.25, 0.25), kw)  # load the kernels
                t1, c1 = time_ours(args, kw, 1, opts.repeat)
                t2, c2 = time_ours(args, kw, cores, opts.repeat) if cores > 1 else (t1, c1)
                tracemalloc.start()
                backproject(*args, kw, nthreads=cores)
                peak = tracemalloc.get_traced_memory()[1]
                tracemalloc.stop()
                rate1 = n * n * pulses / t1
                rows.append((f"{n}² × {pulses}", name, anchor, rate1, rate1 / anchor,
                             t1, t2, t1 / t2 / cores, c1 / c2, compile_s[kw.precision],
                             peak / 2**20, budget / 2**20))
    print(f"machine: {os.cpu_count()} cores; kernel threads {_native.threads()}, SIMD "
          f"{_native.simd_level()}; python {sys.version.split()[0]}; load average "
          f"{load_start:.1f} at start, {os.getloadavg()[0]:.1f} at end (a shared machine: a load "
          f"above the core count slows both codes and makes the thread speed-up meaningless)\n")
    print("| size | ours | anchor px·pulse/s/core | ours px·pulse/s/core | ratio | t 1 thr (s) "
          "| t 2 thr (s) | speed-up / linear | CPU s 1 thr / CPU s 2 thr | first call (s) | peak MiB "
          "| 3×(PH+img) MiB |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:.3g} | {r[3]:.3g} | {r[4]:.2f} | {r[5]:.3f} | {r[6]:.3f} "
              f"| {r[7]:.2f} | {r[8]:.2f} | {r[9]:.2f} | {r[10]:.1f} | {r[11]:.1f} |")


if __name__ == "__main__":
    main()
