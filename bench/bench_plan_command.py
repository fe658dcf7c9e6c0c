"""``sar plan``'s predicted whole ``sar form-image`` against the measured on small collections (no
assertions; target within 1.5x either way), optionally beside another checkout's ``sar``.

Cases: the four GOTCHA files (pass 1 HH, ``sar import gotcha``) onto 800² pixels of 0.125 m, where
``sarcli.io.gotcha.gotcha_dir()`` holds them, and ``configs/three-points.yaml`` simulated
(``sar simulate``, its own grid). For each side (``this``: the ``sar`` beside this interpreter;
``--baseline SAR``: another's) with its own cost-model cache (``SARCLI_CACHE_DIR``: it calibrates
with its own code on its first ``sar plan``): ``sar plan --json`` gives auto's predicted whole
command, then ``sar form-image`` (auto) runs ``--runs`` times, the sides alternating, each to a new
file; the median wall time over the prediction is reported, and the median of the command besides the
formation (wall − the image's ``runtime_s``: start-up, planning, writing) against the prediction's
(whole − formation), which other jobs on the machine stretch far less than the formation.

    python bench/bench_plan_command.py [--runs 5] [--baseline SAR]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from sarcli.io.gotcha import gotcha_dir, gotcha_files

REPO = Path(__file__).resolve().parents[1]


def wall(cmd, out, env):
    """Wall seconds of ``cmd`` and the formation's ``runtime_s`` stored in the image ``out``."""
    import h5py

    t0 = time.perf_counter()
    subprocess.run(list(map(str, cmd)), check=True, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t = time.perf_counter() - t0
    with h5py.File(out, "r") as f:
        return t, float(f.attrs["runtime_s"])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--baseline", default=None, metavar="SAR")
    args = ap.parse_args(argv)
    sar = Path(sys.executable).with_name("sar")
    sides = [("this", sar)] + ([("baseline", Path(args.baseline))] if args.baseline else [])
    work = Path(tempfile.mkdtemp(prefix="plan-command-"))
    cases = []
    files = gotcha_files(gotcha_dir())[:4]
    if len(files) == 4:
        ph = work / "gotcha.h5"
        subprocess.run([sar, "-q", "import", "gotcha", *map(str, files), "-o", str(ph)], check=True)
        cases.append(("GOTCHA 4 files -> 800²", ph, ["--extent", "100", "--pixel-size", "0.125"]))
    ph = work / "three-points.h5"
    subprocess.run([sar, "-q", "simulate", str(REPO / "configs" / "three-points.yaml"), "-o", str(ph)], check=True)
    cases.append(("three-points.yaml, its grid", ph, []))
    res = {"load_before": os.getloadavg()[0], "cases": []}
    for name, ph, grid in cases:
        row = {"case": name}
        for label, exe in sides:
            env = {**os.environ, "SARCLI_CACHE_DIR": str(work / f"cache-{label}")}
            out = subprocess.run([exe, "plan", str(ph), *grid, "--json"], check=True, env=env, capture_output=True,
                                 text=True).stdout
            plan = json.loads(out[out.index("{"):])
            row[label] = {"predicted_s": plan["auto"]["predicted_command_s"], "method": plan["auto"]["method"],
                          "rest_predicted_s": plan["auto"]["predicted_command_s"] - plan["auto"]["predicted_s"],
                          "walls": [], "rests": []}
        for i in range(args.runs):
            for label, exe in (sides if i % 2 == 0 else sides[::-1]):
                env = {**os.environ, "SARCLI_CACHE_DIR": str(work / f"cache-{label}")}
                out = work / f"img-{label}-{i}.h5"
                t, runtime = wall([exe, "-q", "form-image", ph, "-o", out, *grid], out, env)
                row[label]["walls"].append(t)
                row[label]["rests"].append(t - runtime)
        for label, _ in sides:
            r = row[label]
            r["median_s"] = statistics.median(r["walls"])
            r["ratio"] = r["median_s"] / r["predicted_s"]
            r["rest_median_s"] = statistics.median(r["rests"])
            print(f"{name}: {label} {r['method']} measured {r['median_s']:.3f} s / predicted "
                  f"{r['predicted_s']:.3f} s = {r['ratio']:.2f}; besides the formation {r['rest_median_s']:.3f} s / "
                  f"{r['rest_predicted_s']:.3f} s", file=sys.stderr)
        res["cases"].append(row)
    res["load_after"] = os.getloadavg()[0]
    print(json.dumps(res, indent=1))
    shutil.rmtree(work)


if __name__ == "__main__":
    main()
