"""Backprojection against its peers in one run: FastSAR, the numpy bpBasic port, the C anchor (no assertions).

Two cases, each timed in this process (sarcli) and in a subprocess (FastSAR), alternating A B A B:

- ``gotcha``: the AFRL GOTCHA pass files (4 by default), a 100 m grid of 0.125 m pixels (800²);
- ``orbit``: a simulated X-band spotlight from a 740 km orbit (look angle 35°, 1.8° of aperture),
  1024 pulses x 1024 frequencies over 300 MHz, 16 point targets, a 1024² grid of 0.5 m pixels.

Wall seconds and CPU seconds (summed over threads; on a shared, loaded machine the more stable
measure of the work) are the best of the calls. Every image is compared with sarcli's exact matched filter (``direct``) on a strided sub-grid
(:func:`sarcli.analysis.accuracy.reference_grid`). FastSAR's image is the unnormalised, unwindowed
sum over pulses and frequencies, ``[nx, ny]`` on the grid ``x_i = (i - nx/2) dx`` about a centre;
the script transposes it, passes the same frequency line sarcli's backprojection uses (least
squares, :func:`sarcli.core.sampling.frequency_line`) and the same reference ranges, and
before measuring its error divides out one complex factor, the least-squares fit of FastSAR's
sub-grid to the reference (normalisation ``P M`` and any global phase convention; measured: the
fit is ``1/(P M)`` to ~1e-6 with zero phase, so the conventions agree).

FastSAR (PyPI ``fastsar``, C++/OpenMP) is a baseline, never a dependency: it lives in its own
virtual environment, by default ``/work/venv-fastsar`` (``$SARCLI_FASTSAR_PYTHON`` names its python)::

    python3 -m venv /work/venv-fastsar && /work/venv-fastsar/bin/pip install fastsar

Without it the FastSAR rows are skipped with a note. The C anchor ``bp_anchor.c`` (see
bench_backprojection.py) gives per-core pixel-pulse rates for the float32 linear upsample-4 row and
the default, both measured here on one thread in CPU seconds (the anchor's include its set-up of
random profiles, under 2 % of its run). Usage::

    python bench/bench_bp_peer.py [--case gotcha,orbit] [--repeat 2] [--files 4] [--bpbasic]

GOTCHA files: ``sarcli.io.gotcha.gotcha_dir()`` ($SARCLI_GOTCHA_DIR, else ../shared/data/gotcha beside the
repository).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_backprojection import build_anchor  # noqa: E402

from sarcli.analysis.accuracy import reference_grid  # noqa: E402
from sarcli.core import geometry  # noqa: E402
from sarcli.core.geometry import C  # noqa: E402
from sarcli.core.grid import Grid  # noqa: E402
from sarcli.core.sampling import frequency_line  # noqa: E402
from sarcli.formers.backprojection import DEFAULT_PRECISION, backproject  # noqa: E402
from sarcli.formers.direct import direct_spherical  # noqa: E402
from sarcli.formers.formation import image_error  # noqa: E402
from sarcli.io.gotcha import gotcha_dir, gotcha_files  # noqa: E402
from sarcli.core.collection import Collection  # noqa: E402
from sarcli.formers.options import BackprojectionOptions  # noqa: E402

GOTCHA_DIR = gotcha_dir()
FASTSAR_PY = Path(os.environ.get("SARCLI_FASTSAR_PYTHON", "/work/venv-fastsar/bin/python"))

_FASTSAR_WORKER = r"""
import json, sys, time
import numpy as np
import fastsar
z = np.load(sys.argv[1])
S = z["data"]
t0 = time.perf_counter()
former = fastsar.ExactFormer(z["ant"], float(z["fmin"]), float(z["df"]), S.shape[1], int(z["nx"]), int(z["ny"]),
                             float(z["dx"]), float(z["dy"]), backend="cpu", window=False, interp="cubic",
                             upsample=int(z["upsample"]), ref=z["r0"], center=z["center"])
