"""Automatic λ (:mod:`sarcli.regularize.regparam`): noise estimate, Monte-Carlo degrees of freedom, GCV, SURE and
the discrepancy path against closed forms, ``regularize(lam='auto')`` on scenes with and without
range bins outside the scene (every prior, both operators, noiseless data), and ``sar regularize``."""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sarcli.cli.main import cli
from sarcli.errors import AliasingWarning, ConvergenceWarning, SarcliWarning
from sarcli.io.hdf5 import read_image, write_phase_history
from sarcli.regularize import PRIORS, matched_filter, regularize
from sarcli.regularize.driver import PATH_FIRST_ITERS, PATH_ITERS
from sarcli.regularize.regparam import (FLAT_REL, GCV_GAMMA, LAM_MIN, LAM_PATH, SPECKLE_FRACTION, STOP_AFTER, Noise,
                                        discrepancy_lambda, estimate_noise_power, gcv_score, mc_dof, noise_power,
                                        select_lambda, speckle_fraction, sure_score)

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
from bench_lam import disk_scene, gain_error, mag_error, scene  # noqa: E402


@pytest.fixture(scope="module")
def shapes():
    return scene("shapes", 10.0, n=32, seed=1)


@pytest.fixture(scope="module")
def disk():
    """A random-phase scene filling the alias-free disk (32 x 32 samples, 64² grid): no range bin
    outside the scene, so no noise estimate from the data."""
    return disk_scene("shapes", 10.0, seed=7, P=32, M=32)


