"""``regularize()`` and ``sar regularize`` on SAR data: ptv vs matched filter and TV, scaling,
normalisation, extreme λ, operators, defocus warning, the CLI and (when present) GOTCHA."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.cli.main import cli
from sarcli.errors import AliasingWarning, ConvergenceWarning, DefocusWarning, SarcliInputError, SarcliWarning
from sarcli.core.grid import Grid
from sarcli.core.types import PhaseHistory
from sarcli.io.hdf5 import read_image, write_phase_history
from sarcli.linops import NufftOperator
from sarcli.regularize import PRIORS, matched_filter, regularize

from .conftest import GOTCHA_FILES  # noqa: E402


def _narrowband_acquisition(n=48, h=0.25, bandwidth=150e6, **kw):
    """10 GHz, 150 MHz (B/fc = 1.5%), 4° aperture: range resolution ≈ 4.6 pixels."""
    grid = Grid.square(n * h / 2, n)
    fc, M, P = 10e9, 32, 96
    freq = np.linspace(fc - bandwidth / 2, fc + bandwidth / 2, M)
    az = np.deg2rad(np.linspace(-2, 2, P))
    return Acquisition(freq, az, np.full(P, np.deg2rad(30.0)), grid, **kw)


def _random_phase_scene(seed=3, snr_db=20.0):
    """Piecewise-constant magnitude, random phase per pixel, data from a 2× finer grid (no inverse crime)."""
    acq = _narrowband_acquisition()
    grid = acq.grid
    rng = np.random.default_rng(seed)
    u = 2
    fine = Grid(grid.nx * u, grid.ny * u, grid.dx / u, grid.dy / u,
                grid.cx - grid.dx / 2 + grid.dx / (2 * u), grid.cy - grid.dy / 2 + grid.dy / (2 * u))
    X, Y = np.meshgrid(fine.x, fine.y)
    mag = np.zeros(X.shape)
    mag[(np.abs(X + 2) < 2) & (np.abs(Y - 1.5) < 1.5)] = 1.0
    mag[(X - 2.5) ** 2 + (Y + 2) ** 2 < 2.5**2] = 0.6
    mag[(np.abs(X - 1) < 1) & (np.abs(Y - 3.5) < 1)] = 0.3
    phase = np.repeat(np.repeat(rng.uniform(-np.pi, np.pi, grid.shape), u, 0), u, 1)
    values = mag * np.exp(1j * phase) / u**2
    truth_mag = np.abs(values).reshape(grid.ny, u, grid.nx, u).sum(axis=(1, 3))
    kx, ky = acq.kspace()
    d = NufftOperator(kx, ky, fine, eps=1e-12).forward(values)
    noise = rng.standard_normal(d.shape) + 1j * rng.standard_normal(d.shape)
    d = d + noise * np.linalg.norm(d) / np.linalg.norm(noise) / 10 ** (snr_db / 20)
    return PhaseHistory(d, acq), truth_mag


def _mag_error(f, truth):
    return np.linalg.norm(np.abs(f) - truth) / np.linalg.norm(truth)


@pytest.fixture(scope="module")
def scene():
    return _random_phase_scene()


def test_ptv_beats_matched_filter_and_tv_on_random_phase_scene(scene):
    ph, truth = scene
    err_mf = _mag_error(matched_filter(ph), truth)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        ptv = regularize(ph, prior="ptv", iters=300)
        tv = regularize(ph, prior="tv", iters=300)
    err_ptv, err_tv = _mag_error(ptv.image, truth), _mag_error(tv.image, truth)
    assert err_ptv < 0.95 * err_mf
    assert err_ptv < 0.98 * err_tv
    assert ptv.parameters["operator"] == "toeplitz" and ptv.parameters["prior"] == "ptv"
    for key in ("objective", "data_residual", "reg_norm", "relative_change", "step_size", "elapsed_s"):
        assert ptv.history[key].shape == (ptv.parameters["iterations"],)


def test_nufft_and_toeplitz_operators_agree(scene):
    ph, _ = scene
    kw = dict(prior="tv", iters=40, tol=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        a = regularize(ph, operator="nufft", **kw).image
        b = regularize(ph, operator="toeplitz", **kw).image
    assert np.linalg.norm(a - b) / np.linalg.norm(a) < 1e-8   # measured 2.1e-9


def test_unit_point_reconstructs_to_one():
    """Normalisation: a unit point at a pixel centre gives ≈ 1 there, like the matched filter."""
    acq = _narrowband_acquisition(n=32, bandwidth=600e6)
    row, col = 13, 20
    x, y = acq.grid.x[col], acq.grid.y[row]
    psi = geometry.signal_phase(acq.frequency_hz, acq.azimuth_rad, acq.elevation_rad, [[x, y, 0.0]])
    ph = PhaseHistory(np.exp(-1j * psi[:, :, 0]), acq)
    mf = matched_filter(ph)
    assert abs(abs(mf[row, col]) - 1.0) < 1e-12   # measured 2.0e-13
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        img = regularize(ph, prior="l1", lam=0.01, iters=500, tol=1e-7)
    f = img.image
    assert np.unravel_index(np.argmax(np.abs(f)), f.shape) == (row, col)
    assert abs(abs(f[row, col]) - 1.0) < 0.03


def test_scaling_makes_lambda_unit_free(scene):
    """Multiplying the data by 1e6 multiplies the image by 1e6 and changes nothing else."""
    ph, _ = scene
    ph2 = PhaseHistory(ph.data * 1e6, ph.acquisition)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        a = regularize(ph, prior="tv", iters=30)
        b = regularize(ph2, prior="tv", iters=30)
    assert np.linalg.norm(b.image / 1e6 - a.image) / np.linalg.norm(a.image) < 1e-12   # measured 1.2e-13 at most (FINUFFT's threads)
    # measured 4.7e-13 at most over 33 runs (FINUFFT's threaded spreading is not bitwise repeatable)
    assert np.allclose(a.history["objective"], b.history["objective"], rtol=3e-12, atol=0)


@pytest.mark.parametrize("prior", PRIORS)
@pytest.mark.parametrize("lam", [1e-12, 1e12])
def test_noise_only_extreme_lambda_stays_finite(prior, lam):
    acq = _narrowband_acquisition(n=24, h=0.5)
    rng = np.random.default_rng(7)
    d = 1e-3 * (rng.standard_normal((acq.n_pulses, acq.n_frequencies))
                + 1j * rng.standard_normal((acq.n_pulses, acq.n_frequencies)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        img = regularize(PhaseHistory(d, acq), prior=prior, lam=lam, iters=25)
    assert np.all(np.isfinite(img.image))
    assert all(np.all(np.isfinite(v)) for v in img.history.values())
    if lam == 1e12 and prior == "l1":
        assert np.max(np.abs(img.image)) < 5e-34   # measured 7.4e-35 to 8.9e-35 over 6 runs


def test_zero_data_gives_zero_image():
    acq = _narrowband_acquisition(n=16, h=0.5)
    img = regularize(PhaseHistory(np.zeros((acq.n_pulses, acq.n_frequencies), complex), acq), prior="tv")
    assert np.all(img.image == 0)


def test_bad_options_raise_input_errors(scene):
    ph, _ = scene
    for kw in ({"prior": "wavelet"}, {"operator": "magic"}, {"lam": -1.0}, {"order": 4},
               {"init": np.zeros((3, 3))}):
        with pytest.raises(SarcliInputError):
            regularize(ph, **kw)


def _spherical_ph(r0=150.0, n=24, h=0.25):
    grid = Grid.square(n * h / 2, n)
    fc, M, P = 10e9, 48, 64
    freq = np.linspace(fc - 300e6, fc + 300e6, M)
    az = np.deg2rad(np.linspace(-3, 3, P))
    el = np.full(P, np.deg2rad(30.0))
    a = geometry.antenna_positions_circle(az, el, r0)
    acq = Acquisition(freq, az, el, grid, antenna_position_m=a, model="spherical")
    pts = np.array([[1.0, -0.5, 0.0], [-1.25, 1.0, 0.0]])
    psi = geometry.signal_phase(freq, az, el, pts, model="spherical", antenna_position_m=a,
                                range_to_center_m=acq.range_to_center_m)
    return PhaseHistory(np.exp(-1j * psi).sum(axis=2), acq), pts


def test_farfield_operator_on_spherical_data_warns_with_phase_error():
    ph, _ = _spherical_ph()
    predicted = ph.acquisition.farfield_phase_error(ph.acquisition.grid.half_diagonal)
    assert predicted > 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        with pytest.warns(DefocusWarning, match=f"{predicted:.3g} rad") as caught:
            regularize(ph, prior="l1", operator="toeplitz", iters=3, lam=0.05)
    # the warning names the line that called regularize, not one inside sarcli
    assert [w.filename for w in caught if w.category is DefocusWarning] == [__file__]


def test_auto_picks_the_warped_operator_and_focuses():
    """Spherical data whose far field is off at the corner: auto takes the warped operator (its AᴴA
    measured within the tolerance) and the points focus as on the exact pair."""
    ph, pts = _spherical_ph()
    with warnings.catch_warnings():
        warnings.simplefilter("error", DefocusWarning)
        warnings.simplefilter("ignore", ConvergenceWarning)
        img = regularize(ph, prior="l1", lam=0.02, iters=150)
    assert img.parameters["operator"] == "warped" and img.parameters["operator_predicted_error"] <= 1e-3
    grid = ph.acquisition.grid
    for p in pts:
        row, col = grid.index_of(p[0], p[1])
        assert abs(img.image[row, col]) > 0.95  # focused: near the pixel-model value 1 (measured 0.990)


def test_cli_regularize_writes_image_history_and_png(tmp_path, scene):
    ph, _ = scene
    src = tmp_path / "ph.h5"
    write_phase_history(src, ph)
    out, png = tmp_path / "img.h5", tmp_path / "hist.png"
    res = CliRunner().invoke(cli, ["-q", "regularize", str(src), "-o", str(out), "--prior", "hotv",
                                   "--order", "2", "--lam", "0.03", "--iters", "20", "--operator", "nufft",
                                   "--history-png", str(png)])
    assert res.exit_code == 0, res.output
    img = read_image(out)
    assert img.method == "regularize-hotv" and img.parameters["order"] == 2
    assert img.parameters["lam"] == 0.03 and img.parameters["beta"] == pytest.approx(0.96)
    assert img.history["objective"].size == 20 and png.stat().st_size > 1000
    # --init and a grid override
    out2 = tmp_path / "img2.h5"
    res = CliRunner().invoke(cli, ["-q", "regularize", str(src), "-o", str(out2), "--prior", "tikhonov",
                                   "--iters", "10", "--init", str(out)])
    assert res.exit_code == 0, res.output
    assert read_image(out2).parameters["init"] is True
    res = CliRunner().invoke(cli, ["regularize", str(src), "-o", str(out2), "--lam", "-1"])
    assert res.exit_code == 2 and "lam" in res.output


@pytest.mark.gotcha
def test_gotcha_ptv_patch_runs():
    from sarcli.io.gotcha import read_gotcha

    ph = read_gotcha(GOTCHA_FILES[:1], grid=Grid.square(10.0, 64))
    ph = PhaseHistory(ph.data[::4], ph.acquisition.subset(pulses=slice(None, None, 4)))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # lam='auto' on a 20 m patch of real data: the range bins outside the patch give σ² (their
        # clutter included), SURE chooses λ on the path; no fallback, no warning about λ
        img = regularize(ph, prior="ptv", iters=15)
    assert not [w for w in caught if issubclass(w.category, SarcliWarning)
                and not issubclass(w.category, (ConvergenceWarning, AliasingWarning))]
    sel = img.parameters["lam_selection"]
    assert sel["criterion"] in ("sure", "gcv") and "fallback" not in sel
    assert min(sel["lams"]) <= img.parameters["lam"] <= max(sel["lams"])
    assert img.parameters["operator"] == "spherical"
    assert np.all(np.isfinite(img.image)) and np.max(np.abs(img.image)) > 0
    obj = img.history["objective"]
    assert obj[-1] < obj[0]


def test_ptv_phase_reestimation_runs_and_records(scene):
    ph, truth = scene
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        img = regularize(ph, prior="ptv", iters=60, reestimate_every=20)
    assert img.parameters["reestimate_every"] == 20
    assert np.all(np.isfinite(img.image))
    assert _mag_error(img.image, truth) < _mag_error(matched_filter(ph), truth)


def test_cli_help_lists_options():
    res = CliRunner().invoke(cli, ["regularize", "--help"])
    assert res.exit_code == 0
    for opt in ("--prior", "--order", "--lam", "--beta", "--iters", "--tol", "--operator", "--init",
                "--history-png", "--extent", "--pixel-size", "--center"):
        assert opt in res.output


def test_application_stages_give_what_regularize_gives(scene):
    """``Regularization``'s stages one by one, ``regularize`` with an options object and with
    keywords: the same image; an unknown setting is one line naming it."""
    from sarcli.regularize import Regularization, RegularizeOptions

    ph, _ = scene
    opts = RegularizeOptions(prior="tv", iters=40)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = regularize(ph, prior="tv", iters=40)
        same = regularize(ph, opts)
        app = Regularization(ph, opts, ph.acquisition.grid)
        assert app.prepare()
        app.choose_lambda()
        u, hist = app.solve()
    # the same arithmetic; only the rounding of reductions over differently aligned arrays differs
    def rel(a, b):
        return np.linalg.norm(a - b) / np.linalg.norm(b)
    assert rel(same.image, whole.image) < 1e-6
    assert abs(app.lam / whole.parameters["lam"] - 1) < 1e-6
    assert rel(u * (app.problem.s_b / app.problem.s_a), whole.image) < 1e-6
    assert whole.parameters["gram_products"]["path"] == app.products["path"] > 0
    with pytest.raises(SarcliInputError, match="lamda"):
        regularize(ph, lamda=0.1)
