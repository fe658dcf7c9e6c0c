"""The PSF of Theorem main-theorem against brute-force matched filters; predicted IPR; `sar psf`."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.signal import windows as sw

from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.cli.main import cli
from sarcli.errors import SarcliInputError
from sarcli.core.grid import Grid
from sarcli.io.hdf5 import read_image
from sarcli.analysis.psf import dirichlet_ratio, kernel_at, predicted_ipr, psf_image, psf_kernel

F = np.linspace(9.7e9, 10.3e9, 48)
AZ = np.radians(np.linspace(48.5, 51.5, 24))
EL = np.radians(30.0)


def brute_force_mf(freq, az, el, grid, point, weights=None):
    """Exact far-field matched filter (eq. mf, 1/W) of a unit point, by a direct triple sum."""
    pts = grid.points().reshape(-1, 3)
    psi = geometry.signal_phase(freq, az, el, pts)                       # (P, M, S)
    psi0 = geometry.signal_phase(freq, az, el, np.array([[point[0], point[1], 0.0]]))
    w = np.ones(psi.shape[:2]) if weights is None else weights
    img = np.einsum("pm,pms->s", w, np.exp(1j * (psi - psi0)))
    return img.reshape(grid.shape) / w.sum()


def test_dirichlet_ratio_is_finite_at_zeros_and_matches_the_sum():
    m = 6
    u = np.array([0.0, np.pi, 2 * np.pi, -np.pi, 1e-13, 0.3, 1234.567, 1e5 * np.pi + 1e-9])
    j = np.arange(m) - (m - 1) / 2
    ref = np.real(np.exp(2j * np.outer(u, j)).sum(axis=1))  # Σ e^{i(2j-(m-1))u} = sin(mu)/sin(u)
    got = dirichlet_ratio(u, m)
    assert np.all(np.isfinite(got))
    assert got[1] == pytest.approx(-6.0)  # sign (-1)^{n(m-1)} at u = π for even m
    np.testing.assert_allclose(got, ref, rtol=2e-13, atol=1e-12)   # measured 2.8e-14 rel, 1.6e-13 abs


@pytest.mark.parametrize("point, center", [((0.0, 0.0), (0.0, 0.0)), ((0.53, -0.21), (0.7, -0.4)),
                                           ((-1.9, 1.3), (-1.0, 1.0))])
def test_theorem_kernel_equals_bruteforce_matched_filter(point, center):
    grid = Grid.square(2.0, 40, center=center)
    k = psf_kernel((F, AZ, EL), grid, center=point, method="theorem")
    ref = brute_force_mf(F, AZ, EL, grid, point)
    assert np.max(np.abs(k - ref)) / np.max(np.abs(ref)) < 1e-13   # measured 1.6e-14
    row, col = grid.index_of(*point)
    if 0 <= row < grid.ny and 0 <= col < grid.nx and np.allclose(grid.points()[row, col, :2], point):
        assert abs(k[row, col]) == pytest.approx(1.0, abs=1e-12)


def test_theorem_with_per_pulse_elevation_and_frequencies():
    # a straight flight line: elevation and range vary per pulse; frequencies per pulse (P, M)
    el = np.radians(np.linspace(28.0, 32.0, AZ.size))
    f2 = F[None, :] + np.linspace(-5e6, 5e6, AZ.size)[:, None]
    grid = Grid.square(1.5, 24)
    k = psf_kernel((f2, AZ, el), grid, center=(0.2, 0.1))
    ref = brute_force_mf(f2, AZ, el, grid, (0.2, 0.1))
    assert np.max(np.abs(k - ref)) < 5e-14   # measured 6.8e-15


@pytest.mark.parametrize("method", ["direct", "nufft"])
def test_weighted_kernel_equals_bruteforce(method):
    w = np.outer(sw.taylor(AZ.size, nbar=4, sll=35), sw.taylor(F.size, nbar=4, sll=35))
    grid = Grid.square(2.0, 32, center=(0.3, 0.0))
    k = psf_kernel((F, AZ, EL), grid, weights=w, center=(0.25, -0.1), method=method)
    ref = brute_force_mf(F, AZ, EL, grid, (0.25, -0.1), weights=w)
    # measured 5.8e-15 (direct), 2.5e-14 (nufft)
    assert np.max(np.abs(k - ref)) < {"direct": 5e-14, "nufft": 2e-13}[method]


def test_unequal_frequencies_refuse_the_theorem_and_auto_falls_back():
    f = F + np.where(np.arange(F.size) == 7, 2e6, 0.0)
    grid = Grid.square(1.0, 16)
    with pytest.raises(SarcliInputError, match="equally spaced"):
        psf_kernel((f, AZ, EL), grid, method="theorem")
    with pytest.raises(SarcliInputError, match="uniform weights"):
        psf_kernel((F, AZ, EL), grid, weights=np.outer(np.ones(AZ.size), np.hanning(F.size)), method="theorem")
    k = psf_kernel((f, AZ, EL), grid)
    assert np.max(np.abs(k - brute_force_mf(f, AZ, EL, grid, (0, 0)))) < 1e-14   # measured 1.9e-15


def test_kernel_at_points_matches_grid():
    grid = Grid.square(1.0, 8)
    pts = grid.points()
    np.testing.assert_allclose(kernel_at((F, AZ, EL), pts, center=(0.1, 0.2)),
                               psf_kernel((F, AZ, EL), grid, center=(0.1, 0.2)), atol=1e-13)


def test_predicted_uniform_range_irw_and_pslr_match_textbook():
    f = np.linspace(9.7e9, 10.3e9, 512)
    az = np.radians(np.linspace(48.5, 51.5, 16))
    pred = predicted_ipr((f, az, EL))
    textbook = 0.886 * geometry.C / (2 * 600e6 * np.cos(EL))
    assert pred["method"] == "theorem"
    assert abs(pred["range"]["irw_m"] / textbook - 1) < 0.02
    assert abs(pred["range"]["pslr_db"] - (-13.26)) < 0.3
    assert pred["textbook"]["irw_range_m"] == pytest.approx(textbook, rel=1e-3)


def test_predicted_taylor_trades_width_for_sidelobes():
    w = np.outer(sw.taylor(AZ.size, nbar=4, sll=35), sw.taylor(F.size, nbar=4, sll=35))
    uni = predicted_ipr((F, AZ, EL))
    tay = predicted_ipr((F, AZ, EL), window=w)
    assert tay["method"] == "weighted sum"
    for d in ("range", "cross_range"):
        assert 1.15 < tay[d]["irw_m"] / uni[d]["irw_m"] < 1.45
        assert abs(tay[d]["pslr_db"] - (-35.0)) < 1.5


def _acq():
    return Acquisition(frequency_hz=F, azimuth_rad=AZ, elevation_rad=np.full(AZ.size, EL),
                       grid=Grid.square(2.0, 32), model="farfield", name="psf-test")


def test_psf_image_peaks_at_the_grid_centre():
    img = psf_image(_acq())
    assert img.method == "psf"
    assert img.parameters["evaluation"].startswith("theorem")
    assert abs(img.image[16, 16]) == pytest.approx(1.0, abs=1e-12)
    assert np.max(np.abs(img.image)) == pytest.approx(1.0, abs=1e-12)


def test_cli_psf_writes_an_image_and_png(tmp_path):
    from sarcli.core.types import PhaseHistory
    from sarcli.io.hdf5 import write_phase_history

    acq = _acq()
    ph_path = tmp_path / "ph.h5"
    write_phase_history(ph_path, PhaseHistory(data=np.zeros((AZ.size, F.size), complex), acquisition=acq))
    out, png = tmp_path / "psf.h5", tmp_path / "psf.png"
    res = CliRunner().invoke(cli, ["psf", str(ph_path), "-o", str(out), "--png", str(png),
                                   "--extent", "2", "--pixel-size", "0.05"])
    assert res.exit_code == 0, res.output
    img = read_image(out)
    assert img.method == "psf" and img.image.shape == (40, 40)
    assert abs(img.image[20, 20]) == pytest.approx(1.0, abs=1e-12)   # measured exactly 1.0
    assert '"irw_m"' in img.attrs["predicted_ipr"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = CliRunner().invoke(cli, ["psf", str(tmp_path / "missing.h5"), "-o", str(out)])
    assert bad.exit_code == 2 and "no such file" in bad.output


def test_cli_psf_taylor_window(tmp_path, write_config):
    from .conftest import small_config

    cfg = write_config(small_config(image={"half_width_m": 1.0, "pixels": 16}))
    out = tmp_path / "psf.h5"
    res = CliRunner().invoke(cli, ["psf", str(cfg), "-o", str(out), "--window", "taylor"])
    assert res.exit_code == 0, res.output
    img = read_image(out)
    assert img.parameters["window"] == "taylor" and "weighted sum" in img.parameters["evaluation"]
    assert abs(img.image[8, 8]) == pytest.approx(1.0, abs=2e-15)   # measured 4.4e-16


def test_predicted_weighted_cut_matches_direct_sum():
    from sarcli.analysis.psf import _weighted_cut

    w = np.outer(sw.taylor(AZ.size, nbar=4, sll=35), sw.taylor(F.size, nbar=4, sll=35))
    theta, step = 0.9, 0.013
    cut = _weighted_cut(F, AZ, EL, w, theta, step, 50)
    s = np.arange(-50, 51) * step
    ref = kernel_at((F, AZ, EL), s[:, None] * np.array([np.cos(theta), np.sin(theta)]), weights=w,
                    method="direct")
    assert np.max(np.abs(cut - ref)) < 1e-13   # measured 2.3e-14


def test_predicted_ipr_with_unequal_frequencies_uses_the_exact_sum():
    f = F.copy()
    f[5] += 1e6
    pred = predicted_ipr((f, AZ, EL))
    ref = predicted_ipr((F, AZ, EL))
    assert pred["method"] == "weighted sum" and ref["method"] == "theorem"
    assert pred["range"]["irw_m"] == pytest.approx(ref["range"]["irw_m"], rel=1e-3)   # measured 1.6e-4



from .conftest import GOTCHA_FILES  # noqa: E402


@pytest.mark.gotcha
def test_predicted_ipr_on_gotcha_geometry_matches_the_textbook():
    files = GOTCHA_FILES
    from sarcli.io import gotcha
    acq = gotcha.read_gotcha(files[:1]).acquisition
    pred = predicted_ipr(acq)
    # float32-stored frequencies are not exactly equally spaced: the exact sum is used
    assert pred["method"] == "weighted sum"
    rho_r, rho_cr = acq.resolutions()
    assert abs(pred["range"]["irw_m"] / (0.886 * rho_r) - 1) < 0.02
    assert abs(pred["cross_range"]["irw_m"] / (0.886 * rho_cr) - 1) < 0.02
    assert abs(pred["range"]["pslr_db"] - (-13.26)) < 0.3


@pytest.mark.parametrize("kind, irw, pslr", [("none", 0.886, -13.26), ("hamming", 1.30, -42.7),
                                             ("hann", 1.44, -31.5)])
def test_window_textbook_matches_harris_1978(kind, irw, pslr):
    # F. J. Harris, "On the use of windows for harmonic analysis with the DFT", Proc. IEEE 66 (1978),
    # Table 1: 3-dB bandwidth (bins) and highest sidelobe level (dB)
    from sarcli.analysis.psf import window_textbook

    factor, got_pslr, _ = window_textbook(kind)
    assert factor == pytest.approx(irw, abs=0.01)
    assert got_pslr == pytest.approx(pslr, abs=0.3)
