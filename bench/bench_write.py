"""The planner's predicted write and read seconds against the measured, from 32 MiB to gigabytes (no
assertions; target within 1.5x either way).

Runs as ``sar`` does (numpy's huge-page advice off, :func:`sarcli.cli.main.no_huge_pages`). First
measures the command's I/O constants in this run (:func:`sarcli.formers.planning.calibration.command_costs`:
``read_per_byte``, and ``write_per_byte`` / ``write_per_byte_large`` from images written to new
files), then, ``--rounds`` times, for each size in its own fresh process as ``sar form-image`` ends:

- an image held complex128 (every page touched, as a former leaves it) written by
  :func:`sarcli.io.hdf5.write_image` stored complex64 to a new file, the files of the sizes before
  kept (an output's bytes take pages the kernel's file cache has not had); measured wall seconds
  against :func:`sarcli.formers.planning.cost.write_seconds`;
- that file read back by blocks of 128 rows into one buffer, as the formers read a phase history's
  pulses (:meth:`sarcli.io.pulses.PulseArray.read_into`); against
  :func:`sarcli.formers.planning.cost.read_seconds`.

Before each size the bench waits (``--settle``, at most 2 minutes) until the kernel holds under
100 MB of file data not yet written to disk (``Dirty`` + ``Writeback`` of ``/proc/meminfo``) and
records what it held: a write that takes the machine's unwritten data past the kernel's threshold
(``vm.dirty_background_ratio``) is held to the disk's pace, which the model does not know.

Sizes (stored): 32 MiB (the calibration's), 288 MB (the Panama quarter's 6,000² image), 861 MB (the
full size's 12,208 x 8,808) and 2 GB (16,384²; ``--no-2g`` leaves it out: it holds 4.3 GB).

With ``--chunks`` only this: 256 MiB written to a new file by ``os.write`` calls of 16 KiB to
256 MiB, the sizes interleaved in one process, the files kept until the end (seconds per byte).

    python bench/bench_write.py [--rounds 2] [--dir DIR] [--no-2g] [--settle MB] [--chunks]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from sarcli.cli.main import no_huge_pages

no_huge_pages()   # as `sar` runs (numpy reads the setting when first imported); children inherit it

SIZES = {"32MiB": (4096, 1024), "quarter": (6000, 6000), "full": (8808, 12208), "2GB": (16384, 16384)}

CHILD = """
import json, sys, time
import numpy as np
from sarcli.core.types import Image
from sarcli.io.hdf5 import write_image
from sarcli.io.pulses import PulseArray
ny, nx, path = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
a = np.empty((ny, nx), np.complex128)
a.real = 1.0
a.imag = -1.0
img = Image(image=a, x_m=np.arange(nx, dtype=float), y_m=np.arange(ny, dtype=float), method="bench",
            parameters={}, runtime_s=0.0)
t0 = time.perf_counter()
write_image(path, img, np.complex64)
w = time.perf_counter() - t0
del img, a
src = PulseArray(path, "image", (ny, nx), np.complex64)
buf = np.empty((128, nx), np.complex64)
t0 = time.perf_counter()
for r in range(0, ny, 128):
    n = min(128, ny - r)
    src.read_into(slice(r, r + n), buf[:n])
print(json.dumps({"write_s": w, "read_s": time.perf_counter() - t0}))
"""


def unwritten_bytes() -> int:
    """The kernel's file-cache bytes not yet written to disk (``Dirty`` + ``Writeback``)."""
    try:
        with open("/proc/meminfo") as f:
            return sum(int(ln.split()[1]) * 1024 for ln in f if ln.startswith(("Dirty:", "Writeback:")))
    except OSError:
        return 0


def settle(limit_mb, wait_s=120.0) -> int:
    """Wait (at most ``wait_s``) until the machine holds under ``limit_mb`` of unwritten file data;
    returns the bytes unwritten then."""
    t0 = time.perf_counter()
    while unwritten_bytes() > limit_mb * 1e6 and time.perf_counter() - t0 < wait_s:
        time.sleep(0.5)
    return unwritten_bytes()


