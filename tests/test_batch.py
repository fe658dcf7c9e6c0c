"""sar batch on dask: plan validation, serial equivalence, tiles, sub-apertures, resume.

One LocalCluster (2 worker processes, loopback) serves the whole module; the phase histories are
small (64 frequencies x 32 pulses, 64 x 64 pixels) so the module runs in well under a minute.
"""

from __future__ import annotations

import json
import logging
import os

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import sarcli
from sarcli.batch.run import load_plan, parse_plan, run_job, run_plan, subaperture_windows, tile_layout
from sarcli.cli.main import cli
from sarcli.io.config import parse_acquisition
from sarcli.errors import ConfigError
from sarcli.formers.formation import form_image, image_error
from sarcli.core.types import PhaseHistory
from sarcli.io.hdf5 import read_image, read_phase_history

from .conftest import CONFIGS, GOTCHA_DIR, GOTCHA_FILES, small_config

import distributed  # noqa: E402  (a hard dependency: never skipped)


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                       dashboard_address=None, silence_logs=logging.ERROR)
    cl = distributed.Client(cluster)
    try:
        yield cl
    finally:
        cl.close()
        cluster.close()


def _simulate(path, **overrides):
    ph = sarcli.simulate(parse_acquisition(small_config(**overrides)), seed=3, snr_db=None)
    sarcli.write_phase_history(path, ph)
    return path


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    d = tmp_path_factory.mktemp("batch-data")
    for i, c in enumerate((50.0, 95.0, 140.0)):
        _simulate(d / f"ph{i}.h5", azimuths={"center_deg": c, "extent_deg": 3.0, "count": 32})
    return d


def _write_plan(path, plan):
    path.write_text(yaml.safe_dump(plan, sort_keys=False))
    return path


# ---------------------------------------------------------------------------------------------
# plan validation (no cluster needed)
# ---------------------------------------------------------------------------------------------
def test_bad_plan_one_line_per_mistake_exit_2(tmp_path, data):
    plan = _write_plan(tmp_path / "bad.yaml", {
        "defaults": {"method": "backprojection"},
        "jobs": [{"input": str(data / "nothing*.h5")},
                 {"input": str(data / "ph0.h5"), "method": "nufft", "options": {"epss": 1e-6}},
                 {"tiles": {"input": str(data / "ph0.h5"), "tiles": 0}},
                 {"subapertures": {"input": str(data / "ph0.h5"), "window_deg": 30, "composite": "median"}}],
        "workers": 4})
    res = CliRunner().invoke(cli, ["batch", str(plan), "-o", str(tmp_path / "out")])
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 5
    for key in ("'workers'", "'jobs[0].input'", "'jobs[1].options.epss'", "'jobs[2].tiles.tiles'",
                "'jobs[3].subapertures.composite'"):
        assert sum(key in ln and str(plan) in ln for ln in lines) == 1, key
    assert not (tmp_path / "out").exists()


def test_duplicate_outputs_rejected(tmp_path, data):
    plan = _write_plan(tmp_path / "dup.yaml", {"jobs": [
        {"input": str(data / "ph0.h5"), "method": "direct", "output": "a.h5"},
        {"input": str(data / "ph1.h5"), "method": "direct", "output": "a.h5"}]})
    with pytest.raises(ConfigError, match=r"jobs\[1\]'.*'a.h5' is also written by jobs\[0\]"):
        load_plan(plan)
    text = tmp_path / "text.yaml"
    text.write_text(f"jobs:\n  - {{input: {data / 'ph0.h5'}, method: nufft, options: {{eps: 1e-6}}}}\n")
    with pytest.raises(ConfigError, match=r"text.yaml: key 'jobs\[0\].options.eps': expected a number, got '1e-6'"):
        load_plan(text)


