"""``--method auto --tolerance``: the planner's pick meets the tolerance against ``direct``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.core.grid import Grid
from sarcli.core.types import PhaseHistory
from sarcli.errors import SarcliInputError
from sarcli.formers.formation import form_image, image_error
from sarcli.formers.planning.planner import candidates, load_cost_model, recommend

GRID = Grid(48, 48, 0.5, 0.5)
FREQ = 9.6e9 + 4e6 * np.arange(96)
RNG = np.random.default_rng(11)
POINTS = np.column_stack([RNG.uniform(-11, 11, 8), RNG.uniform(-11, 11, 8), np.zeros(8)])
AMPS = RNG.normal(size=8) + 1j * RNG.normal(size=8)


def spherical(r0=10e3, P=96):
    az = np.radians(np.linspace(-2.5, 2.5, P))
    el = np.radians(30)
    a = geometry.antenna_positions_circle(az, el, r0)
    rr = np.linalg.norm(a, axis=1)
    dr = geometry.differential_range(a, rr, POINTS)
    data = (np.exp(-1j * 4 * np.pi / geometry.C * FREQ[None, :, None] * dr[:, None, :]) * AMPS).sum(-1)
    return PhaseHistory(data, Acquisition(FREQ, az, np.full(P, el), GRID, antenna_position_m=a,
                                          range_to_center_m=rr, model="spherical"))


@pytest.fixture(scope="module")
def sph():
    ph = spherical()
    return ph, form_image(ph, "direct").image


@pytest.mark.parametrize("tol", [1e-2, 1e-3, 1e-4])
def test_auto_meets_tolerance_on_spherical_data(sph, tol):
    ph, ref = sph
    img = form_image(ph, "auto", tolerance=tol)
    err = image_error(img.image, ref)
    assert err <= tol, (img.parameters["auto"], err)
    auto = img.parameters["auto"]
    assert auto["tolerance"] == tol and auto["predicted_error"] <= tol and auto["choice"] == img.method


def test_auto_prefers_a_nufft_when_one_meets(sph):
    ph, _ = sph
    cands = candidates(ph, GRID, 1e-2)
    pick = recommend(ph, GRID, 1e-2)
    # at 1e-2 on this grid a NUFFT former (subimage) meets the tolerance, so the pick is no slow one
    assert any(c.meets and c.method in ("nufft", "subimage") for c in cands), [(c.method, c.meets) for c in cands]
    assert pick.method not in ("backprojection", "direct")
    assert {"direct", "backprojection", "ffbp"} <= {c.method for c in cands}


def test_auto_on_farfield_data_is_nufft():
    P = 64
    az = np.radians(np.linspace(-3, 3, P))
    el = np.full(P, np.radians(30))
    psi = geometry.signal_phase(FREQ, az, el, POINTS, model="farfield")
    ph = PhaseHistory((np.exp(-1j * psi) * AMPS).sum(-1), Acquisition(FREQ, az, el, GRID, model="farfield"))
    img = form_image(ph, "auto", tolerance=1e-6)
    assert img.method == "nufft" and img.parameters["eps"] == pytest.approx(1e-7)
    assert image_error(img.image, form_image(ph, "direct").image) <= 1e-6


def test_bad_tolerance_is_a_user_error(sph):
    with pytest.raises(SarcliInputError, match="tolerance"):
        recommend(sph[0], GRID, 2.0)


def test_ffbp_fit_recovers_constants_and_keeps_a_floor():
    """The fit of ffbp's four constants: exact where the settings separate the terms; where the
    timings would send a term to 0, it keeps FFBP_FLOOR of its default-ratio share instead."""
    from sarcli.formers.planning.calibration import DEFAULT_COSTS
    from sarcli.formers.planning.cost import FFBP_TERMS
    from sarcli.formers.planning.planner import FFBP_FLOOR, _fit_ffbp

    names = [name for name, _ in FFBP_TERMS][:4]
    d = np.array([DEFAULT_COSTS[name] for name in names])
    rows = np.random.default_rng(0).uniform(1e6, 1e8, (6, 4))
    true = d * np.array([2.0, 0.5, 1.0, 3.0])
    np.testing.assert_allclose(_fit_ffbp(rows, rows @ true, names), true, rtol=1e-9)
    got = _fit_ffbp(rows, rows @ (d * np.array([1.0, 0.0, 0.0, 1.0])), names)
    assert np.all(got > 0) and np.all(got[1:3] <= 2 * FFBP_FLOOR * d[1:3])
    # a setting with no work in a term (no merges) leaves the fit finite
    rows[0, 2:] = 0.0
    assert np.all(np.isfinite(_fit_ffbp(rows, rows @ true, names)))


def test_cost_model_has_every_constant():
    """Every former's constants are positive, ffbp's four fitted ones included (each keeps a
    floor, :func:`sarcli.formers.planning.planner._fit_ffbp`), and they give a plan a positive time."""
    from sarcli.formers import ffbp as fb
    from sarcli.formers.planning.cost import FFBP_TERMS, ffbp_seconds

    c = load_cost_model()
    for key in ("direct", "bp", "nufft_spread", "subimage_point"):
        assert c[key] > 0
    assert all(c[name] > 0 for name, _ in FFBP_TERMS)
    a = geometry.antenna_positions_circle(np.radians(np.linspace(-3, 3, 64)), np.radians(30), 1e4)
    plan = fb.plan_stages(a, 9.6e9 + 4e6 * np.arange(64), Grid(64, 64, 0.5, 0.5))
    assert ffbp_seconds(c, plan.ops, 64, 128) > c["bp_fft"] * 64 * 128 * 7


def test_cli_plan_and_form_image_auto(tmp_path, sph):
    from sarcli.cli.main import cli
    from sarcli.io.hdf5 import read_image, write_phase_history

    src = tmp_path / "ph.h5"
    write_phase_history(src, sph[0])
    res = CliRunner().invoke(cli, ["plan", str(src), "--tolerance", "1e-3"])
    assert res.exit_code == 0, res.output
    assert "<- auto" in res.output and "ffbp" in res.output
    res = CliRunner().invoke(cli, ["plan", str(src), "--tolerance", "1e-3", "--json"])
    doc = json.loads(res.output)
    assert doc["auto"]["meets"] and doc["tolerance"] == 1e-3
    out = tmp_path / "img.h5"
    res = CliRunner().invoke(cli, ["-q", "form-image", str(src), "-o", str(out), "--method", "auto",
                                   "--tolerance", "1e-3"])
    assert res.exit_code == 0, res.output
    params = read_image(out).parameters
    assert params["auto"]["tolerance"] == 1e-3 and params["auto"]["choice"] == doc["auto"]["method"]


@pytest.mark.parametrize("tol", [1e-2, 1e-4])
def test_ffbp_without_knobs_takes_autos_ffbp_pick(sph, tol):
    ph, ref = sph
    ff = [c for c in candidates(ph, GRID, tol) if c.method == "ffbp"]
    met = [c for c in ff if c.meets]
    want = min(met, key=lambda c: c.seconds) if met else min(ff, key=lambda c: c.predicted_error)
    img = form_image(ph, "ffbp", tolerance=tol)
    assert img.parameters["knobs_for_tolerance"] == tol
    for k, v in want.knobs.items():
        assert img.parameters[k] == v, (k, img.parameters[k], v)
    if met:
        assert image_error(img.image, ref) <= tol


def test_ffbp_with_one_knob_keeps_the_defaults_for_the_others(sph):
    ph, _ = sph
    img = form_image(ph, "ffbp", base=8)
    assert "knobs_for_tolerance" not in img.parameters and img.parameters["base"] == 8


def test_pruned_plan_picks_what_the_full_plan_picks(sph):
    ph, _ = sph
    for tol in (1e-2, 1e-3, 1e-4):
        full = [c for c in candidates(ph, GRID, tol) if c.meets]
        if any(c.method in ("nufft", "subimage") for c in full):
            full = [c for c in full if c.method not in ("backprojection", "direct")]
        best = min(full, key=lambda c: c.seconds)
        pick = recommend(ph, GRID, tol)
        assert (pick.method, pick.knobs) == (best.method, best.knobs)


def test_calibration_is_kept_per_machine(tmp_path, monkeypatch):
    """A calibration serves only the machine it was measured on; until then the shipped one."""
    import json

    from sarcli.formers.planning import calibration as cal

    monkeypatch.setenv("SARCLI_CACHE_DIR", str(tmp_path))
    assert not cal.is_calibrated() and load_cost_model()["calibrated"] is False
    mine = cal.user_cost_model_path()
    mine.write_text(json.dumps({"machine": cal.machine(), "seconds_per_op": {"bp": 1.25e-7}}))
    c = load_cost_model()
    assert c["calibrated"] is True and c["bp"] == 1.25e-7 and c["direct"] > 0
    other = dict(cal.machine(), cpu="another CPU")
    monkeypatch.setattr(cal, "machine", lambda: other)
    assert cal.user_cost_model_path() != mine and not cal.is_calibrated()
    # nor kernels rebuilt since: the build fingerprint follows the modules' files
    rebuilt = dict(cal.machine(), kernels="0" * 12)
    monkeypatch.setattr(cal, "machine", lambda: rebuilt)
    assert cal.user_cost_model_path() != mine and not cal.is_calibrated()


def test_kernel_build_fingerprint_follows_the_module_files(tmp_path, monkeypatch):
    import os
    import shutil
    from pathlib import Path

    import sarcli._native as nat

    real = nat.build_id()
    for f in Path(nat.load("runtime").__file__).parent.glob("_runtime*.so"):
        shutil.copy(f, tmp_path / f.name)
    so = next(tmp_path.glob("_runtime*.so"))
    monkeypatch.setattr(nat, "load", lambda family: type("M", (), {"__file__": str(so)}))
    first = nat.build_id()
    assert first != real   # one module, not all of them
    assert first == nat.build_id() and len(first) == 12
    st = so.stat()
    os.utime(so, ns=(st.st_atime_ns, st.st_mtime_ns + 10 ** 9))
    assert nat.build_id() != first


def test_command_seconds_adds_what_the_command_pays(sph):
    from sarcli.formers.planning.planner import command_seconds

    ph, _ = sph
    c = dict(load_cost_model(), startup=0.3, planning=0.02, read_per_byte=1e-9, write_per_byte=2e-9)
    cand = recommend(ph, GRID, 1e-3, costs=c)
    # the samples at their stored size, the image as written (complex128)
    io = 1e-9 * ph.data.dtype.itemsize * ph.data.size + 2e-9 * 16 * GRID.nx * GRID.ny
    assert command_seconds(cand, ph, GRID, c) == pytest.approx(0.3 + io + cand.seconds)
    assert command_seconds(cand, ph, GRID, c, auto=True) == pytest.approx(0.32 + io + cand.seconds)


def test_command_seconds_at_the_present_load_stretches_each_part_by_its_share(sph):
    """With n other runnable threads on p processors a part on t threads takes (t + n)/p as long once
    t + n > p: the formation on the cost model's threads, the rest (start-up, I/O) on one."""
    from sarcli._util.load import Load
    from sarcli.formers.planning.planner import command_seconds

    ph, _ = sph
    c = dict(load_cost_model(), startup=0.3, planning=0.0, read_per_byte=0.0, write_per_byte=0.0,
             write_per_byte_large=0.0, threads=2)
    cand = recommend(ph, GRID, 1e-3, costs=c)
    idle = command_seconds(cand, ph, GRID, c)
    assert command_seconds(cand, ph, GRID, c, load=Load(0.0, 2)) == pytest.approx(idle)
    assert command_seconds(cand, ph, GRID, c, load=Load(1.0, 2)) == pytest.approx(0.3 + 1.5 * cand.seconds)
    assert command_seconds(cand, ph, GRID, c, load=Load(3.0, 2)) == pytest.approx(0.3 * 2 + 2.5 * cand.seconds)
    assert command_seconds(cand, ph, GRID, c, load=Load(3.0, 2), nthreads=1) == pytest.approx(0.6 + 2 * cand.seconds)


