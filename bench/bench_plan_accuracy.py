"""The planner's predicted ffbp time against the measured, from small collections to a large one (no
assertions; target within 1.5x either way).

Runs as ``sar`` does (numpy's huge-page advice off, :func:`sarcli.cli.main.no_huge_pages`). First
calibrates the cost model in this run (:func:`sarcli.formers.planning.planner.calibrate`, written to a
temporary folder, not the user's cache), then for each case takes ``--method auto``'s ffbp pick at
tolerance 1e-3 (:func:`sarcli.formers.planning.planner.ffbp_knobs`), predicts its formation time
(:func:`sarcli.formers.planning.cost.ffbp_seconds`, the range profiles' FFTs included) and forms it
``--repeat`` times, reporting

- the best wall seconds and measured / predicted;
- the processor seconds of each part (``timings`` of :func:`sarcli.formers.ffbp.ffbp`) against
  what the cost model gives it (:func:`part_predictions`), and the
  wall time the parts would take on an idle machine, the one-thread profiles (reading, FFTs) at
  their processor seconds and the threaded parts at theirs over the threads, and that over the
  prediction: on a machine shared with other jobs the wall time is stretched by them, this is not.

Cases: the planner's own calibration collection (256 pulses x 256 frequencies onto 256², 10 km), a
circle of 1024 x 1024 samples onto 1024² (10 km), the four GOTCHA files onto 800² (where
``sarcli.io.gotcha.gotcha_dir()`` holds them), and, with ``--panama PH.h5``, a phase history written
by ``bench/bench_panama.py --keep`` (its grid: ``--panama-extent W,H`` at 0.15 m).

With ``--ranges`` the cases are instead ``bench_bp_range.py``'s collection at 200 m, 1 km and 10 km,
formed by ffbp's default knobs (base 16, os 2/2); with ``--drone``, a drone-like collection (Ku band,
16 GHz, 200 m slant range, 20° elevation, 2,048 pulses over ±1°, 512 frequencies, 1000² pixels of
5 cm) formed by ffbp without knobs. Both add the error against the exact matched filter (``direct``)
of the same geometry's point targets (``bench_bp_range.py``'s 24; the drone's 16), on a strided
sub-grid, and ffbp's predicted error.

    python bench/bench_plan_accuracy.py [--repeat 2] [--panama DIR/ph.h5 --panama-extent 900,900] [--ranges] [--drone]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time

from sarcli.cli.main import no_huge_pages

no_huge_pages()   # as `sar` runs (numpy reads the setting when first imported)

import numpy as np  # noqa: E402

from sarcli.core import geometry  # noqa: E402
from sarcli.core.acquisition import Acquisition  # noqa: E402
from sarcli.core.collection import Collection  # noqa: E402
from sarcli.core.grid import Grid  # noqa: E402
from sarcli.core.types import PhaseHistory  # noqa: E402

SERIAL = ("profiles",)   # parts run on one thread (reading; the FFTs of blocks under 2M samples)


def circle(P, M, N):
    freq = 9.6e9 + 2e6 * np.arange(M) * 256 / M
    az = np.radians(np.linspace(-3, 3, P))
    a = geometry.antenna_positions_circle(az, np.radians(30), 10e3)
    d = np.random.default_rng(0).normal(size=(P, M)) + 1j * np.random.default_rng(1).normal(size=(P, M))
    grid = Grid(N, N, 0.25, 0.25)
    acq = Acquisition(freq, az, np.full(P, np.radians(30)), grid, antenna_position_m=a,
                      range_to_center_m=np.linalg.norm(a, axis=1), model="spherical")
    return PhaseHistory(d.astype(np.complex64), acq), grid


def at_range(range_m, P=512, M=256, N=512):
    """``bench_bp_range.py``'s collection at ``range_m``: X band, 30° elevation, ±1.5° of a circle,
    pixels of 0.25 m (smaller where the range is short), frequencies alias-free over the scene."""
    h = min(0.25, range_m / (np.sqrt(2.0) * N))
    grid = Grid(N, N, h, h)
    el = np.radians(30.0)
    dalpha = geometry.C / (4.0 * 1.1 * grid.half_diagonal * np.cos(el))
    freq = 10e9 - dalpha * M / 2 + dalpha * np.arange(M)
    az = np.radians(np.linspace(-1.5, 1.5, P))
    a = geometry.antenna_positions_circle(az, el, range_m)
    d = np.random.default_rng(1).normal(size=(P, M)) + 1j * np.random.default_rng(2).normal(size=(P, M))
    acq = Acquisition(freq, az, np.full(P, el), grid, antenna_position_m=a,
                      range_to_center_m=np.linalg.norm(a, axis=1), model="spherical")
    return PhaseHistory(d.astype(np.complex64), acq), grid


def drone(P=2048, M=512, N=1000):
    """A drone-like collection: Ku band (16 GHz), 200 m slant range, 20° elevation, ±1° of a circle,
    pixels of 5 cm, frequencies alias-free over the scene; random samples, and 16 point targets'
    data (the collection and its points, as :func:`at_range` and ``bench_bp_range.problem``)."""
    grid = Grid(N, N, 0.05, 0.05)
    el = np.radians(20.0)
    dalpha = geometry.C / (4.0 * 1.1 * grid.half_diagonal * np.cos(el))
    freq = 16e9 - dalpha * M / 2 + dalpha * np.arange(M)
    az = np.radians(np.linspace(-1.0, 1.0, P))
    a = geometry.antenna_positions_circle(az, el, 200.0)
    r0 = np.linalg.norm(a, axis=1)
    rng = np.random.default_rng(5)
    half = 0.45 * N * grid.dx
    pts = np.column_stack([rng.uniform(-half, half, 16), rng.uniform(-half, half, 16), np.zeros(16)])
    amp = rng.normal(size=16) + 1j * rng.normal(size=16)
    psi = geometry.signal_phase(freq, az, el, pts, model="spherical", antenna_position_m=a, range_to_center_m=r0)
    points = np.einsum("pjs,s->pj", np.exp(-1j * psi), amp).astype(np.complex64)
    d = rng.normal(size=(P, M)) + 1j * rng.normal(size=(P, M))
    acq = Acquisition(freq, az, np.full(P, el), grid, antenna_position_m=a, range_to_center_m=r0, model="spherical")
    return PhaseHistory(d.astype(np.complex64), acq), grid, points


def cases(args):
    """(name, phase history, grid, point targets' data or None) of each case."""
    if args.ranges or args.drone:
        if args.ranges:
            sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
            from bench_bp_range import problem

            for r in (200.0, 1e3, 10e3):
                yield (f"{r:g} m, 512 x 256 -> 512²", *at_range(r), problem(r, 512, 512)[-1])
        if args.drone:
            yield "drone, 2048 x 512 -> 1000²", *drone()
        return
    from sarcli.io.gotcha import gotcha_dir, gotcha_files, read_gotcha

    yield "calibration collection, 256 x 256 -> 256²", *circle(256, 256, 256), None
    yield "circle, 1024 x 1024 -> 1024²", *circle(1024, 1024, 1024), None
    files = gotcha_files(gotcha_dir())[:4]
    if len(files) == 4:
        grid = Grid.from_extent(100, 0.125)
        yield "GOTCHA, 4 files -> 800²", read_gotcha(files, grid=grid), grid, None
    if args.panama:
        import sarcli

        ph = sarcli.read_phase_history(args.panama, lazy=True)
        w, h = (float(v) for v in args.panama_extent.split(","))
        grid = Grid.from_extent((w, h), 0.15)
        yield f"Panama file, {ph.data.shape[0]} x {ph.data.shape[1]} -> {grid.nx} x {grid.ny}", ph, grid, None


def part_predictions(c, ops, n_pulses, n_len) -> dict:
    """Processor seconds the cost model gives each part (seconds x threads, as the constants are);
    the first touch of the grids and the image is charged to the final stage, which makes the
    image."""
    def term(name, key):
        return c[name] * ops[key]

    return {"profiles": c["bp_fft"] * n_pulses * n_len * math.log2(n_len),
            "tones": term("ffbp_tone", "tones"),
            "stage0": term("ffbp_stage0", "stage0") + term("ffbp_node0", "stage0_nodes"),
            "merge": term("ffbp_mac", "merge") + term("ffbp_pair", "merge_pairs"),
            "final": term("ffbp_final", "final_pairs") + term("ffbp_touch", "fresh_bytes")}


def point_error(points, acq, grid, knobs) -> float:
    """ffbp's relative error against ``direct`` on the point targets' data, on a strided sub-grid."""
    from types import SimpleNamespace

    from sarcli.analysis.accuracy import reference_grid
    from sarcli.formers import ffbp as fb
    from sarcli.formers.direct import direct_spherical
    from sarcli.formers.formation import image_error

    a, r0, f = acq.antenna_position_m, acq.range_to_center_m, acq.frequency_hz
    img = fb.ffbp(points, Collection(f, a, r0), grid, **knobs)
    sub, rows, cols, _ = reference_grid(SimpleNamespace(data=points), grid, max_cost=3e8)
    return image_error(img[np.ix_(rows, cols)], direct_spherical(points, f, a, r0, sub))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--panama", default=None, help="a phase history written by bench_panama.py --keep")
    ap.add_argument("--ranges", action="store_true",
                    help="instead: bench_bp_range.py's collection at 200 m, 1 km and 10 km (ffbp's default knobs)")
    ap.add_argument("--drone", action="store_true",
                    help="instead (or with --ranges): a drone-like collection (Ku band, 200 m, 1000² of 5 cm)")
    ap.add_argument("--panama-extent", default="900,900", help="its grid's extent W,H in metres (0.15 m pixels)")
    args = ap.parse_args()
    from sarcli.formers import ffbp as fb
    from sarcli.formers.backprojection import profile_length
    from sarcli.formers.planning.cost import ffbp_seconds
    from sarcli.formers.planning.planner import calibrate, ffbp_knobs

    with tempfile.TemporaryDirectory() as tmp:
        c = calibrate(os.path.join(tmp, "cost.json"))
    thr = int(c["threads"])
    print(f"load average {os.getloadavg()[0]:.1f}; calibrated in this run\n")
    print("| case | pick | predicted s | measured wall s (/ predicted) | idle estimate s (/ predicted) "
          "| processor s by part (/ predicted) | grids (n x n_u x n_q); stage-0 taps, merge pairs, final pairs "
          "| error vs direct (predicted) |")
    print("|---|---|---|---|---|---|---|---|")
    for name, ph, grid, points in cases(args):
        acq = ph.acquisition
        if name.startswith("drone"):
            plan0 = fb.plan_stages(acq.antenna_position_m, acq.frequency_hz, grid)   # ffbp without knobs
            knobs = {k: plan0.knobs[k] for k in ("base", "merge", "os_range", "os_angle", "upsample")}
        elif args.ranges:
            knobs = dict(fb.DEFAULTS, base=16, os_range=2.0, os_angle=2.0, upsample=2.0)
        else:
            knobs = ffbp_knobs(ph, grid, 1e-3)
        plan = fb.plan_stages(acq.antenna_position_m, acq.frequency_hz, grid,
                              **{k: knobs[k] for k in ("base", "merge", "os_range", "os_angle", "upsample")})
        P, M = ph.data.shape
        pred = ffbp_seconds(c, plan.ops, P, profile_length(M, plan.knobs["upsample"]), thr)
        best_wall, best_parts = math.inf, None
        for _ in range(max(1, args.repeat)):
            parts = {}
            t = time.perf_counter()
            fb.ffbp(ph.data, Collection(acq.frequency_hz, acq.antenna_position_m, acq.range_to_center_m), grid,
                    timings=parts, **{k: knobs[k] for k in ("base", "merge", "os_range", "os_angle", "upsample")})
            wall = time.perf_counter() - t
            if wall < best_wall:
                best_wall, best_parts = wall, parts
        idle = sum(v if k in SERIAL else v / thr for k, v in best_parts.items())
        pick = f"base {knobs['base']}, os {knobs['os_range']:g}/{knobs['os_angle']:g}, {plan.n_stages} stages"
        want = part_predictions(c, plan.ops, P, profile_length(M, plan.knobs["upsample"]))
        by_part = ", ".join(f"{k} {v:.3g} ({v / want[k]:.2f})" for k, v in best_parts.items() if k in want)
        ops = plan.ops
        grids = " ".join(f"{lv.n}x{lv.n_u}x{lv.n_q}" for lv in plan.levels)
        err = "" if points is None else f"{point_error(points, acq, grid, knobs):.3g} ({plan.predicted_error:.2g})"
        print(f"| {name} | {pick} | {pred:.3g} | {best_wall:.3g} ({best_wall / pred:.2f}) | {idle:.3g} "
              f"({idle / pred:.2f}) | {by_part} | {grids}; {ops['stage0']:.3g}, {ops['merge_pairs']:.3g}, "
              f"{ops['final_pairs']:.3g} | {err} |", flush=True)
    print(f"\nload average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
