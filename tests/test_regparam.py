"""Automatic λ (:mod:`sarcli.regparam`): noise estimate, discrepancy path against a closed form,
``regularize(lam='auto')`` on a random-phase piecewise-constant scene, and ``sar regularize``."""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sarcli.cli.main import cli
from sarcli.errors import ConvergenceWarning, SarcliWarning
from sarcli.io.hdf5 import read_image, write_phase_history
from sarcli.regparam import LAM_PATH, discrepancy_lambda, estimate_noise_power, noise_power
from sarcli.regularize import matched_filter, regularize

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
from bench_lam import mag_error, scene  # noqa: E402


@pytest.fixture(scope="module")
def shapes():
    return scene("shapes", 10.0, n=32, seed=1)


def test_noise_estimate_on_pure_noise_and_on_a_scene(shapes):
    rng = np.random.default_rng(0)
    freq = np.linspace(9.85e9, 10.15e9, 64)
    noise = 3.0 * (rng.standard_normal((200, 64)) + 1j * rng.standard_normal((200, 64))) / np.sqrt(2)
    assert estimate_noise_power(noise, freq, 1.0) == pytest.approx(9.0, rel=0.05)
    ph, _ = shapes
    true = np.mean(np.abs(ph.data) ** 2) / (1 + 10 ** (10 / 10))   # SNR 10 dB: σ² = mean|d|²/11
    est, source = noise_power(ph, ph.acquisition.grid)
    assert "estimated" in source and est == pytest.approx(true, rel=0.2)
    # no range bin outside a scene as wide as the range window, non-uniform frequencies: no estimate
    assert estimate_noise_power(noise, freq, 1e4) is None
    assert estimate_noise_power(noise, np.sort(rng.uniform(9e9, 1e10, 64)), 1.0) is None


def test_discrepancy_path_against_tikhonov_denoising_closed_form():
    # A = I, penalty λ‖f‖²: f_λ = b/(1+λ), ‖f_λ − b‖² = ‖b‖² λ²/(1+λ)²; λ* = s/(1−s), s = √(τE/‖b‖²)
    rng = np.random.default_rng(1)
    b = rng.standard_normal(500) + 1j * rng.standard_normal(500)
    bb = float(np.vdot(b, b).real)
    energy = 0.04 * bb
    calls = []

    def solve(lam, x0):
        calls.append(x0 is None)
        return b / (1 + lam)

    choice = discrepancy_lambda(solve, lambda f: float(np.vdot(f - b, f - b).real), energy,
                                lams=np.geomspace(1.0, 1e-3, 61))
    s = np.sqrt(energy / bb)
    assert choice.status == "bracketed"
    assert choice.lam == pytest.approx(s / (1 - s), rel=0.01)
    assert calls[0] and not any(calls[1:])                         # warm starts after the first
    assert choice.ratios[-1] <= 1.0 < choice.ratios[-2]           # stops at the first λ below
    assert np.all(np.diff(choice.ratios) < 0)
    over = discrepancy_lambda(solve, lambda f: float(np.vdot(f - b, f - b).real), 10 * bb, lams=LAM_PATH)
    assert over.status == "below at the largest λ" and over.lam == max(LAM_PATH)
    under = discrepancy_lambda(solve, lambda f: float(np.vdot(f - b, f - b).real), 1e-9 * bb, lams=LAM_PATH)
    assert under.status == "above at the smallest λ" and under.lam == min(LAM_PATH)
    # dof-corrected target: r_min + κ(1 − r_min) on the whole path
    rel = discrepancy_lambda(solve, lambda f: float(np.vdot(f - b, f - b).real), energy,
                             lams=np.geomspace(1.0, 1e-3, 61), kappa=0.25)
    r_min = min(rel.ratios)
    assert len(rel.ratios) == 61 and rel.target == pytest.approx(max(r_min + 0.25 * (1 - r_min), 1.1 * r_min))
    s = np.sqrt(rel.target * energy / bb)
    assert rel.lam == pytest.approx(s / (1 - s), rel=0.01)


def test_auto_lambda_ptv_beats_matched_filter_by_the_target(shapes):
    ph, truth = shapes
    err_mf = mag_error(matched_filter(ph), truth)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        img = regularize(ph, prior="ptv")
    err = mag_error(img.image, truth)
    assert err <= 0.65 * err_mf, (err, err_mf)
    sel = img.parameters["lam_selection"]
    assert sel["criterion"].startswith("discrepancy") and sel["status"] == "bracketed"
    assert img.parameters["lam"] == pytest.approx(sel["lam"])
    r = np.array(sel["ratios"])
    assert sel["lams"] == list(LAM_PATH) and np.all(np.diff(r) < 0)   # the whole curve, monotone
    assert sel["target"] == pytest.approx(max(r.min() + 0.25 * (1 - r.min()), 1.1 * r.min()))
    i = int(np.argmax(r <= sel["target"]))
    assert sel["lams"][i] <= sel["lam"] <= sel["lams"][i - 1]
    assert img.parameters["beta"] == pytest.approx(32 * sel["lam"])


def test_auto_uses_the_file_noise_power_and_falls_back_with_a_warning(shapes):
    ph, _ = shapes
    from sarcli.core.types import PhaseHistory

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        with pytest.warns(SarcliWarning, match="residual .* x the noise level"):
            img = regularize(PhaseHistory(ph.data, ph.acquisition, attrs={"noise_power": 1e-30}), prior="tv",
                             iters=30)
    sel = img.parameters["lam_selection"]
    assert sel["noise_source"] == "file attribute noise_power" and sel["status"] == "above at the smallest λ"
    assert img.parameters["lam"] == sel["fallback"] == 0.02
    acq = ph.acquisition.with_(frequency_hz=np.sort(np.r_[ph.acquisition.frequency_hz[:-1], 10.2e9]))
    with pytest.warns(SarcliWarning, match="no noise estimate"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            img = regularize(PhaseHistory(ph.data, acq), prior="tv", iters=5)
    assert img.parameters["lam"] == 0.02


def test_cli_lam_auto_is_the_default_and_recorded(tmp_path, shapes):
    ph, _ = shapes
    src, out = tmp_path / "ph.h5", tmp_path / "img.h5"
    write_phase_history(src, ph)
    res = CliRunner().invoke(cli, ["regularize", str(src), "-o", str(out), "--iters", "40"])
    assert res.exit_code == 0, res.output
    p = read_image(out).parameters
    assert p["lam_selection"]["criterion"].startswith("discrepancy") and len(p["lam_selection"]["ratios"]) >= 2
    json.dumps(p)
    res = CliRunner().invoke(cli, ["regularize", str(src), "-o", str(out), "--lam", "0.05", "--iters", "5"])
    assert res.exit_code == 0 and read_image(out).parameters["lam"] == 0.05
    for bad in ("soon", "-1", "inf"):
        res = CliRunner().invoke(cli, ["regularize", str(src), "-o", str(tmp_path / "x.h5"), "--lam", bad])
        assert res.exit_code == 2 and "--lam" in res.output and "Traceback" not in res.output
        assert not (tmp_path / "x.h5").exists()
