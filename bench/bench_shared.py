"""A formation beside one CPU-bound process, against the same formation alone, in one run (no assertions).

GOTCHA pass 1 HH, 4 files, 100 m at 0.125 m (800²), in this process: for backprojection and ffbp
(default knobs), three alternating samples alone and beside ``python -c "while True: pass"``, each
sample the best of three calls; the ratio of the medians (target ≤ 2.5 on a 2-core machine: the
kernels' threads must not wait on a core the other process holds).

    python bench/bench_shared.py [--methods backprojection,ffbp]

Says it skipped, and exits 0, without the GOTCHA files (``sarcli.io.gotcha.gotcha_dir()``).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
import warnings

from sarcli.core.grid import Grid
from sarcli.formers.formation import form_image
from sarcli.io.gotcha import gotcha_files, read_gotcha


def _best(fn, n=3) -> float:
    ts = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return min(ts)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--methods", default="backprojection,ffbp")
    args = ap.parse_args(argv)
    files = gotcha_files()[:4]
    if len(files) < 4:
        print("bench_shared: no GOTCHA files (set SARCLI_GOTCHA_DIR); skipped")
        return 0
    ph = read_gotcha([str(f) for f in files])
    grid = Grid.from_extent(100.0, 0.125)
    warnings.simplefilter("ignore")
    print(f"# bench_shared: GOTCHA 800², {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at start")
    print("| method | alone (s) | beside a busy process (s) | ratio of medians | target |")
    print("|---|---|---|---|---|")
    for method in args.methods.split(","):
        def run():
            return form_image(ph, method, grid=grid)

        run()
        alone, beside = [], []
        for _ in range(3):
            alone.append(_best(run))
            busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
            try:
                time.sleep(0.3)
                beside.append(_best(run))
            finally:
                busy.kill()
                busy.wait()
            time.sleep(0.3)
        ratio = statistics.median(beside) / statistics.median(alone)
        print(f"| {method} | {min(alone):.3f}-{max(alone):.3f} | {min(beside):.3f}-{max(beside):.3f} | "
              f"{ratio:.2f} | <= 2.5 {'met' if ratio <= 2.5 else 'missed'} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
