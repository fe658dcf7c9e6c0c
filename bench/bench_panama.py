"""Umbra's Panama collection size, simulated: `sar simulate`, `sar plan` and `sar form-image` (default
method) timed as whole commands, with their peak memory, the error against the exact matched filter
at the targets and the rate against FastSAR's.

FastSAR forms Umbra's Panama collection (15,186 pulses x 14,399 samples -> 12,207 x 8,808 pixels)
in 11.3 s on 16 vCPUs: 9.0e9 pixel-pulses per vCPU-second (:data:`FASTSAR_RATE`). This bench builds
a collection of that size from simulated point targets (X band, 9.6 GHz, 600 km slant range at 45°
elevation, 5° of aperture, 700 MHz; range and cross-range windows alias-free over the grid) and
images it on the grid's size with square pixels of 0.15 m; sarcli's grids have even sides, so the
full size is 12,208 x 8,808. The quarter keeps the pulse and frequency spacing: 7,600 x 7,200 samples
onto 6,000² pixels.

Measured, each command in its own process (peak memory from ``wait4``):

- ``sar simulate``: wall time and peak memory (it writes by blocks of pulses);
- ``sar plan --json``: auto's choice and its predicted whole-command time; the ratio
  measured / predicted (target within 1.5x either way), and the command's processor seconds over
  the vCPUs / predicted (a lower bound of the ratio the machine would give idle, where other jobs
  stretch the wall time), and measured / the prediction at the load ``sar plan`` saw
  (``predicted_command_now_s``);
- ``sar form-image`` with the default method, under a pseudo-terminal so the progress bar draws:
  wall time, the formation's own ``runtime_s``, the rest of the command (wall − ``runtime_s``:
  start-up, planning, writing the image) against the rest of the prediction (whole − formation), peak memory against 1.5 x (phase history + image as
  stored: the datasets' bytes), and how many different percentages the progress bar showed;
- error: on a 16 x 16 pixel patch centred on each target, ``‖f − f_ref‖ / ‖f_ref‖`` with ``f_ref``
  the exact matched filter of the noiseless point scene, summed in closed form over frequencies
  (a Dirichlet kernel per pulse and target, float64 with cancellation-free range differences); the
  worst patch is reported (target ≤ 1e-3). ``--check-direct`` also compares that closed form with
  sarcli's ``direct`` former on a small patch (same sum, evaluated term by term);
- rate: pixel-pulses / (runtime_s x vCPUs) against FastSAR's 9.0e9 (target ≥ 3x).

With ``--baseline SAR`` (the ``sar`` of another checkout, e.g. the main branch's) ``sar simulate``
(unless ``--reuse`` finds the phase history), ``sar plan`` and ``sar form-image`` run for both, alternating for ``--rounds`` rounds on the same phase history, each
with its own cost-model cache (``SARCLI_CACHE_DIR``: each calibrates with its own code on its first
``sar plan``); each run's measured / predicted is reported beside the other's (``rounds``).

    python bench/bench_panama.py [--size quarter|full] [--dir DIR] [--keep] [--check-direct]
                                 [--baseline SAR] [--rounds N] [--reuse]

The full size writes a 1.75 GB phase history and a 1.7 GB image and takes minutes; it runs only
with ``--size full`` or ``SARCLI_BENCH_FULL=1``.
"""

from __future__ import annotations

import argparse
import json
import re
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

C = 299_792_458.0
#: FastSAR on Panama: 15,186 x 12,207 x 8,808 pixel-pulses in 11.3 s on 16 vCPUs.
FASTSAR_RATE = 15186 * 12207 * 8808 / (11.3 * 16)
SIZES = {
    # pulses, frequencies, grid (nx, ny) at PIXEL_M
    "full": (15186, 14399, (12207, 8808)),
    "quarter": (7600, 7200, (6000, 6000)),
}
PIXEL_M = 0.15
CENTER_GHZ = 9.6
STANDOFF_M = 600e3
ELEVATION_DEG = 45.0
#: aperture and bandwidth of the full size; the quarter keeps their spacing per pulse and sample
FULL_APERTURE_DEG = 5.0
FULL_BANDWIDTH_MHZ = 700.0
N_TARGETS = 12
PATCH = 16