CHUNKS = """
import os, sys, time
import numpy as np
n, folder = 2 ** 28, sys.argv[1]
mv = memoryview(np.ones(n // 8, np.complex64)).cast("B")
out = []
for i, chunk in enumerate(int(c) for c in sys.argv[2:]):
    t0 = time.perf_counter()
    fd = os.open(os.path.join(folder, f"raw-{i}"), os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    for s in range(0, n, chunk):
        os.write(fd, mv[s:s + chunk])
    os.close(fd)
    out.append([chunk, (time.perf_counter() - t0) / n])
print(out)
"""
#: ``--chunks``: write sizes of 256 MiB of new files, interleaved (bytes).
CHUNK_SIZES = (2 ** 28, 2 ** 17, 2 ** 23, 2 ** 16, 2 ** 20, 2 ** 19, 2 ** 28, 2 ** 17, 2 ** 23, 2 ** 14)


def chunks(work) -> list:
    """Seconds per byte of writing 256 MiB to a new file in one process by ``os.write`` calls of each
    of :data:`CHUNK_SIZES`, the files kept until the end."""
    import ast

    out = subprocess.run([sys.executable, "-c", CHUNKS, str(work), *map(str, CHUNK_SIZES)], check=True,
                         capture_output=True, text=True)
    rows = ast.literal_eval(out.stdout.strip().splitlines()[-1])
    for chunk, per_byte in rows:
        print(f"write calls of {chunk // 1024:7d} KiB: {per_byte * 1e9:6.2f} ns/B", file=sys.stderr)
    for p in Path(work).glob("raw-*"):
        p.unlink()
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--dir", default=None, help="working folder (default: a temporary one, removed)")
    ap.add_argument("--no-2g", action="store_true", help="leave out the 2 GB image")
    ap.add_argument("--settle", type=float, default=100.0, metavar="MB",
                    help="before each size wait until the kernel holds under this much unwritten file data "
                         "(default 100; a large number: no wait)")
    ap.add_argument("--chunks", action="store_true",
                    help="only: 256 MiB to new files by raw writes of 16 KiB to 256 MiB, interleaved")
    args = ap.parse_args(argv)
    if args.chunks:
        work = Path(args.dir or tempfile.mkdtemp(prefix="bench-write-"))
        print(json.dumps({"load_before": os.getloadavg()[0], "chunks": chunks(work),
                          "load_after": os.getloadavg()[0]}))
        if not args.dir:
            shutil.rmtree(work)
        return
    from sarcli.formers.planning.calibration import command_costs
    from sarcli.formers.planning.cost import read_seconds, write_seconds

    work = Path(args.dir or tempfile.mkdtemp(prefix="bench-write-"))
    work.mkdir(parents=True, exist_ok=True)
    res = {"load_before": os.getloadavg()[0]}
    t0 = time.perf_counter()
    c = command_costs(3)
    res["calibration"] = dict(c, seconds=time.perf_counter() - t0)
    sizes = [s for s in SIZES if not (args.no_2g and s == "2GB")]
    rows = []
    for r in range(args.rounds):
        for name in (sizes if r % 2 == 0 else sizes[::-1]):
            ny, nx = SIZES[name]
            stored = ny * nx * 8
            path = work / f"img-{name}-{r}.h5"
            unwritten = settle(args.settle)
            out = subprocess.run([sys.executable, "-c", CHILD, str(ny), str(nx), str(path)], check=True,
                                 capture_output=True, text=True)
            m = json.loads(out.stdout.strip().splitlines()[-1])
            pw, pr = write_seconds(c, stored), read_seconds(c, stored)
            rows.append({"size": name, "round": r, "stored_mb": stored / 1e6, "write_s": m["write_s"],
                         "write_predicted_s": pw, "write_ratio": m["write_s"] / pw, "read_s": m["read_s"],
                         "read_predicted_s": pr, "read_ratio": m["read_s"] / pr, "load": os.getloadavg()[0],
                         "unwritten_mb_before": unwritten / 1e6})
            print(f"{name:8s} round {r} ({unwritten / 1e6:.0f} MB unwritten before): write {m['write_s']:.3f} s / predicted {pw:.3f} s = "
                  f"{m['write_s'] / pw:.2f}; read {m['read_s']:.3f} s / {pr:.3f} s = {m['read_s'] / pr:.2f}",
                  file=sys.stderr)
    res["rows"] = rows
    res["load_after"] = os.getloadavg()[0]
    print(json.dumps(res, indent=1))
    if not args.dir:
        shutil.rmtree(work)
    else:
        for p in work.glob("img-*.h5"):
            p.unlink()


if __name__ == "__main__":
    main()
