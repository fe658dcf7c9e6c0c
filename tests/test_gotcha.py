"""GOTCHA import: the reader on small synthetic ``.mat`` files (always) and on the real data set
(skipped when ``../shared/data/gotcha`` is absent), ``sar import gotcha``, and backprojection of
real data against the exact spherical matched filter."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.io
from click.testing import CliRunner

from sarcli.cli.main import cli
from sarcli.errors import InputFileError
from sarcli.core.geometry import angles_from_positions
from sarcli.io.gotcha import read_gotcha
from sarcli.core.grid import Grid
from sarcli.io.hdf5 import read_phase_history
from sarcli.core.collection import Collection
from sarcli.formers.options import BackprojectionOptions

from .conftest import GOTCHA_FILES  # noqa: E402

REAL = GOTCHA_FILES[:2]
needs_real = pytest.mark.gotcha


def fake_gotcha(path, th0_deg, *, P=5, M=8, freq=None, af=True, drop=None):
    """A tiny file with GOTCHA's layout: a circle at 10 km, 45° elevation."""
    rng = np.random.default_rng(int(th0_deg * 10) % 1000)
    th = th0_deg + 0.01 * np.arange(P)
    phi = np.full(P, 45.0)
    r0 = np.full(P, 1e4)
    t, e = np.radians(th), np.radians(phi)
    x, y, z = r0 * np.cos(e) * np.cos(t), r0 * np.cos(e) * np.sin(t), r0 * np.sin(e)
    freq = 9.6e9 + 1.5e6 * np.arange(M) if freq is None else freq
    data = {"fp": (rng.normal(size=(M, P)) + 1j * rng.normal(size=(M, P))).astype(np.complex64),
            "freq": freq.astype(np.float32)[:, None], "x": x[None].astype(np.float32),
            "y": y[None].astype(np.float32), "z": z[None].astype(np.float32),
            "r0": r0[None].astype(np.float32), "th": th[None].astype(np.float32),
            "phi": phi[None].astype(np.float32)}
    if af:
        data["af"] = {"r_correct": rng.normal(size=(1, P)).astype(np.float32),
                      "ph_correct": rng.normal(size=(1, P)).astype(np.float32)}
    if drop:
        del data[drop]
    scipy.io.savemat(path, {"data": data})
    return data


def test_reader_joins_files_in_azimuth_order_and_applies_autofocus(tmp_path):
    a = fake_gotcha(tmp_path / "a.mat", 359.0)   # across the 360° -> 0° seam: a comes first
    b = fake_gotcha(tmp_path / "b.mat", 0.5)
    ph = read_gotcha([tmp_path / "b.mat", tmp_path / "a.mat"])
    acq = ph.acquisition
    assert ph.data.shape == (10, 8) and acq.model == "spherical"
    np.testing.assert_array_equal(ph.data[:5], a["fp"].T)
    np.testing.assert_array_equal(ph.data[5:], b["fp"].T)
    # look azimuth θ = th + 180°, and it agrees with the antenna positions
    az, el, _ = angles_from_positions(acq.antenna_position_m)
    assert np.max(np.abs(np.angle(np.exp(1j * (az - acq.azimuth_rad))))) < 1e-6
    assert np.max(np.abs(el - np.radians(45.0))) < 1e-6
    assert acq.grid == Grid.from_extent(100.0, 0.25) and acq.grid.shape == (400, 400)
    af = read_gotcha([tmp_path / "a.mat", tmp_path / "b.mat"], autofocus=True)
    ph_corr = np.concatenate([a["af"]["ph_correct"][0], b["af"]["ph_correct"][0]]).astype(float)
    r_corr = np.concatenate([a["af"]["r_correct"][0], b["af"]["r_correct"][0]]).astype(float)
    np.testing.assert_allclose(af.data, ph.data * np.exp(1j * ph_corr)[:, None], rtol=1e-6)
    np.testing.assert_allclose(af.acquisition.range_to_center_m - acq.range_to_center_m, r_corr, atol=1e-9)


def test_reader_refuses_foreign_broken_and_mismatched_files(tmp_path):
    (tmp_path / "text.mat").write_text("not matlab at all\n")
    scipy.io.savemat(tmp_path / "foreign.mat", {"image": np.ones((3, 3))})
    fake_gotcha(tmp_path / "nofreq.mat", 1.0, drop="freq")
    fake_gotcha(tmp_path / "noaf.mat", 1.0, af=False)
    fake_gotcha(tmp_path / "ok.mat", 1.0)
    fake_gotcha(tmp_path / "other_band.mat", 2.0, freq=9.0e9 + 1.5e6 * np.arange(8))
    cases = [("text.mat", False, "MATLAB"), ("foreign.mat", False, "no variable 'data'"),
             ("nofreq.mat", False, "no field 'freq'"), ("noaf.mat", True, "autofocus"),
             ("missing.mat", False, "no such file")]
    for name, autofocus, msg in cases:
        with pytest.raises(InputFileError, match=msg) as err:
            read_gotcha(tmp_path / name, autofocus=autofocus)
        assert "\n" not in str(err.value) and name in str(err.value)
    with pytest.raises(InputFileError, match="frequencies"):
        read_gotcha([tmp_path / "ok.mat", tmp_path / "other_band.mat"])
    with pytest.raises(InputFileError, match="twice"):
        read_gotcha([tmp_path / "ok.mat", tmp_path / "ok.mat"])
    read_gotcha(tmp_path / "noaf.mat")  # fine without --autofocus


