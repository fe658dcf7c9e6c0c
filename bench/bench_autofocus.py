"""``sar autofocus`` on the GOTCHA pass-1 HH files, as delivered and with a seeded injected error
(no assertions; prints a markdown table).

For the four files on the default grid (400 × 400 at 0.25 m):

1. whole-process wall and CPU time of ``sar form-image`` (default method) and of
   ``sar autofocus`` (default method), run alternately ``--repeats`` times each (A B A B: on
   shared cores neighbouring runs see the same load), and the range of their ratios run for run
   (target ≤ 5);
2. raw data: entropy of the autofocused image over the raw image's (target ≤ 0.99);
3. raw data with an injected error (:func:`sarcli.autofocus._common.synthetic_phase_error`:
   quadratic 4 rad at the aperture ends + smooth ~1 rad + jitter 0.15 rad rms; seeds
   ``--seeds``): entropy over the raw image's (target ≤ 1), relative magnitude error against the
   command's own correction of the raw data (target ≤ 0.10), and the rms of what is left of the
   injected error (estimate on injected data minus estimate on raw data, against the injected
   error, constant and linear part removed).

Entropies are of backprojected images (:func:`sarcli.autofocus._common.form`) on the full grid.

Usage: ``python bench/bench_autofocus.py [--seeds 0,1,2] [--repeats 3] [--files DIR] [--method pga]``
(says it skipped, and exits 0, when the files are absent).
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sarcli.io.gotcha import gotcha_dir, gotcha_files

GOTCHA_DIR = gotcha_dir()
SAR = [sys.executable, "-m", "sarcli.cli.main"] if not (Path(sys.executable).parent / "sar").exists() else \
    [str(Path(sys.executable).parent / "sar")]


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _run(*args, cpu=False):
    """Wall time (and, with ``cpu``, the child's CPU time) of one ``sar`` command, and its output."""
    c, t = _cpu(), time.perf_counter()
    out = subprocess.run([*SAR, *map(str, args)], capture_output=True, text=True, check=True)
    wall, used = time.perf_counter() - t, _cpu() - c
    text = out.stdout.strip() + out.stderr.strip()
    return (wall, used, text) if cpu else (wall, text)


def main():
    from sarcli.analysis.speckle import image_entropy
    from sarcli.autofocus import remove_linear_phase
    from sarcli.autofocus._common import form, synthetic_phase_error
    from sarcli.core.types import PhaseHistory
    from sarcli.io.hdf5 import read_phase_history, write_phase_history

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--repeats", type=int, default=3, help="alternating runs of form-image and autofocus")
    ap.add_argument("--files", default=str(GOTCHA_DIR))
    ap.add_argument("--method", default="min-entropy", choices=("min-entropy", "pga"))
    a = ap.parse_args()
    files = gotcha_files(a.files)
    if len(files) < 4:  # nothing to measure without the data set; `make bench` goes on
        print(f"bench_autofocus: skipped, GOTCHA pass-1 HH files not found in {a.files}")
        return
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        raw_h5 = tmp / "raw.h5"
        _run("import", "gotcha", *files, "-o", raw_h5)
        ph = read_phase_history(raw_h5)
        grid, az, P = ph.acquisition.grid, ph.acquisition.azimuth_rad, ph.data.shape[0]
        pairs = []
        for _ in range(max(1, a.repeats)):  # A B A B
            pairs.append((_run("form-image", raw_h5, "-o", tmp / "img.h5", cpu=True),
                          _run("-v", "autofocus", raw_h5, "-o", tmp / "af.h5", "--method", a.method,
                               cpu=True)))
        wall = [b[0] / f[0] for f, b in pairs]
        cpu = [b[1] / f[1] for f, b in pairs]
        t_form, t_af, msg = pairs[-1][0][0], pairs[-1][1][0], pairs[-1][1][2]
        af_raw = read_phase_history(tmp / "af.h5")
        est_raw = np.asarray(af_raw.attrs.get("autofocus_phase_rad", np.zeros(P)))
        h_raw = image_entropy(form(ph, grid))
        img_af_raw = np.abs(form(af_raw, grid))
        print(f"GOTCHA pass 1 HH, {P} pulses, grid {grid.ny} x {grid.nx} at {grid.dx} m, "
              f"sar autofocus --method {a.method}")
        print(f"raw: {msg}")
        print()
        print("| case | sar autofocus (s) | / sar form-image | entropy / raw | magnitude error vs raw's correction "
              "| injected error left (rad rms) |")
        print("|---|---|---|---|---|---|")
        print(f"| raw | {t_af:.1f} | {t_af / t_form:.2f} | {image_entropy(img_af_raw) / h_raw:.4f} | | |")
        for seed in (int(s) for s in a.seeds.split(",")):
            err = synthetic_phase_error(P, seed)
            bad = PhaseHistory(ph.data * np.exp(1j * err)[:, None].astype(ph.data.dtype), ph.acquisition,
                               None, dict(ph.attrs))
            write_phase_history(tmp / "bad.h5", bad)
            t, msg = _run("-v", "autofocus", tmp / "bad.h5", "-o", tmp / "bad_af.h5", "--method", a.method)
            out = read_phase_history(tmp / "bad_af.h5")
            est = np.asarray(out.attrs.get("autofocus_phase_rad", np.zeros(P)))
            # the images may differ by a cross-range shift (an unobservable linear phase): align it
            r = err - (est - est_raw)
            lin = r - remove_linear_phase(r, az)
            img = np.abs(form(out, grid, lin))
            mag = np.linalg.norm(img - img_af_raw) / np.linalg.norm(img_af_raw)
            left = float(np.sqrt(np.mean(remove_linear_phase(r, az) ** 2)))
            print(f"| injected, seed {seed} | {t:.1f} | {t / t_form:.2f} | {image_entropy(img) / h_raw:.4f} | "
                  f"{mag:.4f} | {left:.3f} |", flush=True)
            print(f"<!-- {msg} -->")
        print(f"\nsar autofocus / sar form-image, whole process, {len(pairs)} alternating pairs: wall "
              f"{min(wall):.2f}-{max(wall):.2f}x, CPU {min(cpu):.2f}-{max(cpu):.2f}x (form-image "
              f"{min(f[0] for f, _ in pairs):.1f}-{max(f[0] for f, _ in pairs):.1f} s wall, "
              f"{min(f[1] for f, _ in pairs):.1f}-{max(f[1] for f, _ in pairs):.1f} s CPU; autofocus "
              f"{min(b[0] for _, b in pairs):.1f}-{max(b[0] for _, b in pairs):.1f} s wall, "
              f"{min(b[1] for _, b in pairs):.1f}-{max(b[1] for _, b in pairs):.1f} s CPU; load average "
              f"{os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
