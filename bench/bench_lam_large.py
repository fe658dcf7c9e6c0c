"""Default ``sar regularize`` (λ auto) on a large spherical collection against one fixed-λ solve.

A user's own collection: 256 pulses × 512 frequencies (10 GHz, 600 MHz, 3.5° of a circle 1 km from
the scene centre, 30° elevation), 300 point scatterers of amplitude 0.3-1 at random positions
within 30 m (seed 2612), 10 dB noise (``sar simulate --seed 7``), 566² pixels of 0.125 m. The
file's ``noise_power`` attribute is removed, as a collection of one's own has none: λ auto must
estimate σ² itself. Then, on a pseudo-terminal of 120 columns (so the bar is drawn as a user sees
it), ``sar -v regularize PH -o AUTO`` with every default, and ``sar -v regularize PH -o FIXED --lam
λ*`` at the λ it chose. Prints wall and CPU seconds of both commands, their AᴴA products (power
iterations, both path solvers, the final solve) and the ratios; the terminal output goes to
``WORKDIR/auto.log`` and ``WORKDIR/fixed.log`` with the time of each write.

Beside them, one default ``sar form-image`` of the same file and grid (the best of three), and the
ratios of both regularisations to it.

About 600 + 300 AᴴA products (GOTCHA: 622 for the default, 311 for the fixed λ). Usage: ``python bench/bench_lam_large.py [WORKDIR] [--ph PH.h5]``
(default ``out/bench/large-spherical``, where ``make bench`` runs it); ``--ph`` regularises that file
(its stored grid) instead of the simulated collection, e.g. the four GOTCHA files imported by
``sar import gotcha FILES -o PH.h5 --extent 100 --pixel-size 0.125``.
"""

from __future__ import annotations

import fcntl
import os
import pty
import resource
import struct
import subprocess
import sys
import termios
import time
from pathlib import Path

import numpy as np


def write_config(path: Path) -> None:
    rng = np.random.default_rng(2612)
    r = 30 * np.sqrt(rng.uniform(0, 1, 300))
    t = rng.uniform(0, 2 * np.pi, 300)
    pts = np.c_[r * np.cos(t), r * np.sin(t)]
    amp = rng.uniform(0.3, 1.0, 300)
    lines = ["# 300 random points within 30 m, 256 pulses x 512 frequencies, spherical from 1 km, 566^2 pixels of 0.125 m",
             "name: large-spherical", "model: spherical",
             "frequencies: {center_frequency_ghz: 10.0, bandwidth_mhz: 600.0, count: 512}",
             "elevation_deg: 30.0", "azimuths: {center_deg: 0.0, extent_deg: 3.5, count: 256}",
             "geometry: {path: circle, standoff_range_m: 1000.0}",
             "image: {half_width_m: 35.375, pixels: 566}", "noise: {snr_db: 10}", "scene:", "  points:"]
    lines += [f"    - {{position_m: [{x:.3f}, {y:.3f}], amplitude: {a:.3f}}}" for (x, y), a in zip(pts, amp)]
    path.write_text("\n".join(lines) + "\n")


def on_terminal(log: Path, argv: list[str]) -> tuple[float, float]:
    """Run ``argv`` on a 120 x 40 pseudo-terminal, logging each write with its time; (wall, CPU) s."""
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    pid, fd = pty.fork()
    if pid == 0:
        os.execvp(argv[0], argv)
    fcntl.ioctl(fd, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))
    with open(log, "w") as out:
        while True:
            try:
                chunk = os.read(fd, 65536)
            except OSError:
                break
            if not chunk:
                break
            out.write(f"[{time.perf_counter() - t0:8.1f}] {chunk.decode('utf-8', 'replace')!r}\n")
            out.flush()
    _, status = os.waitpid(pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(argv)} failed; see {log}")
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.perf_counter() - t0, (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)


def products(params: dict) -> int:
    """AᴴA products of a run, as regularize counts them (scaling, λ path, final solve)."""
    return params["gram_products"]["total"]


def form_image_s(sar: str, ph: Path, out: Path, repeat: int = 3) -> float:
    """The best wall time of ``repeat`` default ``sar form-image`` runs (whole processes)."""
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run([sar, "-q", "form-image", str(ph), "-o", str(out)], check=True)
        best = min(best, time.perf_counter() - t0)
    return best


def main(argv=None):
    import argparse

    import h5py

    from sarcli.io.hdf5 import read_image

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("workdir", nargs="?", default="out/bench/large-spherical")
    ap.add_argument("--ph", help="a phase-history file to regularise instead of the simulated collection")
    args = ap.parse_args(argv)
    work = Path(args.workdir)
    work.mkdir(parents=True, exist_ok=True)
    sar = str(Path(sys.executable).with_name("sar"))
    if args.ph:
        ph = Path(args.ph)
    else:
        ph = work / "large.h5"
        write_config(work / "large.yaml")
        subprocess.run([sar, "-q", "simulate", str(work / "large.yaml"), "-o", str(ph), "--seed", "7"], check=True)
        with h5py.File(ph, "a") as f:
            del f.attrs["noise_power"]
    t_form = form_image_s(sar, ph, work / "mf.h5")
    wall_a, cpu_a = on_terminal(work / "auto.log", [sar, "-v", "regularize", str(ph), "-o",
                                                    str(work / "auto.h5")])
    pa = read_image(work / "auto.h5").parameters
    wall_f, cpu_f = on_terminal(work / "fixed.log", [sar, "-v", "regularize", str(ph), "-o",
                                                     str(work / "fixed.h5"), "--lam", repr(pa["lam"])])
    pf = read_image(work / "fixed.h5").parameters
    sel = pa["lam_selection"]
    print(f"lam auto: {pa['lam']:.4g} by {sel['criterion']} ({sel['status']}; {sel['noise_source']}); path "
          f"{sum(sel['path_iterations'])} iterations x 2, final {pa['iterations']}; fixed: {pf['iterations']}")
    print(f"AᴴA products {products(pa)} vs {products(pf)} ({products(pa) / products(pf):.2f} x); CPU "
          f"{cpu_a:.0f} s vs {cpu_f:.0f} s ({cpu_a / cpu_f:.2f} x); wall {wall_a:.0f} s vs {wall_f:.0f} s "
          f"({wall_a / wall_f:.2f} x)")
    print(f"form-image (default, best of 3): {t_form:.2f} s; fixed-lam solve {wall_f / t_form:.0f} x, "
          f"auto {wall_a / t_form:.0f} x; operator {pa['operator']} ({pa.get('subapertures', '-')} sub-apertures, "
          f"path {pa.get('path_operator', {}).get('subapertures', '-')})")
    for name, p, wall in (("auto", pa, wall_a), ("fixed", pf, wall_f)):
        print(f"{name}: predicted {p['predicted_s']:.0f} s (up to {p['predicted_max_s']:.0f} s), took "
              f"{wall:.0f} s wall (predicted / measured {p['predicted_s'] / wall:.2f})")


if __name__ == "__main__":
    main()