def test_cli_import_gotcha_writes_phase_history(tmp_path):
    fake_gotcha(tmp_path / "a.mat", 10.0)
    fake_gotcha(tmp_path / "b.mat", 10.05)
    out = tmp_path / "ph.h5"
    res = CliRunner().invoke(cli, ["import", "gotcha", str(tmp_path / "b.mat"), str(tmp_path / "a.mat"),
                                   "-o", str(out), "--autofocus", "--extent", "40", "--pixel-size", "0.5"])
    assert res.exit_code == 0, res.output
    ph = read_phase_history(out)
    ref = read_gotcha([tmp_path / "a.mat", tmp_path / "b.mat"], autofocus=True)
    np.testing.assert_array_equal(ph.data, ref.data)
    np.testing.assert_array_equal(ph.acquisition.range_to_center_m, ref.acquisition.range_to_center_m)
    assert ph.model == "spherical" and ph.acquisition.grid.shape == (80, 80)
    bad = CliRunner().invoke(cli, ["import", "gotcha", str(tmp_path / "nothere.mat"), "-o", str(tmp_path / "x.h5")])
    assert bad.exit_code == 2 and "nothere.mat" in bad.output and not (tmp_path / "x.h5").exists()


@needs_real
def test_real_files_geometry():
    ph = read_gotcha(REAL)
    acq = ph.acquisition
    assert ph.data.shape[1] == 424 and ph.data.shape[0] > 200
    az, el, r0 = angles_from_positions(acq.antenna_position_m)
    assert np.max(np.abs(np.angle(np.exp(1j * (az - acq.azimuth_rad))))) < 1e-5  # th + 180° is the look
    assert np.max(np.abs(el - acq.elevation_rad)) < 1e-5
    assert np.max(np.abs(r0 - acq.range_to_center_m)) < 2e-3  # float32 positions, ~1 ulp
    assert np.all(np.diff(np.unwrap(acq.azimuth_rad)) > 0)


@needs_real
def test_real_backprojection_matches_exact_matched_filter():
    """az001-002 with autofocus, 20 m window on the bright scatterer near (-15.5, 21.5) m."""
    from sarcli.formers.backprojection import backproject
    from sarcli.formers.direct import direct_spherical

    ph = read_gotcha(REAL, autofocus=True)
    acq = ph.acquisition
    window = Grid.from_extent(20.0, 0.5, center=(-15.5, 21.5))  # 40 x 40 keeps the reference fast
    args = (ph.data, acq.frequency_hz, acq.antenna_position_m, acq.range_to_center_m, window)
    col = Collection(acq.frequency_hz, acq.antenna_position_m, acq.range_to_center_m)
    ref = direct_spherical(*args)
    img = backproject(ph.data, col, window)
    err = np.linalg.norm(img - ref) / np.linalg.norm(ref)
    assert err < 3e-4  # measured 3.6e-5 (cubic, upsample 16)
    assert np.abs(ref).max() / np.abs(ref).mean() > 30  # a focused bright scatterer (measured 114)
    err32 = np.linalg.norm(backproject(ph.data, col, window, BackprojectionOptions(precision="float32")) - ref) \
        / np.linalg.norm(ref)
    assert err32 < 3e-4  # measured 3.6e-5


@needs_real
def test_real_phase_sign_focuses_only_as_stored():
    """With AFRL's autofocus (exp(+i ph_correct)) the stored sign focuses, the conjugate does not."""
    from sarcli.formers.backprojection import backproject

    ph = read_gotcha(REAL, autofocus=True)
    acq = ph.acquisition
    grid = Grid.from_extent(100.0, 0.5)
    col = Collection(acq.frequency_hz, acq.antenna_position_m, acq.range_to_center_m)
    opts = BackprojectionOptions(precision="float32", interp="linear", upsample=4)
    ratio = [np.abs(f).max() / np.abs(f).mean()
             for f in (backproject(ph.data, col, grid, opts), backproject(np.conj(ph.data), col, grid, opts))]
    assert ratio[0] > 5 * ratio[1], ratio
