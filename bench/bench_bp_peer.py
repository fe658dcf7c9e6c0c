"""Backprojection on GOTCHA against the numpy peer everyone starts from, in the same run (no assertions).

The peer is Gorham & Moore's bpBasic as written in numpy: for each pulse, an 8x zero-padded
inverse FFT into a range profile, the differential range of every pixel, linear interpolation of
the profile at it, the carrier phase ``exp(i 4π α_min Δr / c)``, and accumulation. sarcli's
backprojection runs with its default settings (float64, cubic, upsample 8) and with the peer's
(linear, upsample 8). Both are measured against the exact matched filter (``direct``) on a strided
sub-grid covering the whole image. Target (issue 13): default ≥ 10x the peer at ≤ 1e-3 error.

    python bench/bench_bp_peer.py [--extent 100] [--pixel-size 0.25] [--files N]

GOTCHA files: $SARCLI_GOTCHA_DIR, else ../shared/data/gotcha beside the repository.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from sarcli.analysis.benchmark import reference_grid
from sarcli.core.geometry import C
from sarcli.formers.formation import form_image, image_error
from sarcli.io.gotcha import read_gotcha

GOTCHA_DIR = Path(os.environ.get("SARCLI_GOTCHA_DIR") or Path(__file__).resolve().parents[2] / "shared" / "data" / "gotcha")


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


def _timed(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, statistics.median(times)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--extent", type=float, default=100.0)
    ap.add_argument("--pixel-size", type=float, default=0.25)
    ap.add_argument("--files", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    files = sorted(GOTCHA_DIR.glob("data_3dsar_pass1_az00*_HH.mat"))[:args.files]
    if not files:
        print(f"no GOTCHA files in {GOTCHA_DIR}: set SARCLI_GOTCHA_DIR")
        return 0
    ph = read_gotcha(files)
    acq = ph.acquisition
    img0 = form_image(ph, "backprojection", extent=args.extent, pixel_size=args.pixel_size)  # compile, grid
    grid = img0.grid
    sub, rows, cols, _ = reference_grid(ph, grid, max_cost=4e9)
    ref = form_image(ph, "direct", grid=sub).image
    if acq.frequency_hz.ndim != 1:
        print("per-pulse frequencies: the peer needs one frequency axis")
        return 0
    peer, t_peer = _timed(lambda: bp_basic(ph.data, acq.frequency_hz, acq.antenna_position_m,
                                           acq.range_to_center_m, grid), 1)
    rows_out = [("numpy bpBasic peer (linear, 8x)", t_peer, image_error(peer[np.ix_(rows, cols)], ref))]
    for label, kw in [("sarcli default (float64 cubic, 8x)", {}),
                      ("sarcli float32 cubic, 8x", {"precision": "float32"}),
                      ("sarcli peer settings (float64 linear, 8x)", {"interp": "linear"}),
                      ("sarcli float32 linear, 8x", {"interp": "linear", "precision": "float32"})]:
        img, t = _timed(lambda: form_image(ph, "backprojection", grid=grid, **kw).image, args.repeat)
        rows_out.append((label, t, image_error(img[np.ix_(rows, cols)], ref)))
    print(f"# GOTCHA, {len(files)} files ({ph.data.shape[0]} pulses x {ph.data.shape[1]} frequencies), "
          f"{grid.nx} x {grid.ny} pixels of {grid.dx:g} m; reference: direct on a {sub.nx} x {sub.ny} strided "
          f"sub-grid; {os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}")
    print(f"| {'what':<42} | seconds | speed-up vs peer | error vs direct |")
    print("|---|---|---|---|")
    for label, t, err in rows_out:
        print(f"| {label:<42} | {t:7.3f} | {t_peer / t:6.1f}x | {err:.2e} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
