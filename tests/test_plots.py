"""Diagnostic figures: PSF cuts (-3 dB widths), k-space in dimensionless frequencies, image spectrum."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.cli.main import cli
from sarcli.core.grid import Grid
from sarcli.core.types import Image, PhaseHistory
from sarcli.io.hdf5 import write_image, write_phase_history
from sarcli.viz import plot_image_fft, plot_kspace, plot_psf_cuts

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def _acq(look_rad=0.0, grid=None):
    f = 9.6e9 + np.arange(48) * 2e6
    az = look_rad + np.radians(np.linspace(-2.0, 2.0, 40))
    el = np.full(az.size, np.radians(30.0))
    return Acquisition(f, az, el, grid or Grid.square(8.0, 64))


def _png_ok(path):
    from PIL import Image as PILImage

    with PILImage.open(path) as im:
        assert im.format == "PNG" and im.size[0] > 300 and im.size[1] > 300


def test_psf_cuts_widths_match_prediction(tmp_path):
    from sarcli.analysis.psf import predicted_ipr, psf_image

    acq = _acq(0.0)  # range along x, cross-range along y
    out = plot_psf_cuts(psf_image(acq), tmp_path / "cuts.png")
    _png_ok(tmp_path / "cuts.png")
    pred = predicted_ipr(acq)
    assert out["peak_xy_m"] == pytest.approx((0.0, 0.0), abs=1e-9)
    assert out["x"]["irw_m"] == pytest.approx(pred["range"]["irw_m"], rel=0.02)
    assert out["y"]["irw_m"] == pytest.approx(pred["cross_range"]["irw_m"], rel=0.02)
    # the marked width is where the cut crosses -3.01 dB
    for name in ("x", "y"):
        c = out[name]
        lo, hi = c["half_power_m"]
        assert hi - lo == pytest.approx(c["irw_m"], rel=1e-12)
        for edge in (lo, hi):
            # linear in amplitude between samples vs linear in dB: a few hundredths of a dB
            assert np.interp(edge, c["s_m"], c["db"]) == pytest.approx(-3.01, abs=0.08)


def test_psf_cuts_on_bare_array_needs_grid():
    from sarcli.errors import SarcliInputError

    with pytest.raises(SarcliInputError, match="grid"):
        plot_psf_cuts(np.ones((8, 8)))


def test_kspace_samples_and_aliases(tmp_path):
    grid = Grid.square(8.0, 40)  # h = 0.4 m
    acq = _acq(np.radians(35.0), grid)
    out = plot_kspace(acq, grid, tmp_path / "k.png", max_points=500)
    _png_ok(tmp_path / "k.png")
    assert out["n_drawn"] <= 500
    assert np.all(out["k1"] >= -np.pi) and np.all(out["k1"] < np.pi)
    assert np.all(out["k2"] >= -np.pi) and np.all(out["k2"] < np.pi)
    k = acq.wavenumbers()
    lo, hi = out["unwrapped_radius"]
    assert lo == pytest.approx(k.min() * 0.4, rel=1e-12)
    assert hi == pytest.approx(k.max() * 0.4, rel=1e-3)  # decimation may skip the last frequency
    # wrapped = unwrapped modulo 2π for the first drawn sample (pulse 0, frequency 0)
    k1u = k[0, 0] * 0.4 * np.cos(acq.azimuth_rad[0])
    assert np.angle(np.exp(1j * (out["k1"][0, 0] - k1u))) == pytest.approx(0.0, abs=1e-9)


def test_image_fft_finds_a_plane_wave(tmp_path):
    grid = Grid(64, 48, 0.5, 0.5)
    xx, yy = np.meshgrid(grid.x, grid.y)
    fx0, fy0 = 0.25, -0.5  # cycles/m, on the FFT grid (1/(64*0.5) = 1/32, 1/(48*0.5) = 1/24)
    img = Image(np.exp(2j * np.pi * (fx0 * xx + fy0 * yy)), grid.x, grid.y, method="wave")
    out = plot_image_fft(img, tmp_path / "f.png")
    _png_ok(tmp_path / "f.png")
    assert out["spectral_peak_cycles_per_m"] == pytest.approx((fx0, fy0), abs=1e-12)
    assert out["spectrum_db"].max() == 0.0
    # everything else is numerically zero: floored at -60 dB
    assert np.sort(out["spectrum_db"].ravel())[-2] == -60.0


def test_cli_plot(tmp_path):
    from sarcli.analysis.psf import psf_image

    runner = CliRunner()
    acq = _acq(0.3)
    write_image(tmp_path / "psf.h5", psf_image(acq))
    for what in ("psf-cuts", "image-fft"):
        res = runner.invoke(cli, ["plot", what, str(tmp_path / "psf.h5"), "-o", str(tmp_path / f"{what}.png")])
        assert res.exit_code == 0, res.output
        _png_ok(tmp_path / f"{what}.png")
    pos = geometry.antenna_positions_circle(acq.azimuth_rad, acq.elevation_rad, 5e3)
    ph = PhaseHistory(np.zeros((acq.n_pulses, acq.n_frequencies), np.complex64),
                      acq.with_(antenna_position_m=pos, range_to_center_m=None))
    write_phase_history(tmp_path / "ph.h5", ph)
    res = runner.invoke(cli, ["plot", "kspace", str(tmp_path / "ph.h5"), "-o", str(tmp_path / "k.png"),
                              "--pixel-size", "0.3"])
    assert res.exit_code == 0, res.output
    _png_ok(tmp_path / "k.png")
    res = runner.invoke(cli, ["plot", "spectrum", str(tmp_path / "ph.h5"), "-o", str(tmp_path / "x.png")])
    assert res.exit_code == 2
    res = runner.invoke(cli, ["plot", "psf-cuts", str(tmp_path / "nope.h5"), "-o", str(tmp_path / "x.png")])
    assert res.exit_code == 2 and "no such file" in res.output
    assert not (tmp_path / "x.png").exists()


def test_cli_plot_kspace_from_yaml(tmp_path):
    cfg = CONFIGS / "three-points.yaml"
    if not cfg.exists():
        pytest.skip(f"{cfg} is not in this checkout")
    res = CliRunner().invoke(cli, ["plot", "kspace", str(cfg), "-o", str(tmp_path / "k.png")])
    assert res.exit_code == 0, res.output
    _png_ok(tmp_path / "k.png")