setup = time.perf_counter() - t0
former(S)  # first call: loads the compiled kernel
times, cpus = [], []
for _ in range(int(z["repeat"])):
    t0, c0 = time.perf_counter(), time.process_time()
    img = former(S)
    times.append(time.perf_counter() - t0)
    cpus.append(time.process_time() - c0)
np.save(sys.argv[2], img)
print(json.dumps({"setup": setup, "times": times, "cpus": cpus, "tile": list(former.tile),
                  "version": fastsar.__version__}))
"""


def bp_basic(data, freq, pos, r0, grid, upsample=8):
    """Gorham & Moore's bpBasic, per pulse in numpy (the peer), normalised like the matched filter."""
    P, M = data.shape
    n_fft = int(2 ** np.ceil(np.log2(upsample * M)))
    dalpha = (freq[-1] - freq[0]) / (M - 1)
    max_wr = C / (2 * dalpha)
    dr_axis = np.linspace(-n_fft / 2, n_fft / 2 - 1, n_fft) * max_wr / n_fft
    x, y = np.meshgrid(grid.x, grid.y)
    img = np.zeros(x.shape, complex)
    for p in range(P):
        rc = np.fft.fftshift(np.fft.ifft(data[p], n_fft)) * n_fft
        dr = np.sqrt((pos[p, 0] - x) ** 2 + (pos[p, 1] - y) ** 2 + pos[p, 2] ** 2) - r0[p]
        ph = np.exp(1j * 4 * np.pi * freq[0] / C * dr)
        img += (np.interp(dr, dr_axis, rc.real) + 1j * np.interp(dr, dr_axis, rc.imag)) * ph
    return img / (P * M)


def gotcha_case(n_files):
    from sarcli.io.gotcha import read_gotcha

    files = gotcha_files(GOTCHA_DIR)[:n_files]
    if not files:
        return None
    ph = read_gotcha(files)
    acq = ph.acquisition
    grid = Grid.from_extent(100.0, 0.125)
    return (f"GOTCHA {len(files)} files", ph.data, acq.frequency_hz, acq.antenna_position_m,
            acq.range_to_center_m, grid)


def orbit_case():
    """X-band spotlight from 740 km altitude: 1024 pulses x 1024 frequencies, 1024² pixels of 0.5 m."""
    P = M = 1024
    h, look = 740e3, np.radians(35.0)
    ground = h * np.tan(look)
    slant = np.hypot(h, ground)
    half_ap = slant * np.tan(np.radians(0.9))
    ys = np.linspace(-half_ap, half_ap, P)
    a = np.column_stack([np.full(P, -ground), ys, np.full(P, h)])
    r0 = np.linalg.norm(a, axis=1)
    freq = 9.65e9 - 150e6 + np.arange(M) * (300e6 / M)
    rng = np.random.default_rng(4)
    pts = np.column_stack([rng.uniform(-240, 240, 16), rng.uniform(-240, 240, 16), np.zeros(16)])
    amps = rng.normal(size=16) + 1j * rng.normal(size=16)
    dr = geometry.differential_range(a, r0, pts)                       # [P, S]
    data = np.zeros((P, M), np.complex128)
    k = 4 * np.pi * freq / C
    for s in range(pts.shape[0]):
        data += amps[s] * np.exp(-1j * k[None, :] * dr[:, s:s + 1])
    return "orbit 740 km", data.astype(np.complex64), freq, a, r0, Grid(1024, 1024, 0.5, 0.5)