def config(size: str) -> tuple[dict, tuple[float, float]]:
    """The YAML config of a size and the grid's extent (W, H) in metres."""
    P, M, (nx, ny) = SIZES[size]
    fp, fm, _ = SIZES["full"]
    aperture = FULL_APERTURE_DEG * (P - 1) / (fp - 1)
    bandwidth = FULL_BANDWIDTH_MHZ * (M - 1) / (fm - 1)
    w, h = nx * PIXEL_M, ny * PIXEL_M
    rng = np.random.default_rng(36)
    pts = np.column_stack([rng.uniform(-0.42, 0.42, N_TARGETS) * w, rng.uniform(-0.42, 0.42, N_TARGETS) * h])
    amps = rng.uniform(0.5, 1.5, N_TARGETS) * np.exp(2j * np.pi * rng.uniform(size=N_TARGETS))
    cfg = {
        "name": f"panama-{size}",
        "description": "Umbra Panama size, simulated point targets",
        "model": "spherical",
        "frequencies": {"center_frequency_ghz": CENTER_GHZ, "bandwidth_mhz": bandwidth, "count": M},
        "elevation_deg": ELEVATION_DEG,
        # the look along +y: y is range, x cross-range
        "azimuths": {"center_deg": 90.0, "extent_deg": aperture, "count": P},
        "geometry": {"path": "circle", "standoff_range_m": STANDOFF_M},
        "image": {"half_width_m": max(w, h) / 2, "pixels": 2 * int(np.ceil(max(nx, ny) / 2))},
        "scene": {"points": [{"position_m": [float(x), float(y)], "amplitude": [float(a.real), float(a.imag)]}
                             for (x, y), a in zip(pts, amps)]},
    }
    return cfg, (w, h)