def test_present_load_counts_the_other_runnable_threads(tmp_path):
    """procs_running less this process's own thread, averaged over the samples; no /proc: idle."""
    from sarcli._util.load import Load, present_load, usable_cpus

    stat = tmp_path / "stat"
    stat.write_text("cpu  1 2 3 4\nprocs_running 4\nprocs_blocked 0\n")
    got = present_load(samples=3, interval_s=0.0, path=str(stat))
    assert got == Load(3.0, usable_cpus())
    assert present_load(samples=2, interval_s=0.0, path=str(tmp_path / "missing")).others == 0.0
    assert Load(3.0, 2).slowdown(2) == pytest.approx(2.5) and Load(0.5, 4).slowdown(2) == 1.0


def test_a_files_write_costs_its_first_bytes_at_one_rate_and_the_rest_at_another(sph):
    """write_seconds: the calibrated rate of a file's first WRITE_BYTES, the large-file rate beyond;
    command_seconds charges the image as stored through it."""
    from sarcli.formers.planning.calibration import WRITE_BYTES
    from sarcli.formers.planning.cost import write_seconds
    from sarcli.formers.planning.planner import command_seconds

    c = {"write_per_byte": 1e-9, "write_per_byte_large": 1e-8}
    assert write_seconds(c, 1000) == pytest.approx(1e-6)
    assert write_seconds(c, WRITE_BYTES) == pytest.approx(1e-9 * WRITE_BYTES)
    assert write_seconds(c, 3 * WRITE_BYTES) == pytest.approx(1e-9 * WRITE_BYTES + 2e-8 * WRITE_BYTES)
    assert write_seconds({"write_per_byte": 1e-9}, 3 * WRITE_BYTES) == pytest.approx(3e-9 * WRITE_BYTES)
    ph, _ = sph
    base = dict(load_cost_model(), startup=0.3, planning=0.0, read_per_byte=0.0, write_per_byte=1e-9)
    cand = recommend(ph, GRID, 1e-3, costs=base)
    image = 16 * GRID.nx * GRID.ny     # complex128 samples: a complex128 image
    for large in (1e-9, 1e-8, 1e-7):
        c = dict(base, write_per_byte_large=large)
        assert command_seconds(cand, ph, GRID, c) == pytest.approx(0.3 + cand.seconds + write_seconds(c, image))