def run_fastsar(tmp, data, freq, a, r0, grid, repeat):
    """FastSAR's ExactFormer (cpu) in its own venv: (image [ny, nx], call seconds, info) or None."""
    if not FASTSAR_PY.exists():
        return None
    f = np.asarray(freq, float)
    f = f[0] if f.ndim == 2 else f
    m = f.size
    a_ref, df = frequency_line(f[None, :], m // 2)
    fmin = float(a_ref[0] - (m // 2) * df[0])
    if df[0] < 0:
        return None
    inp, out = Path(tmp) / "fastsar_in.npz", Path(tmp) / "fastsar_out.npy"
    center = np.array([grid.x[grid.nx // 2] - 0.0, grid.y[grid.ny // 2], 0.0])
    np.savez(inp, data=np.asarray(data, np.complex64), ant=a, r0=r0, fmin=fmin, df=float(df[0]),
             nx=grid.nx, ny=grid.ny, dx=grid.dx, dy=grid.dy, center=center, upsample=8, repeat=repeat)
    res = subprocess.run([str(FASTSAR_PY), "-c", _FASTSAR_WORKER, str(inp), str(out)], capture_output=True,
                         text=True)
    if res.returncode != 0:
        print(f"note: FastSAR failed: {res.stderr.strip().splitlines()[-1:]}")
        return None
    info = json.loads(res.stdout.strip().splitlines()[-1])
    img = np.load(out).T    # [nx, ny] -> [ny, nx]
    return img, min(info["times"]), min(info["cpus"]), info


def fit_scale(img, ref):
    """The complex factor s minimising |s img - ref| (normalisation and global phase)."""
    return np.vdot(img, ref) / np.vdot(img, img)


def timed(fn, repeat):
    """(result, best wall seconds, best CPU seconds of all threads) over ``repeat`` calls."""
    best, best_cpu, out = np.inf, np.inf, None
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        best = min(best, time.perf_counter() - t0)
        best_cpu = min(best_cpu, time.process_time() - c0)
    return out, best, best_cpu


def run_case(case, args, tmp, exe):
    name, data, freq, a, r0, grid = case
    P, M = data.shape
    ph_like = type("PH", (), {})()
    ph_like.data = data
    sub, rows, cols, _ = reference_grid(ph_like, grid, max_cost=args.max_cost)
    t0 = time.perf_counter()
    ref = direct_spherical(data, freq, a, r0, sub)
    t_ref = time.perf_counter() - t0
    pick = np.ix_(rows, cols)
    out = []
    col = Collection(freq, a, r0)
    backproject(data[:2], col.pulses(slice(0, 2)), Grid(16, 16, grid.dx, grid.dy))  # load the kernels
    default = lambda: backproject(data, col, grid, BackprojectionOptions(precision=DEFAULT_PRECISION))  # noqa: E731
    fs_runs, ours_runs = [], []
    img = None
    for _ in range(args.repeat):  # A B A B, two calls each
        res = run_fastsar(tmp, data, freq, a, r0, grid, repeat=2)
        if res is not None:
            fs_runs.append(res)
        img, t, c = timed(default, 2)
        ours_runs.append((t, c))
    out.append(("sarcli default (%s, %s, upsample %g)" % (DEFAULT_PRECISION, _default_interp(), _default_upsample()), min(r[0] for r in ours_runs),
                min(r[1] for r in ours_runs), image_error(img[pick], ref)))
    if fs_runs:
        fimg, _, _, info = fs_runs[-1]
        s = fit_scale(fimg[pick], ref)
        out.append((f"FastSAR {info['version']} ExactFormer cpu (cubic, upsample 8, tile {info['tile']})",
                    min(r[1] for r in fs_runs), min(r[2] for r in fs_runs), image_error(s * fimg[pick], ref)))
        note = f"FastSAR scale fit: |s| P M = {abs(s) * P * M:.6f}, arg s = {np.angle(s):.2e} rad"
    else:
        note = f"FastSAR skipped: no {FASTSAR_PY} (create it: python3 -m venv /work/venv-fastsar && " \
               "/work/venv-fastsar/bin/pip install fastsar)"
    for label, kw in [("sarcli float64 " + _default_interp(), BackprojectionOptions(precision="float64")),
                      ("sarcli float32 linear upsample 4",
                       BackprojectionOptions(precision="float32", interp="linear", upsample=4))]:
        im, t, c = timed(lambda: backproject(data, col, grid, kw), args.repeat)
        out.append((label, t, c, image_error(im[pick], ref)))
    if args.bpbasic and np.ndim(freq) == 1:
        im, t, c = timed(lambda: bp_basic(data, freq, a, r0, grid), 1)
        out.append(("numpy bpBasic (linear, upsample 8)", t, c, image_error(im[pick], ref)))
    # per-core rates against the C anchor: one thread each, same pulse count, image side up to
    # 512, CPU seconds (a loaded machine stretches wall time, not CPU time), alternating
    n = min(512, grid.nx)
    small = Grid(n, n, grid.dx, grid.dy, grid.x[grid.nx // 2], grid.y[grid.ny // 2])
    variants = [("default", BackprojectionOptions(precision=DEFAULT_PRECISION)),
                ("float32 linear u=4", BackprojectionOptions(precision="float32", interp="linear", upsample=4))]
    rates = {label: 0.0 for label, _ in variants}
    anchor = 0.0 if exe else float("nan")
    for _ in range(args.repeat):
        for label, kw in variants:
            c0 = time.process_time()
            backproject(data, col, small, kw, nthreads=1)
            rates[label] = max(rates[label], n * n * P / (time.process_time() - c0))
        if exe:
            anchor = max(anchor, anchor_cpu_rate(exe, n, P))
    return name, data.shape, grid, sub, t_ref, out, note, rates, anchor


def anchor_cpu_rate(exe, n, pulses):
    """The C anchor's pixel-pulses per CPU second (its own process: the child's CPU time)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([str(exe), str(n), str(pulses)], check=True, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return n * n * pulses / cpu


def _default_upsample():
    from sarcli.formers.backprojection import DEFAULT_UPSAMPLE

    return DEFAULT_UPSAMPLE


def _default_interp():
    from sarcli.formers.backprojection import DEFAULT_INTERP

    return DEFAULT_INTERP


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="gotcha,orbit")
    ap.add_argument("--files", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--max-cost", type=float, default=1e9, help="P·M·pixels of the direct reference")
    ap.add_argument("--bpbasic", action="store_true", help="also run the numpy bpBasic port (slow)")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        exe = build_anchor(Path(tmp))
        for which in args.case.split(","):
            case = gotcha_case(args.files) if which == "gotcha" else orbit_case()
            if case is None:
                print(f"no GOTCHA files in {GOTCHA_DIR}: set SARCLI_GOTCHA_DIR")
                continue
            name, shape, grid, sub, t_ref, rows, note, rates, anchor = run_case(case, args, tmp, exe)
            print(f"\n# {name}: {shape[0]} pulses x {shape[1]} frequencies, {grid.nx} x {grid.ny} pixels of "
                  f"{grid.dx:g} m; reference: direct on a {sub.nx} x {sub.ny} strided sub-grid ({t_ref:.0f} s); "
                  f"{os.cpu_count()} cores, load {load0:.1f} -> {os.getloadavg()[0]:.1f}")
            fs = next(((t, c) for label, t, c, _ in rows if label.startswith("FastSAR")), None)
            print("| what | seconds | CPU seconds (all threads) | FastSAR / this: seconds | CPU seconds "
                  "| error vs direct |")
            print("|---|---|---|---|---|---|")
            for label, t, c, err in rows:
                r1, r2 = (f"{fs[0] / t:.2f}", f"{fs[1] / c:.2f}") if fs else ("-", "-")
                print(f"| {label} | {t:.3f} | {c:.3f} | {r1} | {r2} | {err:.2e} |")
            print(note)
            print(f"per core (1 thread, {min(512, grid.nx)}² pixels x {shape[0]} pulses, per CPU second): "
                  f"C anchor {anchor:.3g} pixel-pulses/s; sarcli default {rates['default']:.3g} ({rates['default'] / anchor:.2f}x the "
                  f"anchor), float32 linear u=4 {rates['float32 linear u=4']:.3g} "
                  f"({rates['float32 linear u=4'] / anchor:.2f}x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