def test_fingerprint_ignores_plan_order_and_threads(data):
    a = {"input": str(data / "ph0.h5"), "method": "direct"}
    b = {"tiles": {"input": str(data / "ph1.h5"), "tiles": 2, "method": "backprojection"}}
    one = {j.name: j.fingerprint for j in parse_plan({"jobs": [a, b]}).jobs}
    two = {j.name: j.fingerprint for j in parse_plan({"jobs": [b, a], "threads_per_job": 2}).jobs}
    assert one == two and len(one) == 1 + 4 + 1
    changed = parse_plan({"jobs": [{**a, "options": {"window": "hann"}}]}).jobs[0]
    assert changed.fingerprint != one["ph0_direct.h5"]


def test_windows_and_tiles_cover_everything():
    az = np.radians(np.arange(360) + 0.5)
    wins = subaperture_windows(az, 30.0, 10.0)
    assert len(wins) == 18                      # starts 0, 20, ..., 320, then one aligned to the end
    assert all(len(p) == 30 for _, _, p in wins)
    assert set().union(*(set(p) for _, _, p in wins)) == set(range(360))
    assert [len(p) for _, _, p in subaperture_windows(az, 30.0, 0.0)] == [30] * 12
    assert tile_layout(10, 4) == [(0, 2), (2, 5), (5, 8), (8, 10)]


# ---------------------------------------------------------------------------------------------
# on the cluster
# ---------------------------------------------------------------------------------------------
def test_six_jobs_equal_serial_images(client, tmp_path, data):
    plan = _write_plan(data / "six.yaml", {"jobs": [
        {"input": "ph*.h5", "method": "backprojection"},
        {"input": "ph*.h5", "method": "direct", "grid": {"extent": [6.0, 4.0], "pixel_size": 0.125,
                                                           "center": [0.5, -0.25]}}]})
    report = run_plan(plan, tmp_path / "out", client=client)
    assert report.ok and report.count("done") == 6 and report.workers == 2
    for i in range(3):
        ph = read_phase_history(data / f"ph{i}.h5")
        bp = form_image(ph, "backprojection", nthreads=1).image
        dr = form_image(ph, "direct", extent=(6.0, 4.0), pixel_size=0.125, center=(0.5, -0.25)).image
        out_bp = read_image(tmp_path / "out" / f"ph{i}_backprojection.h5")
        out_dr = read_image(tmp_path / "out" / f"ph{i}_direct.h5")
        assert np.array_equal(out_bp.image, bp)          # deterministic: bit-identical
        assert np.array_equal(out_dr.image, dr)
        assert out_dr.image.shape == (32, 48)
        assert out_bp.attrs["batch_input"] == str((data / f"ph{i}.h5").resolve())


def test_job_warnings_reach_the_driver_with_the_job_name(client, tmp_path, data):
    from sarcli.errors import DefocusWarning

    plan = parse_plan({"jobs": [{"input": str(data / "ph0.h5"), "method": "nufft"}]})
    with pytest.warns(DefocusWarning, match=r"^ph0_nufft.h5: far-field method 'nufft' on spherical data"):
        report = run_plan(plan, tmp_path / "out", client=client)
    assert report.ok and report.results[0].warnings[0][0] == "DefocusWarning"


def test_tiles_4x4_backprojection_equals_single_grid(client, tmp_path, data):
    plan = _write_plan(tmp_path / "tiles.yaml", {"jobs": [
        {"tiles": {"input": str(data / "ph0.h5"), "tiles": 4, "method": "backprojection", "name": "t0"}},
        {"tiles": {"input": str(data / "ph0.h5"), "tiles": 4, "margin_px": 3, "method": "backprojection",
                   "name": "t3"}}]})
    report = run_plan(plan, tmp_path / "out", client=client)
    assert report.ok and report.count("done") == 2 * (16 + 1)
    ref = form_image(read_phase_history(data / "ph0.h5"), "backprojection", nthreads=1)
    for name in ("t0", "t3"):
        img = read_image(tmp_path / "out" / name / "stitched.h5")
        np.testing.assert_array_equal(img.x_m, ref.x_m)
        # the kernel's per-tile range model (within MODEL_TOLERANCE = 1e-5 rad) depends on where
        # its pixel tiles fall, so a tiled image agrees with the whole one to that size (3.6e-6)
        assert image_error(img.image, ref.image) <= 1e-5
        assert img.parameters["stitch"] == "exact"
    tile = read_image(tmp_path / "out" / "t3" / "tile_r1_c2.h5")
    assert tile.image.shape == (16 + 6, 16 + 6)


