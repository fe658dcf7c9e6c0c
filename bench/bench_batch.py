"""Throughput of ``sar batch`` on 1 and 2 dask workers, and the per-job cost of one GOTCHA file.

Simulates ``--jobs`` independent phase histories, then runs the same plan (backprojection, one
thread per job) on a LocalCluster of 1 worker and of 2 workers (each after a warm-up run that
starts the workers and loads the compiled kernels), every job redone (``force``); prints the wall
times, the throughput ratio, the load average and the CPU share each job got (``cpu_s / wall_s``:
below 1 when other processes competed for the cores), and the ratio of the CPU the 2 workers got to
what the single worker got, against which the throughput ratio is judged on a busy machine.
Then times one backprojection job on one GOTCHA file (``.mat``, default 100 m grid at 0.25 m, one
thread) when ``sarcli.io.gotcha.gotcha_dir()`` holds the pass files, else a comparable simulated job,
and projects a 360-file pass on N workers from its CPU seconds.

Usage: ``python bench/bench_batch.py [--jobs 8] [--pulses 512] [--freqs 512] [--n 384]``
"""

from __future__ import annotations

import argparse
import logging
import os
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import sarcli
from sarcli.batch.run import Job, parse_plan, run_job, run_plan
from sarcli.io.config import parse_acquisition
from sarcli.io.gotcha import gotcha_files



def _config(center_deg, pulses, freqs, n):
    return {"name": f"bench-{center_deg:g}", "model": "spherical",
            "frequencies": {"center_frequency_ghz": 10.0, "bandwidth_mhz": 600.0, "count": freqs},
            "elevation_deg": 30.0, "azimuths": {"center_deg": center_deg, "extent_deg": 3.0, "count": pulses},
            "geometry": {"path": "circle", "standoff_range_m": 10000.0},
            "image": {"half_width_m": 5.0, "pixels": n},
            "scene": {"points": [{"position_m": [0.0, 0.0], "amplitude": 1.0},
                                 {"position_m": [-3.0, 2.0], "amplitude": 1.0}]}}


def _timed_run(plan, out, n_workers):
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None, silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        run_plan(plan, out, client=client, force=True)          # warm-up: imports, compiled kernels
        t0 = time.perf_counter()
        report = run_plan(plan, out, client=client, force=True)
        wall = time.perf_counter() - t0
    assert report.ok, report.summary()
    cpu = sum(r.cpu_s for r in report.results)
    busy = sum(r.wall_s for r in report.results)
    return wall, cpu / busy, cpu / len(report.results)


def _gotcha_job_cost(tmp, repeat=3):
    files = gotcha_files()
    if files:
        job = Job(name="gotcha.h5", input=str(files[0]), method="backprojection", threads=1)
        what = f"one GOTCHA file ({files[0].name}), backprojection on the default 400 x 400 grid (0.25 m)"
    else:
        path = Path(tmp) / "gotcha-like.h5"
        sarcli.write_phase_history(path, sarcli.simulate(parse_acquisition(_config(50.0, 117, 424, 400)),
                                                          seed=0, snr_db=None))
        job = Job(name="gotcha.h5", input=str(path), method="backprojection", threads=1)
        what = "a simulated GOTCHA-sized job (117 pulses x 424 frequencies, 400 x 400 grid): no GOTCHA data here"
    run_job(job, tmp, force=True)  # warm-up
    walls, forms, cpus = [], [], []
    for _ in range(repeat):
        res = run_job(job, tmp, force=True)
        assert res.status == "done", res.error
        walls.append(res.wall_s)
        forms.append(res.runtime_s)
        cpus.append(res.cpu_s)
    return what, float(np.median(walls)), float(np.median(forms)), float(np.median(cpus))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=8)
    ap.add_argument("--pulses", type=int, default=512)
    ap.add_argument("--freqs", type=int, default=512)
    ap.add_argument("--n", type=int, default=384, help="image side in pixels")
    args = ap.parse_args(argv)

    logging.getLogger("distributed").setLevel(logging.CRITICAL)  # shutdown chatter of the clusters
    cpu = subprocess.run("lscpu | grep 'Model name'", shell=True, capture_output=True, text=True).stdout.strip()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for i in range(args.jobs):
            ph = sarcli.simulate(parse_acquisition(_config(10.0 + 20 * i, args.pulses, args.freqs, args.n)),
                                 seed=i, snr_db=None)
            sarcli.write_phase_history(tmp / f"ph{i:02d}.h5", ph)
        plan = parse_plan({"jobs": [{"input": "ph*.h5", "method": "backprojection"}]}, source="bench",
                          base_dir=tmp)
        load0 = os.getloadavg()[0]
        t1, share1, cpu1 = _timed_run(plan, tmp / "out", 1)
        t2, share2, cpu2 = _timed_run(plan, tmp / "out", 2)
        load1 = os.getloadavg()[0]
        what, job_wall, job_form, job_cpu = _gotcha_job_cost(tmp)

    print(f"machine: {cpu}; {os.cpu_count()} cores; 1-min load average {load0:.1f} before, {load1:.1f} after")
    print(f"plan: {args.jobs} independent backprojection jobs, {args.pulses} pulses x {args.freqs} "
          f"frequencies -> {args.n} x {args.n} pixels, 1 thread per job")
    print("| workers | wall (s) | jobs/s | CPU s per job | CPU share of a job (cpu_s / wall_s) |")
    print("|---|---|---|---|---|")
    print(f"| 1 | {t1:.2f} | {args.jobs / t1:.2f} | {cpu1:.2f} | {share1:.2f} |")
    print(f"| 2 | {t2:.2f} | {args.jobs / t2:.2f} | {cpu2:.2f} | {share2:.2f} |")
    print(f"throughput ratio 2 vs 1 workers: {t1 / t2:.2f}x")
    # what the cores allowed: the 2 workers together got 2*share2 cores, the single worker share1
    allowed = 2 * share2 / share1
    print(f"CPU the workers got, 2 vs 1 workers: {allowed:.2f}x; scaling efficiency against it: "
          f"{t1 / t2 / allowed:.2f} (1.0 = the batch scaled as far as free cores allowed)")
    print(f"per-job cost of {what}: {job_wall:.2f} s wall (read + form + write), {job_form:.2f} s formation, "
          f"{job_cpu:.2f} CPU s")
    print("projected 360-file pass (one job per file on a free core each, from the CPU s): "
          + ", ".join(f"N={n}: {360 * job_cpu / n:.0f} s" for n in (1, 2, 8, 16, 64)))


if __name__ == "__main__":
    main()