def test_calibration_writes_new_files_the_way_form_image_writes_images(tmp_path, monkeypatch):
    """write_costs writes WRITE_FILES images through write_image (complex128 stored complex64), each
    to a new file kept until the end, and divides by the stored bytes."""
    from sarcli.formers.planning import calibration as cal
    from sarcli.io import h5output, hdf5

    calls = []
    real = hdf5.write_image

    def spy(path, img, dtype=None):
        calls.append((path.name, img.image.dtype, np.dtype(dtype), sorted(p.name for p in tmp_path.iterdir())))
        return real(path, img, dtype)

    monkeypatch.setattr(hdf5, "write_image", spy)
    first, large = cal.write_costs(tmp_path)
    assert first > 0 and large > 0
    assert len(calls) == cal.WRITE_FILES == len({name for name, *_ in calls})
    for i, (name, src, stored, before) in enumerate(calls):
        assert src == np.complex128 and stored == np.complex64
        assert len(before) == i                      # the earlier files are all still there
    assert 4096 * (cal.WRITE_BYTES // (4096 * 8)) * 8 == cal.WRITE_BYTES > h5output.IN_MEMORY_MAX_BYTES


def test_calibration_reads_by_blocks_of_rows_as_the_formers_read_pulses(monkeypatch):
    """command_costs times reads of READ_ROWS rows into one buffer through PulseArray (the formers'
    reader of a phase history left on disk), every row once per pass."""
    from sarcli.formers.planning import calibration as cal
    from sarcli.io.pulses import PulseArray

    reads, buffers = [], set()
    real = PulseArray.read_into

    def spy(self, rows, out):
        reads.append((rows.start, rows.stop))
        buffers.add(out.__array_interface__["data"][0])
        return real(self, rows, out)

    monkeypatch.setattr(PulseArray, "read_into", spy)
    monkeypatch.setattr(cal, "write_costs", lambda folder: (1e-9, 2e-9))
    c = cal.command_costs(1)
    assert c["read_per_byte"] > 0 and (c["write_per_byte"], c["write_per_byte_large"]) == (1e-9, 2e-9)
    assert len(buffers) == 1 and all(b - a == cal.READ_ROWS for a, b in reads)
    passes = len(reads) * cal.READ_ROWS // 512
    assert passes == 2 and sorted(reads) == sorted([(r, r + cal.READ_ROWS) for r in range(0, 512, cal.READ_ROWS)] * 2)


def test_sar_plan_measures_an_uncalibrated_machine_once(tmp_path, monkeypatch, sph):
    import json

    from sarcli.cli.main import cli
    from sarcli.formers.planning import calibration as cal
    from sarcli.io.hdf5 import write_phase_history

    monkeypatch.setenv("SARCLI_CACHE_DIR", str(tmp_path))
    calls = []

    def fake(path=None, **kw):
        calls.append(1)
        cal.user_cost_model_path().write_text(json.dumps({"seconds_per_op": dict(cal.DEFAULT_COSTS, startup=0.25)}))

    import sarcli.formers.planning.planner as planner_mod

    monkeypatch.setattr(planner_mod, "calibrate", fake)
    src = tmp_path / "ph.h5"
    write_phase_history(src, sph[0])
    first = CliRunner().invoke(cli, ["plan", str(src), "--json"])
    assert first.exit_code == 0, first.output
    assert calls == [1] and "measuring this machine's cost model" in first.output
    again = CliRunner().invoke(cli, ["plan", str(src), "--json"])
    assert calls == [1] and "measuring" not in again.output
    doc = json.loads(again.output)
    for c in doc["candidates"]:
        assert c["predicted_command_s"] >= c["predicted_s"] + 0.25
        assert c["predicted_command_now_s"] >= c["predicted_command_s"] - 1e-12
    assert doc["load"]["cpus"] >= 1 and doc["load"]["other_runnable_threads"] >= 0.0
    assert doc["auto"]["predicted_command_now_s"] >= doc["auto"]["predicted_command_s"] - 1e-12
    CliRunner().invoke(cli, ["plan", str(src), "--calibrate", "--json"])
    assert calls == [1, 1]


def test_calibrate_measures_every_constant(tmp_path):
    """The real measurement, written where asked, read back as this machine's model."""
    import json

    from sarcli.formers.planning.planner import calibrate

    path = tmp_path / "model.json"
    c = calibrate(path, repeat=1)
    doc = json.loads(path.read_text())
    assert doc["seconds_per_op"] == c and doc["machine"]["cpus"] >= 1
    for key in ("bp", "bp_fft", "direct", "ffbp_stage0", "ffbp_mac", "ffbp_pair", "ffbp_final", "ffbp_tone",
                "ffbp_touch", "nufft_spread", "subimage_point", "startup", "planning", "read_per_byte",
                "write_per_byte", "write_per_byte_large"):
        assert c[key] > 0, key


def _ffbp_picks_planned_fully(ph, grid, tol, costs):
    """ffbp's two candidates as planning every setting of the sweep fully gives them: the cheapest
    that meets the target and the most accurate that does not (ties: the first in the sweep)."""
    from sarcli.formers import ffbp as fb
    from sarcli.formers.backprojection import profile_length
    from sarcli.formers.ffbp.model import deapodized_error, default_upsample, frequency_error
    from sarcli.formers.planning.planner import FFBP_BASES, FFBP_OVERSAMPLINGS, FFBP_PAIRS_PAST_MET, SAFETY, ffbp_seconds

    acq, target = ph.acquisition, tol / SAFETY
    pos, rcv, _ = acq.range_geometry()
    rcv = rcv if acq.is_bistatic else None
    P, M = ph.data.shape
    met, miss, met_at = None, None, None
    for i, (os_r, os_a) in enumerate(FFBP_OVERSAMPLINGS):
        if met_at is not None and i > met_at + FFBP_PAIRS_PAST_MET:
            break
        up = default_upsample(os_r)
        while deapodized_error(up) > target / 8 and up < 16 * os_r:
            up *= 2
        for base in FFBP_BASES:
            try:
                lay = fb.layout_stages(pos, acq.frequency_hz, grid, base=base, os_range=os_r, os_angle=os_a,
                                       upsample=up, interp="optimal", receive_position_m=rcv)
            except SarcliInputError:
                continue
            plan = lay.plan()
            # the floors the sweep prunes by are below the error (to the rounding of their sums)
            for floor in (lay.error_floor(), lay.error_floor(above=-np.inf)):
                assert floor <= plan.predicted_error * (1 + 1e-12), (floor, plan.predicted_error)
            assert lay.error_floor(above=-np.inf) <= lay.error_floor()
            t = ffbp_seconds(costs, plan.ops, P, profile_length(M, up), costs["threads"])
            got = ({"base": base, "os_range": os_r, "os_angle": os_a, "upsample": up}, plan.predicted_error, t)
            if plan.predicted_error <= target:
                met_at = i if met_at is None else met_at
                met = got if met is None or t < met[2] else met
            elif miss is None or plan.predicted_error < miss[1]:
                miss = got
    return met, miss


def _picks(cands):
    ff = [c for c in cands if c.method == "ffbp"]
    out = [None, None]
    for c in ff:
        k = {n: c.knobs[n] for n in ("base", "os_range", "os_angle", "upsample")}
        out[0 if c.meets else 1] = (k, c.predicted_error, c.seconds)
    return tuple(out)


def _plan_cases():
    from sarcli import read_phase_history

    from .conftest import GOTCHA_DIR, REPO

    yield "circle", spherical(), GRID
    near = spherical(r0=1.5e3, P=160)
    yield "near", near, Grid(96, 96, 0.3, 0.3)
    a = near.acquisition
    rcv = geometry.antenna_positions_circle(np.radians(np.linspace(0.5, 5.5, 160)), np.radians(40), 2.5e3)
    bi = PhaseHistory(near.data, Acquisition(a.frequency_hz, a.azimuth_rad, a.elevation_rad, a.grid,
                                             transmit_position_m=a.antenna_position_m, receive_position_m=rcv,
                                             model="spherical"))
    yield "bistatic", bi, Grid(64, 64, 0.4, 0.4)
    demo = read_phase_history(REPO / "data" / "synthetic" / "three-points-small.h5")
    yield "demo", demo, demo.acquisition.grid
    files = sorted(GOTCHA_DIR.glob("data_3dsar_pass1_az00*_HH.mat"))[:4] if GOTCHA_DIR.is_dir() else []
    if len(files) == 4:
        from sarcli.io.gotcha import read_gotcha

        yield "gotcha", read_gotcha(files, grid=Grid.from_extent(100, 0.125)), Grid.from_extent(100, 0.125)


def test_the_sweep_picks_what_planning_every_setting_picks():
    """The planner lays out every ffbp setting but completes the error model only where it can
    change the answer: its picks are those of planning every setting fully, on geometries that
    deapodize, that do not and that widen the bands, at three tolerances (and, on one geometry, one
    that no ffbp setting meets); and ``recommend`` picks what the full list does. Both outcomes are
    covered by the synthetic cases alone: the GOTCHA case, where present, only adds to them."""
    c = dict(load_cost_model(), threads=2)
    seen = set()
    for name, ph, grid in _plan_cases():
        for tol in (1e-2, 1e-3, 1e-4) + ((1e-6,) if name == "near" else ()):
            want = _ffbp_picks_planned_fully(ph, grid, tol, c)
            full = candidates(ph, grid, tol, costs=c, nthreads=2)
            assert _picks(full) == want, (name, tol)
            pruned = candidates(ph, grid, tol, costs=c, nthreads=2, prune=True)
            assert _picks(pruned)[0] == want[0], (name, tol)
            pick = recommend(ph, grid, tol, costs=c, nthreads=2)
            met = [x for x in full if x.meets]
            if any(x.method in ("nufft", "subimage") for x in met):
                met = [x for x in met if x.method not in ("backprojection", "direct")]
            best = min(met, key=lambda x: x.seconds)
            assert (pick.method, pick.knobs, pick.seconds) == (best.method, best.knobs, best.seconds), (name, tol)
            seen.add((name, want[0] is not None, want[1] is not None))
    synthetic = {s for s in seen if s[0] != "gotcha"}
    assert {s[1] for s in synthetic} == {True, False} and {s[2] for s in synthetic} == {True, False}


def test_candidates_are_planned_once_per_geometry(sph, monkeypatch):
    from sarcli.formers.planning import planner

    ph = sph[0]
    planner._CANDIDATE_CACHE.clear()
    calls = []
    real = planner._candidates
    monkeypatch.setattr(planner, "_candidates", lambda *a: calls.append(1) or real(*a))
    first = candidates(ph, GRID, 1e-3)
    first[0].knobs["spoiled"] = True   # a caller's edits stay its own
    first.pop()
    again = candidates(ph, GRID, 1e-3)
    assert len(calls) == 1
    assert [(x.method, x.knobs, x.seconds) for x in again] == [(x.method, x.knobs, x.seconds) for x in real(
        ph, GRID, 1e-3, load_cost_model(), None, False, None)]
    # another tolerance, grid, cost model or geometry (same samples) is planned anew
    candidates(ph, GRID, 1e-2)
    candidates(ph, Grid(40, 40, 0.5, 0.5), 1e-3)
    candidates(ph, GRID, 1e-3, costs={**load_cost_model(), "ffbp_stage0": 2 * load_cost_model()["ffbp_stage0"]})
    moved = spherical(r0=11e3)
    assert len(calls) == 4
    candidates(moved, GRID, 1e-3)
    assert len(calls) == 5


def test_candidates_cache_is_shared_by_threads(sph, monkeypatch):
    """Threads planning several grids at once through a cache smaller than their number (each
    call evicts another's entry) each get the candidates of their own grid."""
    from concurrent.futures import ThreadPoolExecutor

    from sarcli.formers.planning import planner

    ph = sph[0]
    monkeypatch.setattr(planner, "_CANDIDATE_CACHE_SIZE", 2)
    planner._CANDIDATE_CACHE.clear()
    grids = [Grid(n, n, 0.5, 0.5) for n in (32, 40, 48, 56)]
    want = {g: [(x.method, x.knobs) for x in candidates(ph, g, 1e-3)] for g in grids}
    with ThreadPoolExecutor(4) as pool:
        got = list(pool.map(lambda g: (g, [(x.method, x.knobs) for x in candidates(ph, g, 1e-3)]), grids * 6))
    assert all(cands == want[g] for g, cands in got)
    assert len(planner._CANDIDATE_CACHE) <= 2


@pytest.mark.parametrize("tol", [1e-3, 1e-4])
def test_planner_picks_lagrange_for_backprojection(sph, tol):
    """Lagrange costs what Keys costs at the same upsampling and errs less (its error falls as 1/u⁴),
    so among backprojection's candidates it meets the tolerance at a lower upsampling or, at the
    same one, is listed first; its pick meets the tolerance against ``direct``."""
    ph, ref = sph
    bp = {c.knobs["interp"]: c for c in candidates(ph, GRID, tol, methods=("backprojection",))
          if c.method == "backprojection"}
    lag, keys = bp["lagrange"], bp["cubic"]
    assert lag.meets and lag.knobs["upsample"] < keys.knobs["upsample"] and lag.seconds < keys.seconds, (lag, keys)
    best = min((c for c in bp.values() if c.meets), key=lambda c: c.seconds)
    assert best.knobs["interp"] == "lagrange"
    img = form_image(ph, "backprojection", **best.knobs)
    assert image_error(img.image, ref) <= tol