def test_subapertures_circular_360(client, tmp_path):
    cfg = yaml.safe_load((CONFIGS / "circular-360.yaml").read_text())
    cfg["frequencies"]["count"] = 32
    cfg["image"]["pixels"] = 48
    ph = sarcli.simulate(parse_acquisition(cfg), seed=1, snr_db=None)
    sarcli.write_phase_history(tmp_path / "circ.h5", ph)
    plan = _write_plan(tmp_path / "sub.yaml", {"defaults": {"method": "backprojection"}, "jobs": [
        {"subapertures": {"input": "circ.h5", "window_deg": 30, "overlap_deg": 0, "composite": "max", "name": "circ"}},
        {"subapertures": {"input": "circ.h5", "window_deg": 30, "overlap_deg": 15, "composite": "mean",
                          "name": "circ-mean"}}]})
    report = run_plan(plan, tmp_path / "out", client=client)
    assert report.ok and report.count("done") == 13 + 24
    mags = []
    wins = subaperture_windows(ph.acquisition.azimuth_rad, 30.0, 0.0)
    assert len(wins) == 12
    for k, (_, _, pulses) in enumerate(wins):
        sel = np.asarray(pulses)
        alone = form_image(PhaseHistory(ph.data[sel], ph.acquisition.subset(pulses=sel)), "backprojection",
                           nthreads=1)
        img = read_image(tmp_path / "out" / "circ" / f"window_{k:03d}.h5")
        assert img.parameters["subaperture"]["n_pulses"] == 120
        assert np.array_equal(img.image, alone.image)
        mags.append(np.abs(alone.image))
    comp = read_image(tmp_path / "out" / "circ" / "composite.h5")
    assert "maximum" in comp.attrs["composite"] and comp.parameters["n_windows"] == 12
    assert np.max(np.abs(comp.image - np.max(mags, axis=0))) <= 1e-12
    # every window images the unit point at the centre with a peak near 1, so does the composite
    row, col = comp.grid.index_of(0.0, 0.0)
    assert abs(comp.image[row, col]) == pytest.approx(1.0, abs=0.02)
    assert abs(comp.image[row, col]) == np.abs(comp.image).max()
    # incoherent mean over 23 windows advancing by 15 degrees
    wins = sorted((tmp_path / "out" / "circ-mean").glob("window_*.h5"))
    assert len(wins) == 23
    mean = np.mean([np.abs(read_image(w).image) for w in wins], axis=0)
    comp = read_image(tmp_path / "out" / "circ-mean" / "composite.h5")
    assert "incoherent mean" in comp.attrs["composite"]
    assert np.max(np.abs(comp.image - mean)) <= 1e-12