def _quiet(fn, *args, **kw):
    """Run fn; return (result, its warnings but convergence and the grid's aliasing warnings)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = fn(*args, **kw)
    return out, [w for w in caught if not issubclass(w.category, (ConvergenceWarning, AliasingWarning))]


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


def _diagonal_problem(n=4000, seed=2):
    """A = diag(a), Tikhonov with D = I: f_λ = a b / (a² + λ), exact residual and dof."""
    rng = np.random.default_rng(seed)
    a = np.geomspace(1.0, 1e-2, n)
    x = rng.standard_normal(n) * np.exp(-np.arange(n) / 800.0)
    sigma2 = 1e-3
    b = a * x + np.sqrt(sigma2 / 2) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))

    def exact(lam):
        h = a**2 / (a**2 + lam)
        return float(np.sum(np.abs((1 - h) * b) ** 2)), float(np.sum(h))

    return a, b, sigma2, exact


def test_mc_dof_against_the_exact_trace():
    a, b, _, exact = _diagonal_problem(n=20000)
    rng = np.random.default_rng(5)
    eps = (rng.standard_normal(a.size) + 1j * rng.standard_normal(a.size)) / np.sqrt(2)
    for lam in (1e-3, 1e-2, 0.3):
        solve = lambda d: a * d / (a**2 + lam)  # noqa: E731  f(d) for data d
        delta = 1e-3
        est = mc_dof(a * eps, delta, solve(b), solve(b + delta * eps))   # Aᴴε = a ε
        dof = exact(lam)[1]
        # one probe: standard deviation sqrt(Σ h²) ≤ sqrt(n)
        assert abs(est - dof) < 5 * np.sqrt(np.sum((a**2 / (a**2 + lam)) ** 2)), (lam, est, dof)


@pytest.mark.parametrize("criterion", ["gcv", "sure"])
def test_select_lambda_against_the_exact_minimiser(criterion):
    a, b, sigma2, exact = _diagonal_problem()
    n = a.size
    sig = None if criterion == "gcv" else sigma2

    def score(loglam):
        r2, dof = exact(np.exp(loglam))
        return gcv_score(r2, dof, n) if sig is None else sure_score(r2, dof, n, sig)

    grid = np.linspace(np.log(1e-6), 0.0, 20001)
    best = float(np.exp(grid[int(np.argmin([score(v) for v in grid]))]))
    starts = []

    def solve(lam, start):
        starts.append(start)
        r2, dof = exact(lam)
        return None, r2, dof

    lams = np.geomspace(1.0, 1e-6, 121)
    choice = select_lambda(solve, n, lams=lams, noise=Noise(sig))
    assert choice.status == "interior"
    assert choice.lam == pytest.approx(best, rel=0.02)
    assert 1e-6 < best < 1.0
    # the path stopped STOP_AFTER points after the minimum, long before its end
    assert len(choice.lams) == choice.index + 1 + STOP_AFTER < len(lams)
    assert all(s is None for s in starts)                     # always warm from the previous point
    assert np.all(np.diff(choice.lams) < 0) and choice.scores[choice.index] == min(choice.scores)


def test_gcv_and_sure_scores():
    assert gcv_score(2.0, 10.0, 100) == pytest.approx(100 * 2.0 / (100 - GCV_GAMMA * 10) ** 2)
    assert gcv_score(2.0, 80.0, 100) == float("inf")          # γ dof ≥ n: the fit used up the data
    assert sure_score(5.0, 10.0, 100, 0.1) == pytest.approx(5.0 - 10.0 + 2.0)


def test_select_lambda_extends_upwards_when_the_largest_lambda_wins():
    # GCV = r2 / n with dof 0 and r2 = 1 + 1/λ: smallest at the largest λ; the path goes up from its
    # top by its ratio (3) while λ ≤ lam_max, each point warm-started from the previous top
    starts = []

    def solve(lam, start):
        starts.append(start)
        return lam, 1.0 + 1.0 / lam, 0.0

    choice = select_lambda(solve, 100, lams=[0.3, 0.1, 0.03], lam_max=10.0)
    assert choice.status == "at the largest λ" and choice.lam == pytest.approx(0.3 * 3.0**3)  # 8.1 ≤ 10 < 24.3
    assert choice.lams == sorted(choice.lams, reverse=True) and len(choice.lams) == 6
    assert starts == [None, None, None, 0, 3, 4]          # calls 3.. start from the top of their time
    assert choice.start == choice.lam
    top = select_lambda(lambda lam, start: (lam, 1.0 + 1.0 / lam, 0.0), 100, lams=[0.3, 0.1, 0.03])
    assert top.lam == 0.3 and len(top.lams) == 3                 # no lam_max: no extension


def test_select_lambda_extends_downwards_while_the_criterion_falls():
    # SURE = r2 − nσ² + 2σ² dof with r2 = λ, dof = 0: falls all the way down; the path goes on by its
    # ratio (10) below its end (1e-2) to the floor, each point warm from the previous one
    starts = []

    def solve(lam, start):
        starts.append(start)
        return lam, lam, 0.0

    choice = select_lambda(solve, 100, lams=[1.0, 0.1, 0.01], noise=Noise(0.0), lam_min=1e-5)
    assert choice.lams == pytest.approx([1.0, 0.1, 0.01, 1e-3, 1e-4, 1e-5])
    assert choice.status == "at the smallest λ" and choice.at_limit and choice.lam == pytest.approx(1e-5)
    assert all(s is None for s in starts)
    # a minimum below the path's end: found by the extension, interior, not at a limit
    inner = select_lambda(lambda lam, start: (lam, (np.log10(lam) + 3.3) ** 2, 0.0), 100,
                          lams=[1.0, 0.1, 0.01], noise=Noise(0.0), lam_min=1e-5)
    assert inner.status == "interior" and not inner.at_limit
    assert inner.lams == pytest.approx([1.0, 0.1, 0.01, 1e-3, 1e-4])
    assert inner.lam == pytest.approx(10 ** -3.3, rel=1e-6)       # the parabola is exact here
    # a criterion gone flat stops the extension above the floor (at a limit all the same)
    flat = select_lambda(lambda lam, start: (lam, 1.0 + FLAT_REL * 1e-3 * lam, 0.0), 100,
                         lams=[1.0, 0.1, 0.01], noise=Noise(0.0), lam_min=1e-5)
    assert flat.at_limit and flat.status == "at the smallest λ" and len(flat.lams) == 4
    # no floor: the path's own end is the limit, as before
    plain = select_lambda(solve, 100, lams=[1.0, 0.1, 0.01], noise=Noise(0.0))
    assert plain.lams == [1.0, 0.1, 0.01] and plain.at_limit


def test_speckle_is_counted_as_noise_in_sure_and_after_gcv():
    a, b, sigma2, exact = _diagonal_problem()
    n = a.size
    power = float(np.vdot(b, b).real) / n
    kappa = 0.2
    eff = sigma2 + kappa * (power - sigma2)
    grid = np.linspace(np.log(1e-6), 0.0, 20001)
    best = float(np.exp(grid[int(np.argmin([sure_score(*exact(np.exp(v)), n, eff) for v in grid]))]))
    solve = lambda lam, start: (None, *exact(lam))  # noqa: E731
    lams = np.geomspace(1.0, 1e-6, 121)
    sure = select_lambda(solve, n, lams=lams, noise=Noise(sigma2, kappa, power))
    assert sure.lam == pytest.approx(best, rel=0.02) and sure.speckle == pytest.approx(kappa * (power - sigma2))
    plain = select_lambda(solve, n, lams=lams, noise=Noise(sigma2))
    assert plain.lam < 0.5 * sure.lam                               # speckle asks for more smoothing
    # no σ²: GCV walks the path, its minimum gives Wahba's σ̂², then SURE with σ̂² + speckle chooses
    gcv = select_lambda(solve, n, lams=lams, noise=Noise(None, kappa, power))
    gcv_only = select_lambda(solve, n, lams=lams)
    i = gcv_only.index
    s2 = gcv_only.residuals[i] / (n - gcv_only.dofs[i])
    assert gcv.noise_power == pytest.approx(s2) and gcv.walk_scores == pytest.approx(gcv_only.scores)
    assert gcv.scores == pytest.approx([sure_score(r, d, n, s2 + kappa * (power - s2))
                                        for r, d in zip(gcv.residuals, gcv.dofs)])
    assert gcv.lam > gcv_only.lam and gcv.scores[gcv.index] == min(gcv.scores)


def test_speckle_fraction_follows_the_pixels_the_data_do_not_fix():
    assert SPECKLE_FRACTION == pytest.approx(1 - np.pi / 4)
    assert speckle_fraction(1000, 3000) == 0.0 == speckle_fraction(3000, 3000)   # every pixel fixed by the data
    assert speckle_fraction(4000, 1000) == pytest.approx(0.75 * (1 - np.pi / 4))
    assert speckle_fraction(0, 10) == 0.0


def test_auto_on_a_scene_filling_the_disk_uses_gcv_and_beats_the_matched_filter(disk):
    ph, truth, sigma2 = disk
    assert noise_power(ph, ph.acquisition.grid)[0] is None          # no range bin outside the scene
    img, warns = _quiet(regularize, ph, prior="ptv")
    assert not warns, [str(w.message) for w in warns]
    sel = img.parameters["lam_selection"]
    assert sel["criterion"] == "gcv" and sel["noise_code"] == "gcv" and sel["status"] == "interior"
    assert img.parameters["lam"] == pytest.approx(sel["lam"]) and min(sel["lams"]) < sel["lam"] < max(sel["lams"])
    err, err_mf = gain_error(img.image, truth), gain_error(matched_filter(ph), truth)
    assert err <= 0.75 * err_mf, (err, err_mf)
    # the fixed default of the earlier rule does worse on this scene
    fixed, _ = _quiet(regularize, ph, prior="ptv", lam=0.02)
    assert err < gain_error(fixed.image, truth)
    # the residual noise estimate is of the right order (it is biased where dof ~ n)
    assert 0.2 < sel["noise_power"] / sigma2 < 5
    json.dumps(sel)
    assert len(sel["lams"]) == len(sel["scores"]) == len(sel["dofs"]) == len(sel["path_iterations"])
    assert max(sel["path_iterations"][1:]) <= PATH_ITERS and sel["path_iterations"][0] <= PATH_FIRST_ITERS
    # cost, counted in AᴴA applications: two solvers per path iteration, then the warm final solve,
    # against one solve from zero at the chosen λ
    fx, _ = _quiet(regularize, ph, prior="ptv", lam=img.parameters["lam"])
    auto_its = 2 * sum(sel["path_iterations"]) + img.parameters["iterations"]
    assert auto_its <= 3 * fx.parameters["iterations"], (auto_its, fx.parameters["iterations"])


def test_auto_with_the_file_noise_power_uses_sure(shapes):
    ph, truth = shapes
    from sarcli.core.types import PhaseHistory

    true = np.mean(np.abs(ph.data) ** 2) / 11
    img, warns = _quiet(regularize, PhaseHistory(ph.data, ph.acquisition, attrs={"noise_power": true}), prior="ptv")
    sel = img.parameters["lam_selection"]
    assert not warns and sel["criterion"] == "sure" and sel["noise_code"] == "file"
    assert sel["noise_power"] == true and sel["status"] == "interior"
    assert mag_error(img.image, truth) <= 0.65 * mag_error(matched_filter(ph), truth)
    # the estimate from the range bins outside the scene gives nearly the same λ
    est, _ = _quiet(regularize, ph, prior="ptv")
    assert est.parameters["lam_selection"]["noise_code"] == "range_bins"
    assert est.parameters["lam"] == pytest.approx(img.parameters["lam"], rel=0.5)


@pytest.mark.parametrize("prior", PRIORS)
def test_every_prior_chooses_lambda_without_warning(prior, disk):
    ph, _, _ = disk
    img, warns = _quiet(regularize, ph, prior=prior, iters=60)
    sel = img.parameters["lam_selection"]
    assert not warns, [str(w.message) for w in warns]
    assert sel["criterion"] == "gcv" and np.isfinite(img.parameters["lam"]) and img.parameters["lam"] > 0
    assert np.all(np.isfinite(img.image)) and np.max(np.abs(img.image)) > 0
    assert np.all(np.diff(sel["lams"]) < 0)


def test_spherical_operator_auto_lambda():
    ph, truth, _ = disk_scene("shapes", 10.0, spherical=True, seed=8, P=16, M=16)
    img, warns = _quiet(regularize, ph, prior="ptv", iters=60)
    assert img.parameters["operator"] == "spherical" and not warns
    sel = img.parameters["lam_selection"]
    assert sel["criterion"] == "gcv" and sel["status"] in ("interior", "at the largest λ")
    mf, _ = _quiet(matched_filter, ph, operator="spherical")
    assert gain_error(img.image, truth) < gain_error(mf, truth)


def test_noiseless_data_get_a_small_lambda_and_no_warning():
    ph, _ = scene("shapes", 300.0, n=32, seed=4)
    noisy, _ = scene("shapes", 10.0, n=32, seed=4)
    img, warns = _quiet(regularize, ph, prior="ptv", iters=60)
    ref, _ = _quiet(regularize, noisy, prior="ptv", iters=60)
    assert not warns
    sel = img.parameters["lam_selection"]
    assert img.parameters["lam"] == min(sel["lams"])
    assert img.parameters["lam"] < 0.1 * ref.parameters["lam"]
    # the path went below its nominal end (1e-3) while SURE still fell, and says where it stopped
    assert min(sel["lams"]) < 1e-3 and min(sel["lams"]) >= LAM_MIN * (1 - 1e-9)
    assert sel["at_path_end"] == "smallest" and sel["at_limit"] and sel["speckle_fraction"] == 0.0
    assert [a["code"] for a in img.parameters["advice"]][:1] == ["lam_at_smallest"]
    assert ref.parameters["lam_selection"]["at_path_end"] is None
    assert "lam_at_smallest" not in [a["code"] for a in ref.parameters["advice"]]


def test_progress_and_notice_cover_the_path_and_the_final_solve(disk, monkeypatch):
    import sarcli.regularize.forecast as F

    class Bar:
        n, total, desc = 0, None, ""

        def reset(self, total=None):
            self.n, self.total = 0, total

        def update(self, k=1):
            self.n += k

        def set_description(self, d):
            self.desc = d

    ph, _, _ = disk
    bar, notes = Bar(), []
    monkeypatch.setattr(F, "LONG_RUN_S", 0.0)
    ticks_at_notice = []

    def note(line):
        notes.append(line)
        ticks_at_notice.append(bar.n)

    img, _ = _quiet(regularize, ph, prior="tv", iters=40, progress=bar, notice=note)
    sel = img.parameters["lam_selection"]
    power = img.parameters["scale_power_iterations"]
    assert bar.n == power + 2 * sum(sel["path_iterations"]) + img.parameters["iterations"] <= bar.total
    assert "lam=" in bar.desc
    assert len(notes) == 1 and "predicted" in notes[0] and "--lam" in notes[0] and "GiB of memory" in notes[0]
    # the memory it will take, said before the run: auto (two solvers and the path's solutions) more
    from sarcli.formers.planning.cost import regularize_bytes
    p, m = ph.data.shape
    assert img.parameters["predicted_bytes"] > 0
    assert regularize_bytes(p, m, ph.acquisition.grid, "toeplitz", auto=True) > \
        regularize_bytes(p, m, ph.acquisition.grid, "toeplitz", auto=False)
    # announced after the scaling (its second AᴴA product timed: the first carries one-time
    # set-up), before the λ path
    assert ticks_at_notice == [power]
    assert 0 < img.parameters["predicted_s"] < img.parameters["predicted_max_s"]
    # every AᴴA product is counted: the scaling's, two solvers per path point (one at the start and
    # one per iteration each) and the one that times the path for the forecast, the final solve's
    # (one at the start and one per iteration)
    counts = img.parameters["gram_products"]
    assert counts["scaling"] == power
    assert counts["path"] == 2 * (sum(sel["path_iterations"]) + len(sel["path_iterations"])) + 1
    assert counts["final"] == img.parameters["iterations"] + 1
    assert counts["total"] == counts["scaling"] + counts["path"] + counts["final"]
    notes.clear()
    _quiet(regularize, ph, prior="tv", iters=5, lam=0.1, notice=notes.append)
    assert len(notes) == 1 and "--lam" not in notes[0]


def test_cli_lam_auto_is_the_default_and_recorded(tmp_path, disk):
    ph, _, _ = disk
    src, out = tmp_path / "ph.h5", tmp_path / "img.h5"
    write_phase_history(src, ph)
    res = CliRunner().invoke(cli, ["-v", "regularize", str(src), "-o", str(out), "--iters", "40"])
    assert res.exit_code == 0, res.output
    p = read_image(out).parameters
    assert p["lam_selection"]["criterion"] == "gcv" and len(p["lam_selection"]["scores"]) >= 3
    json.dumps(p)
    line = [ln for ln in res.output.splitlines() if ln.startswith("lam selection:")]
    assert len(line) == 1 and "gcv" in line[0] and "path lam" in line[0]
    res = CliRunner().invoke(cli, ["regularize", str(src), "-o", str(out), "--iters", "40"])
    assert "lam selection:" not in res.output
    # the final solve stopped at its cap: the final line says so, one note says what to do, and the
    # file's parameters carry both as fields
    res = CliRunner().invoke(cli, ["regularize", str(src), "-o", str(out), "--iters", "3"])
    assert res.exit_code == 0, res.output
    p = read_image(out).parameters
    assert p["iteration_cap_reached"] is True and p["final_relative_change"] > p["tol"]
    assert [a["code"] for a in p["advice"]] == ["iteration_cap"]
    assert "(cap reached)" in res.output
    notes = [ln for ln in res.output.splitlines() if ln.startswith("note:")]
    assert len(notes) == 1 and "--iters 6" in notes[0]
    res = CliRunner().invoke(cli, ["-q", "regularize", str(src), "-o", str(out), "--iters", "3"])
    assert res.exit_code == 0 and "note:" not in res.output and "wrote" not in res.output
    res = CliRunner().invoke(cli, ["regularize", str(src), "-o", str(out), "--lam", "0.05", "--iters", "5"])
    assert res.exit_code == 0 and read_image(out).parameters["lam"] == 0.05
    assert "lam_selection" not in read_image(out).parameters
    for bad in ("soon", "-1", "inf"):
        res = CliRunner().invoke(cli, ["regularize", str(src), "-o", str(tmp_path / "x.h5"), "--lam", bad])
        assert res.exit_code == 2 and "--lam" in res.output and "Traceback" not in res.output
        assert not (tmp_path / "x.h5").exists()


def test_forecast_product_time_is_the_median_after_the_first(monkeypatch):
    """The forecast's product time is the median of the scaling's products after the first (which
    carries the set-up): one product slowed by another process does not move it."""
    import sarcli.regularize.forecast as F

    clock = iter([0.0, 5.0, 15.0, 16.0, 17.0, 18.0, 19.0])   # products: 5 (set-up), 10 (slowed), 1, 1, 1, 1
    monkeypatch.setattr(F.time, "perf_counter", lambda: next(clock))
    f = F.Forecast("tv", "toeplitz", 6, 100, False, None, lambda k: None)
    for i in range(1, 7):
        f.on_power(i)
    assert f.gram_s == 1.0
