"""``sar autofocus`` on the GOTCHA pass-1 HH files, as delivered and with a seeded injected error
(no assertions; prints a markdown table).

For the four files on the default grid (400 × 400 at 0.25 m):

1. whole-process wall time of ``sar form-image`` (default method) and of ``sar autofocus``
   (default method), and their ratio (target ≤ 5);
2. raw data: entropy of the autofocused image over the raw image's (target ≤ 0.99);
3. raw data with an injected error (:func:`sarcli.autofocus._common.synthetic_phase_error`:
   quadratic 4 rad at the aperture ends + smooth ~1 rad + jitter 0.15 rad rms; seeds
   ``--seeds``): entropy over the raw image's (target ≤ 1), relative magnitude error against the
   command's own correction of the raw data (target ≤ 0.10), and the rms of what is left of the
   injected error (estimate on injected data minus estimate on raw data, against the injected
   error, constant and linear part removed).

Entropies are of backprojected images (:func:`sarcli.autofocus._common.form`) on the full grid.

Usage: ``python bench/bench_autofocus.py [--seeds 0,1,2] [--files DIR]`` (says it skipped, and exits 0,
when the files are absent).
"""

from __future__ import annotations

import argparse
import os
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


def _run(*args) -> tuple[float, str]:
    t = time.perf_counter()
    out = subprocess.run([*SAR, *map(str, args)], capture_output=True, text=True, check=True)
    return time.perf_counter() - t, out.stdout.strip() + out.stderr.strip()


def main():
    from sarcli.analysis.speckle import image_entropy
    from sarcli.autofocus import remove_linear_phase
    from sarcli.autofocus._common import form, synthetic_phase_error
    from sarcli.core.types import PhaseHistory
    from sarcli.io.hdf5 import read_phase_history, write_phase_history

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--files", default=str(GOTCHA_DIR))
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
        t_form, _ = _run("form-image", raw_h5, "-o", tmp / "img.h5")
        t_af, msg = _run("-v", "autofocus", raw_h5, "-o", tmp / "af.h5")
        af_raw = read_phase_history(tmp / "af.h5")
        est_raw = np.asarray(af_raw.attrs.get("autofocus_phase_rad", np.zeros(P)))
        h_raw = image_entropy(form(ph, grid))
        img_af_raw = np.abs(form(af_raw, grid))
        print(f"GOTCHA pass 1 HH, {P} pulses, grid {grid.ny} x {grid.nx} at {grid.dx} m")
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
            t, msg = _run("-v", "autofocus", tmp / "bad.h5", "-o", tmp / "bad_af.h5")
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
        print(f"\nsar form-image (default method): {t_form:.1f} s whole process")


if __name__ == "__main__":
    main()