def test_resume_after_failure_only_missing_outputs_made(client, tmp_path, data):
    bad = tmp_path / "broken.h5"
    bad.write_text("not an HDF5 file: this job raises on purpose")
    plan = {"defaults": {"method": "backprojection"},
            "jobs": [{"input": str(data / "ph*.h5")}, {"input": str(bad), "output": "broken.h5"}]}
    plan_path = _write_plan(tmp_path / "plan.yaml", plan)
    out = tmp_path / "out"
    args = ["batch", str(plan_path), "-o", str(out), "--scheduler", client.scheduler.address]
    first = CliRunner().invoke(cli, args)
    assert first.exit_code == 1
    assert f"failed: broken.h5 (input {bad})" in first.output and "not a readable HDF5 file" in first.output
    made = {p.name: p.stat().st_mtime_ns for p in out.glob("ph*.h5")}
    assert len(made) == 3 and not (out / "broken.h5").exists()

    _simulate(bad)                                # repair the input, re-run: only it is made
    second = CliRunner().invoke(cli, args)
    assert second.exit_code == 0, second.output
    status = {r["name"]: r["status"] for r in json.loads((out / "batch-report.json").read_text())["results"]}
    assert status == {"ph0_backprojection.h5": "skipped", "ph1_backprojection.h5": "skipped",
                      "ph2_backprojection.h5": "skipped", "broken.h5": "done"}
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("ph*.h5")} == made

    plan["jobs"][1]["options"] = {"window": "hann"}    # a changed job spec is redone, not skipped
    _write_plan(plan_path, plan)
    report = run_plan(plan_path, out, client=client)
    assert [r.status for r in report.results] == ["skipped"] * 3 + ["done"]
    assert read_image(out / "broken.h5").parameters["window"] == "hann"


@pytest.mark.gotcha
def test_gotcha_file_job_serial(tmp_path):
    files = GOTCHA_FILES
    from sarcli.io.gotcha import read_gotcha

    plan = _write_plan(tmp_path / "g.yaml", {"jobs": [{"input": str(GOTCHA_DIR / "*.mat"), "method": "backprojection",
                                                       "grid": {"extent": 20.0, "pixel_size": 0.5}}]})
    jobs = load_plan(plan).jobs
    assert [j.name for j in jobs] == [f"{f.stem}_backprojection.h5" for f in files]
    res = run_job(jobs[0], tmp_path / "out")
    assert res.status == "done", res.error
    ref = form_image(read_gotcha(files[0]), "backprojection", extent=20.0, pixel_size=0.5, nthreads=1)
    assert np.array_equal(read_image(tmp_path / "out" / jobs[0].name).image, ref.image)
    assert run_job(jobs[0], tmp_path / "out").status == "skipped"


def test_cli_embedded_local_cluster(tmp_path, data):
    plan = _write_plan(tmp_path / "one.yaml", {"jobs": [{"input": str(data / "ph1.h5"), "method": "direct",
                                                         "output": "one/{stem}.h5"}]})
    out = tmp_path / "out"
    res = CliRunner().invoke(cli, ["batch", str(plan), "-o", str(out), "--workers", "1"])
    assert res.exit_code == 0, res.output
    assert "1 jobs: 1 done" in res.output and "on 1 worker(s)" in res.output
    ref = form_image(read_phase_history(data / "ph1.h5"), "direct")
    assert np.array_equal(read_image(out / "one" / "ph1.h5").image, ref.image)
    both = CliRunner().invoke(cli, ["batch", str(plan), "-o", str(out), "--workers", "1", "--scheduler", "tcp://x:1"])
    assert both.exit_code == 2 and "--workers" in both.output



@pytest.mark.skipif(not os.path.exists("/proc/self/task"), reason="needs Linux /proc")
def test_interrupt_finds_grandchildren():
    """On an interruption the grandchildren (a dask nanny's worker) are stopped too, before their
    parents: the watchdog finds every process below it, parents first."""
    import subprocess
    import sys
    import time

    from sarcli._util.interrupt import descendants

    code = ("import subprocess, sys, time; "
            "subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(30)']); time.sleep(30)")
    child = subprocess.Popen([sys.executable, "-c", code])
    grand = []
    try:
        for _ in range(200):
            grand = descendants(child.pid)
            if grand:
                break
            time.sleep(0.05)
        assert len(grand) == 1
        mine = descendants(os.getpid())   # other tests' helpers (a resource tracker) may be there too
        assert mine.index(child.pid) < mine.index(grand[0])
    finally:
        for pid in grand + [child.pid]:
            os.kill(pid, 9)
        child.wait()
