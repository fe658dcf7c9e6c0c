"""Peak memory of one image formation as a multiple of the image (and phase-history) bytes.

Runs in its own process per method (peak resident set above the level after a warm-up call,
from /proc/self/status VmHWM after resetting it), so the allocations of compiled libraries
(FINUFFT's fine grid, FFT work arrays) count, which tracemalloc cannot see. Target: every method
<= 3 x (phase history + image) bytes.

    python bench/bench_memory.py N METHOD ["{'eps': 1e-9}"]      # one measurement
    python bench/bench_memory.py                                 # the table at 2048² and 4096²
    python bench/bench_memory.py stream                          # streaming: 1x and 4x the pulses

Streaming: ``sar form-image --method backprojection`` (and ``ffbp``) on collections of P and 4P
pulses with the image fixed, whole-process peak RSS of each, from the sarcli HDF5 phase history
and from the same collection exported as CPHD; either is read by blocks of pulses, so the 4x
longer collection should raise the peak by <= 20 %.
"""

from __future__ import annotations

import gc
import subprocess
import sys

import sarcli
from sarcli.core.grid import Grid


def _status(key: str) -> float:
    """A /proc/self/status memory figure in MiB (VmRSS now, VmHWM the high-water mark)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key):
                return int(line.split()[1]) / 1024
    raise RuntimeError(f"{key} not in /proc/self/status")


def one(n, method, kw):
    from pathlib import Path

    cfg = Path(__file__).resolve().parents[1] / "configs" / "three-points.yaml"
    acq = sarcli.load_acquisition(cfg).with_(grid=Grid.square(5.0, n))
    ph = sarcli.simulate(acq, seed=1, model="farfield", snr_db=None)
    sarcli.form_image(ph, method, grid=Grid.square(1.0, 64), **kw)   # warm: kernels, plans
    gc.collect()
    # reset the high-water mark
    open("/proc/self/clear_refs", "w").write("5")
    base = _status("VmRSS")
    img = sarcli.form_image(ph, method, **kw)
    peak = _status("VmHWM") - base
    imgb, phb = img.image.nbytes / 2**20, ph.data.nbytes / 2**20
    print(f"{method} {kw} {n}²: peak above start {peak:.0f} MiB = {peak/imgb:.2f} x image ({imgb:.0f} MiB), "
          f"{peak/(imgb+phb):.2f} x (PH {phb:.0f} + image)")


_PEAK = ("import resource, sys; from sarcli.cli.main import cli\n"
         "try:\n    cli(sys.argv[1:])\nexcept SystemExit:\n    pass\n"
         "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)")


def stream(pulses=(2048, 8192), freqs=2048, pixels=256, methods=("backprojection", "ffbp")):
    """Whole-process peak RSS of the block-reading formers from disk for 1x and 4x the pulses, image fixed.

    Each collection is imaged from its HDF5 phase history and from its CPHD export.
    """
    import tempfile
    from pathlib import Path

    import yaml

    cfg = yaml.safe_load((Path(__file__).resolve().parents[1] / "configs" / "three-points.yaml").read_text())
    sar = str(Path(sys.executable).parent / "sar")
    rows = {(m, f): [] for m in methods for f in ("HDF5", "CPHD")}
    with tempfile.TemporaryDirectory() as tmp:
        for p in pulses:
            cfg["azimuths"] = {"center_deg": 50.0, "extent_deg": 3.0 * p / pulses[0], "count": p}
            cfg["frequencies"] = {"center_frequency_ghz": 10.0, "bandwidth_mhz": 600.0, "count": freqs}
            cfg["image"] = {"half_width_m": 5.0, "pixels": pixels}
            yml, ph = Path(tmp) / f"a{p}.yaml", Path(tmp) / f"ph{p}.h5"
            yml.write_text(yaml.safe_dump(cfg))
            cphd = Path(tmp) / f"ph{p}.cphd"
            subprocess.run([sar, "-q", "simulate", str(yml), "-o", str(ph), "--noiseless"], check=True)
            subprocess.run([sar, "-q", "export-cphd", str(ph), "-o", str(cphd)], check=True)
            for (method, fmt), rs in rows.items():
                src = ph if fmt == "HDF5" else cphd
                out = subprocess.run([sys.executable, "-c", _PEAK, "-q", "form-image", str(src), "-o",
                                      str(Path(tmp) / "img.h5"), "--method", method],
                                     check=True, capture_output=True, text=True).stdout.split()[-1]
                rs.append((p, Path(src).stat().st_size / 2**20, float(out)))
    image_mib = pixels * pixels * 16 / 2**20
    for (method, fmt), rs in rows.items():
        for p, size, peak in rs:
            print(f"{method} from {fmt}: {p} pulses x {freqs} ({size:.0f} MiB on disk), image {pixels}² "
                  f"({image_mib:.0f} MiB): whole-process peak RSS {peak:.0f} MiB")
        print(f"{method}, {fmt}: 4x the pulses raises the peak by {100 * (rs[-1][2] / rs[0][2] - 1):.1f} % "
              "(target <= 20 %)")


if __name__ == "__main__":
    import ast

    if sys.argv[1:] == ["stream"]:
        stream()
    elif len(sys.argv) > 2:
        one(int(sys.argv[1]), sys.argv[2], ast.literal_eval(sys.argv[3]) if len(sys.argv) > 3 else {})
    else:
        for n in (2048, 4096):
            for method, kw in (("pfa", "{}"), ("nufft", "{'eps': 1e-9}"), ("nufft", "{'eps': 1e-3}"),
                               ("backprojection", "{}"), ("ffbp", "{}")):
                subprocess.run([sys.executable, __file__, str(n), method, kw], check=True)