def run(cmd, *, tty=False, env=None):
    """Run ``cmd``; return (wall s, peak RSS bytes, stdout text). ``tty``: under a pseudo-terminal;
    ``env``: variables added to this process's environment."""
    if tty:
        # a pseudo-terminal has no size unless told: tqdm draws nothing on zero columns
        cmd = ["script", "-q", "-e", "-c", "stty cols 100 rows 40; " + " ".join(map(str, cmd)), "/dev/null"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(list(map(str, cmd)), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            env=None if env is None else {**os.environ, **env})
    out = proc.stdout.read().decode(errors="replace")
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        sys.exit(f"{' '.join(map(str, cmd))} failed ({proc.returncode}):\n{out[-2000:]}")
    run.cpu_s = usage.ru_utime + usage.ru_stime
    return wall, usage.ru_maxrss * 1024, out


def exact_patch(ph, pos, amp, cx, cy, grid_x, grid_y, n=PATCH):
    """The exact matched filter of the point scene on an n x n patch of the image's pixels nearest (cx, cy).

    ``(1/PM) Σ_s a_s Σ_p Σ_j exp(i k_j δ_ps(x))``, ``δ = Δr_p(x) − Δr_p(x_s)``; the sum over the
    equally spaced frequencies in closed form. Returns (rows, cols, values).
    """
    f = np.asarray(ph["frequency_hz"][()])
    a = np.asarray(ph["antenna_position_m"][()])
    c0 = int(np.argmin(np.abs(grid_x - cx))) - n // 2
    r0 = int(np.argmin(np.abs(grid_y - cy))) - n // 2
    c0 = min(max(c0, 0), grid_x.size - n)
    r0 = min(max(r0, 0), grid_y.size - n)
    X, Y = np.meshgrid(grid_x[c0:c0 + n], grid_y[r0:r0 + n])
    px = np.column_stack([X.ravel(), Y.ravel()])
    k0 = 4 * np.pi * f[0] / C
    dk = 4 * np.pi * (f[1] - f[0]) / C
    M = f.size
    na = np.linalg.norm(a, axis=1)
    out = np.zeros(px.shape[0], complex)
    for (sx, sy, _), s_amp in zip(pos, amp):
        # δ = |a - x| - |a - x_s| = (|x|² - |x_s|² - 2 a·(x - x_s)) / (|a - x| + |a - x_s|)
        ds = np.sqrt(na ** 2 - 2 * (a[:, 0] * sx + a[:, 1] * sy) + sx * sx + sy * sy)
        for i0 in range(0, px.shape[0], 16):
            q = px[i0:i0 + 16]
            dx = np.sqrt(na[:, None] ** 2 - 2 * (a[:, 0:1] * q[:, 0] + a[:, 1:2] * q[:, 1]) + np.sum(q ** 2, axis=1))
            num = np.sum(q ** 2, axis=1) - (sx * sx + sy * sy) - 2 * (a[:, 0:1] * (q[:, 0] - sx) + a[:, 1:2] * (q[:, 1] - sy))
            delta = num / (dx + ds[:, None])
            # Σ_j e^{i (k0 + j dk) δ} = e^{i k0 δ} e^{i (M-1) dk δ / 2} sin(M dk δ / 2) / sin(dk δ / 2)
            half = dk * delta / 2
            with np.errstate(invalid="ignore", divide="ignore"):
                dir_ = np.where(np.abs(np.sin(half)) < 1e-300, M, np.sin(M * half) / np.sin(half))
            out[i0:i0 + 16] += s_amp * np.sum(np.exp(1j * (k0 * delta + (M - 1) * half)) * dir_, axis=0)
    return slice(r0, r0 + n), slice(c0, c0 + n), (out / (a.shape[0] * M)).reshape(n, n)


def errors(ph_path, img_path, n=PATCH):
    with h5py.File(ph_path, "r") as ph, h5py.File(img_path, "r") as im:
        pos = ph["truth/point_position_m"][()]
        amp = ph["truth/point_amplitude"][()]
        gx, gy = im["x_m"][()], im["y_m"][()]
        errs = []
        for (sx, sy, _), s_amp in zip(pos, amp):
            rows, cols, ref = exact_patch(ph, pos, amp, sx, sy, gx, gy, n)
            img = im["image"][rows, cols]
            errs.append(float(np.linalg.norm(img - ref) / np.linalg.norm(ref)))
    return errs


def check_direct(ph_path, n=4):
    """The closed form against sarcli's direct former on an n x n patch at the first target."""
    import sarcli
    from sarcli.formers.direct import direct_spherical

    ph = sarcli.read_phase_history(ph_path, lazy=True)
    acq = ph.acquisition
    pos = ph.truth.point_position_m
    g = sarcli.Grid(n, n, PIXEL_M, PIXEL_M, float(pos[0, 0]), float(pos[0, 1]))
    ref = direct_spherical(ph.data, acq.frequency_hz, acq.antenna_position_m, acq.range_to_center_m, g)
    with h5py.File(ph_path, "r") as f:
        _, _, closed = exact_patch(f, pos, ph.truth.point_amplitude, g.cx, g.cy, g.x, g.y, n)
    return float(np.linalg.norm(closed - ref) / np.linalg.norm(ref))


def plan_and_form(sar, ph_path, img_path, grid_opts, P, vcpus, env):
    """``sar plan --json`` then ``sar form-image`` (default method) of ``sar``, each in its own process."""
    res = {}
    t, rss, out = run([sar, "plan", ph_path, *grid_opts, "--json"], env=env)
    plan = json.loads(out[out.index("{"):])
    res["plan"] = {"s": t, "choice": plan["auto"]["method"], "knobs": plan["auto"]["knobs"],
                   "predicted_error": plan["auto"]["predicted_error"],
                   "predicted_command_s": plan["auto"]["predicted_command_s"],
                   # at the load `sar plan` saw (other runnable threads): what a busy machine stretches
                   "predicted_command_now_s": plan["auto"].get("predicted_command_now_s"),
                   "load_other_threads": plan.get("load", {}).get("other_runnable_threads"),
                   "predicted_formation_s": plan["auto"]["predicted_s"]}
    t, rss, out = run([sar, "form-image", ph_path, "-o", img_path, *grid_opts], tty=True, env=env)
    with h5py.File(ph_path, "r") as f, h5py.File(img_path, "r") as im:
        hist_bytes = f["phase_history"].size * f["phase_history"].dtype.itemsize
        img_bytes = im["image"].size * im["image"].dtype.itemsize
        runtime = float(im.attrs["runtime_s"])
        params = json.loads(im.attrs["parameters"])
        gnx, gny = im["image"].shape[1], im["image"].shape[0]
    bound = 1.5 * (hist_bytes + img_bytes)
    pp = P * gnx * gny
    res["form_image"] = {
        "s": t, "runtime_s": runtime, "peak_rss_mb": rss / 2**20, "grid": [gnx, gny],
        "method": params.get("auto", {}).get("choice", params.get("method")),
        "history_mb": hist_bytes / 2**20, "image_mb": img_bytes / 2**20,
        "rss_over_stored": rss / (hist_bytes + img_bytes), "within_1.5x": rss <= bound,
        "progress_percentages_seen": len(set(re.findall(r"(\d+)%\|", out))),
        "plan_ratio_measured_over_predicted": t / res["plan"]["predicted_command_s"],
        "plan_ratio_measured_over_predicted_now": (t / res["plan"]["predicted_command_now_s"]
                                                   if res["plan"]["predicted_command_now_s"] else None),
        # the command besides the formation (start-up, planning, reading outside it, writing the
        # image): other jobs on the machine stretch it far less than the threaded formation
        "rest_s": t - runtime, "rest_predicted_s": res["plan"]["predicted_command_s"] - res["plan"]["predicted_formation_s"],
        # processor seconds of the whole command over threads: on a machine shared with other jobs
        # the wall time overstates what the command costs, and this bounds the ratio from below
        "cpu_s": run.cpu_s,
        "plan_ratio_cpu_over_threads": run.cpu_s / vcpus / res["plan"]["predicted_command_s"],
        "rate_per_vcpu": pp / (runtime * vcpus), "rate_vs_fastsar": pp / (runtime * vcpus) / FASTSAR_RATE,
        "rate_vs_fastsar_whole_command": pp / (t * vcpus) / FASTSAR_RATE,
    }
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", choices=sorted(SIZES), default="full" if os.environ.get("SARCLI_BENCH_FULL") else "quarter")
    ap.add_argument("--dir", default=None, help="working folder (default: a temporary one)")
    ap.add_argument("--keep", action="store_true", help="keep the phase history and image")
    ap.add_argument("--check-direct", action="store_true", help="also check the closed-form reference against direct")
    ap.add_argument("--baseline", default=None, metavar="SAR",
                    help="another checkout's sar: plan and form-image run for both, alternating")
    ap.add_argument("--rounds", type=int, default=1, help="rounds of plan and form-image (default 1)")
    ap.add_argument("--reuse", action="store_true", help="with --dir: keep a phase history simulated there before")
    args = ap.parse_args(argv)
    sar = Path(sys.executable).with_name("sar")
    work = Path(args.dir or tempfile.mkdtemp(prefix="panama-"))
    work.mkdir(parents=True, exist_ok=True)
    cfg, (w, h) = config(args.size)
    P, M, (nx, ny) = SIZES[args.size]
    import yaml

    (work / "panama.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    ph_path, img_path = work / "ph.h5", work / "img.h5"
    vcpus = os.cpu_count() or 1
    res = {"size": args.size, "pulses": P, "frequencies": M, "vcpus": vcpus,
           "load_before": os.getloadavg()[0]}
    grid_opts = ["--extent", f"{w:.6f},{h:.6f}", "--pixel-size", f"{PIXEL_M}"]

    sides = [("this", sar)] + ([("baseline", Path(args.baseline))] if args.baseline else [])
    if not (args.reuse and ph_path.exists()):
        # with a baseline, both simulate (alternating, to new files); this side's last is the one imaged
        res["simulate_rounds"] = []
        for r in range(args.rounds if args.baseline else 1):
            for label, exe in (sides if r % 2 == 0 else sides[::-1]):
                out_path = work / f"ph-{label}-{r}.h5"
                out_path.unlink(missing_ok=True)
                t, rss, _ = run([exe, "-q", "simulate", work / "panama.yaml", "-o", out_path, "--noiseless"])
                res["simulate_rounds"].append({"side": label, "round": r, "s": t, "peak_rss_mb": rss / 2**20})
        last = [x for x in res["simulate_rounds"] if x["side"] == "this"][-1]
        res["simulate"] = {"s": last["s"], "peak_rss_mb": last["peak_rss_mb"]}
        (work / f"ph-this-{last['round']}.h5").replace(ph_path)
        for x in res["simulate_rounds"]:
            (work / f"ph-{x['side']}-{x['round']}.h5").unlink(missing_ok=True)
    res["rounds"] = []
    # every image goes to a new file, the earlier ones kept until the end: an image written over a
    # file just removed would find its memory in the kernel's file cache freed a moment before
    others = []
    for r in range(args.rounds):
        for label, exe in (sides if r % 2 == 0 else sides[::-1]):
            last_round = r == args.rounds - 1
            out_path = img_path if label == "this" and last_round else work / f"img-{label}-{r}.h5"
            out_path.unlink(missing_ok=True)
            env = {"SARCLI_CACHE_DIR": str(work / f"cache-{label}")}
            row = plan_and_form(exe, ph_path, out_path, grid_opts, P, vcpus, env)
            row.update(side=label, round=r)
            res["rounds"].append(row)
            if out_path != img_path:
                others.append(out_path)
    for p in others:
        p.unlink()
    last = [x for x in res["rounds"] if x["side"] == "this"][-1]
    res["plan"], res["form_image"] = last["plan"], last["form_image"]
    errs = errors(ph_path, img_path)
    res["error"] = {"max": max(errs), "median": float(np.median(errs)), "patches": len(errs)}
    if args.check_direct:
        res["closed_form_vs_direct"] = check_direct(ph_path)
    res["load_after"] = os.getloadavg()[0]
    print(json.dumps(res, indent=1))
    if not args.keep and not args.dir:
        shutil.rmtree(work)


if __name__ == "__main__":
    main()
