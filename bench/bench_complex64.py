"""A complex64 phase history against the same collection stored complex128: `sar form-image` in a
fresh process each time, the two files alternating (A B A B ...), medians of wall time, CPU time
(user + system, which a shared machine inflates less) and minor page faults, and their ratios.

The collection: three point targets at 10 km (X band), ``--pulses`` pulses x ``--pulses``
frequencies onto ``--pixels``² pixels; formed by the default method (auto) and by backprojection.

    python bench/bench_complex64.py [--pulses 2048] [--pixels 2048] [--runs 3] [--methods auto,backprojection]

Targets: complex64 no slower than complex128 (ratio ≤ 1.05 in CPU time) and no more page faults.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def config(pulses: int, pixels: int) -> str:
    return f"""name: c64-bench
model: spherical
frequencies: {{center_frequency_ghz: 10.0, bandwidth_mhz: 600.0, count: {pulses}}}
elevation_deg: 30.0
azimuths: {{center_deg: 50.0, extent_deg: 3.0, count: {pulses}}}
geometry: {{path: circle, standoff_range_m: 10000.0}}
image: {{half_width_m: {pixels * 0.05:g}, pixels: {pixels}}}
scene:
  points:
    - {{position_m: [0.0, 0.0], amplitude: 1.0}}
    - {{position_m: [-{pixels * 0.015:g}, {pixels * 0.01:g}], amplitude: 1.0}}
    - {{position_m: [{pixels * 0.005:g}, {pixels * 0.02:g}], amplitude: 1.0}}
"""


def run(cmd):
    """(wall s, CPU s, minor page faults) of ``cmd`` in its own process."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(list(map(str, cmd)), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    err = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status):
        sys.exit(f"{' '.join(map(str, cmd))} failed:\n{err.decode()[-2000:]}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_minflt


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pulses", type=int, default=2048)
    ap.add_argument("--pixels", type=int, default=2048)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--methods", default="auto,backprojection")
    args = ap.parse_args(argv)
    sar = Path(sys.executable).with_name("sar")
    with tempfile.TemporaryDirectory(prefix="c64-") as tmp:
        tmp = Path(tmp)
        (tmp / "c.yaml").write_text(config(args.pulses, args.pixels))
        files = {}
        for prec, name in (("float32", "complex64"), ("float64", "complex128")):
            files[name] = tmp / f"{name}.h5"
            run([sar, "-q", "simulate", tmp / "c.yaml", "-o", files[name], "--precision", prec])
        print(f"load average before: {os.getloadavg()[0]:.2f}")
        for method in args.methods.split(","):
            got = {name: [] for name in files}
            for _ in range(args.runs):
                for name, path in files.items():
                    got[name].append(run([sar, "-q", "form-image", path, "-o", tmp / "img.h5", "--method", method]))
            med = {name: [statistics.median(v[i] for v in runs) for i in range(3)] for name, runs in got.items()}
            a, b = med["complex64"], med["complex128"]
            print(f"{method}: complex64 {a[0]:.2f} s wall, {a[1]:.2f} s CPU, {a[2]:.0f} faults; complex128 "
                  f"{b[0]:.2f} s wall, {b[1]:.2f} s CPU, {b[2]:.0f} faults; ratio (64/128) wall {a[0] / b[0]:.2f}, "
                  f"CPU {a[1] / b[1]:.2f}, faults {a[2] / b[2]:.2f}")
        print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
