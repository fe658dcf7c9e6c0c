"""Fast far-field formers (NUFFT, PFA) against the exact matched filter (eq. ``mf``).

Geometry like the three-points example: 10 GHz, 600 MHz bandwidth, φ = 30°, 3° of aperture
around θ = 50°; 64 pulses x 128 frequencies, 64² pixels of 0.25 m (inside the alias-free radius).
"""

import warnings

import h5py
import numpy as np
import pytest

from sarcli.core import geometry
from sarcli.errors import InputFileError, SarcliInputError, SarcliWarning
from sarcli.formers import pfa
from sarcli.formers.direct import direct_farfield
from sarcli.formers.nufft import nufft_farfield
from sarcli.core.types import KGrid
from sarcli.io.hdf5 import read_kgrid, write_kgrid
from sarcli.formers.options import PfaOptions
from sarcli.formers.pfa import pfa_image, regrid_polar
from sarcli.core.grid import Grid
from sarcli.core.windows import window_weights

P, M = 64, 128
AZ = np.deg2rad(50 + np.linspace(-1.5, 1.5, P))
EL = np.full(P, np.deg2rad(30))
FREQ = 1e10 + np.linspace(-3e8, 3e8, M)
KX, KY = geometry.kspace_coordinates(FREQ, AZ, EL)
GRID = Grid.square(8.0, 64)  # h = 0.25 m
THREE = np.array([[0.0, 0.0, 0.0], [2.0, 1.0, 0.0], [-3.0, -2.5, 0.0]])


def _data(points, amplitudes=None):
    psi = geometry.signal_phase(FREQ, AZ, EL, points)
    amp = np.ones(len(points)) if amplitudes is None else amplitudes
    return np.exp(-1j * psi) @ amp


def _extended_data():
    """Random complex reflectivities on a coarse 6 x 6 lattice of points (2 m spacing)."""
    rng = np.random.default_rng(7)
    xs = np.arange(-5.0, 6.0, 2.0)
    xx, yy = np.meshgrid(xs, xs)
    pts = np.column_stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)])
    amp = rng.standard_normal(xx.size) + 1j * rng.standard_normal(xx.size)
    return _data(pts, amp)


def _rel(a, ref):
    return float(np.linalg.norm(a - ref) / np.linalg.norm(ref))


def _pfa(data, grid, weights=None, density="none", **knobs):
    kg = regrid_polar(data, KX, KY, weights, pixel_m=(grid.dx, grid.dy), shape=grid.shape,
                      center_m=(grid.cx, grid.cy), options=PfaOptions(**knobs), density=density)
    return pfa_image(kg, grid)


@pytest.fixture(scope="module")
def three_points():
    data = _data(THREE)
    return data, direct_farfield(data, KX, KY, GRID)


@pytest.fixture(scope="module")
def extended():
    data = _extended_data()
    return data, direct_farfield(data, KX, KY, GRID)


# -- NUFFT ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["three_points", "extended"])
def test_nufft_matches_direct(case, request):
    data, ref = request.getfixturevalue(case)
    err = _rel(nufft_farfield(data, KX, KY, GRID), ref)
    assert err <= 2e-9  # measured 2.6e-10 at eps = 1e-9


def test_nufft_error_falls_with_eps(three_points):
    data, ref = three_points
    errs = [_rel(nufft_farfield(data, KX, KY, GRID, eps=eps), ref) for eps in (1e-3, 1e-6, 1e-9)]
    assert errs[0] > 30 * errs[1] > 30 * 30 * errs[2]
    assert errs[0] < 6e-4 and errs[1] < 1e-6   # measured 6.2e-5, 1.1e-7


@pytest.mark.parametrize("case", ["three_points", "extended"])
@pytest.mark.parametrize("eps", [1e-2, 1e-3, 1e-4, 1e-6, 1e-9, 1e-11])
def test_nufft_meets_the_tolerance_asked_for(case, eps, request):
    """eps is a promise: the reduced upsampling and single precision chosen for loose eps keep it."""
    from sarcli.formers.nufft import nufft_options

    data, ref = request.getfixturevalue(case)
    assert _rel(nufft_farfield(data, KX, KY, GRID, eps=eps), ref) <= eps
    assert nufft_options(eps)["precision"] == ("single" if eps >= 1e-3 else "double")


@pytest.mark.parametrize("grid", [Grid(63, 40, 0.3, 0.2, 1.3, -2.1), Grid(48, 80, 0.25, 0.25, -2.0, 3.5)])
def test_nufft_offset_and_nonsquare_grid(grid):
    data = _extended_data()
    ref = direct_farfield(data, KX, KY, grid)
    assert _rel(nufft_farfield(data, KX, KY, grid, nthreads=1), ref) <= 3e-9   # measured 2.9e-10


# -- PFA ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["three_points", "extended"])
def test_pfa_matches_direct(case, request):
    data, ref = request.getfixturevalue(case)
    err = _rel(_pfa(data, GRID), ref)
    assert err <= 1e-5  # measured 1.8e-6 (both cases), Kaiser-Bessel w = 6, oversample 2


def test_pfa_error_falls_with_knobs(three_points):
    data, ref = three_points
    err = {knobs: _rel(_pfa(data, GRID, kernel=knobs[0], oversample=knobs[1], width=knobs[2]), ref)
           for knobs in [("kaiser", 2.0, 4), ("kaiser", 2.0, 6), ("kaiser", 2.0, 8),
                         ("kaiser", 1.5, 4), ("linear", 2.0, 2), ("linear", 4.0, 2)]}
    assert err[("kaiser", 2.0, 4)] > 10 * err[("kaiser", 2.0, 6)] > 100 * err[("kaiser", 2.0, 8)]
    assert err[("kaiser", 1.5, 4)] > 2 * err[("kaiser", 2.0, 4)]
    assert err[("linear", 2.0, 2)] > 1.5 * err[("linear", 4.0, 2)]
    assert err[("linear", 2.0, 2)] > 100 * err[("kaiser", 2.0, 6)]
    assert err[("linear", 2.0, 2)] < 0.1  # measured 2.6e-2


@pytest.mark.parametrize("grid", [Grid(63, 40, 0.3, 0.2, 1.3, -2.1), Grid(48, 80, 0.25, 0.25, -2.0, 3.5)])
def test_pfa_offset_and_nonsquare_grid(grid):
    data = _extended_data()
    ref = direct_farfield(data, KX, KY, grid)
    assert _rel(_pfa(data, grid), ref) <= 2e-5   # measured 1.3e-6, 2.3e-6
    # a k-grid designed around the origin still serves an offset grid of the same pixel size
    kg = regrid_polar(data, KX, KY, pixel_m=(grid.dx, grid.dy), shape=grid.shape)
    assert _rel(pfa_image(kg, grid), ref) <= 3e-3   # measured 3.1e-4, 3.9e-5


def test_pfa_area_density_keeps_centre_peak():
    data = _data(THREE[:1])
    image = _pfa(data, GRID, density="area")
    row, col = GRID.index_of(0.0, 0.0)
    assert abs(image[row, col]) == pytest.approx(1.0, abs=1e-6)   # measured 7.6e-8
    # the area weighting is a genuinely different (integral) image: a few percent from eq. mf
    ref = direct_farfield(data, KX, KY, GRID)
    assert 1e-3 < _rel(image, ref) < 5e-2


# -- shared properties ----------------------------------------------------------------------------
@pytest.mark.parametrize("method", ["nufft", "pfa", "pfa-linear"])
@pytest.mark.parametrize("window", ["none", "taylor"])
def test_unit_point_peak_one(method, window):
    point = (2.0, -1.25)
    data = _data(np.array([[point[0], point[1], 0.0]]))
    w = window_weights(P, M, window)
    if method == "nufft":
        image = nufft_farfield(data, KX, KY, GRID, w)
    else:
        image = _pfa(data, GRID, w, kernel="linear" if method == "pfa-linear" else "kaiser")
    row, col = GRID.index_of(*point)
    assert np.unravel_index(np.argmax(np.abs(image)), image.shape) == (row, col)
    # measured |peak| - 1: nufft 1.0e-12, pfa kaiser 1.6e-7, pfa linear 7.0e-5
    assert abs(image[row, col]) == pytest.approx(1.0, abs={"nufft": 1e-11, "pfa": 2e-6, "pfa-linear": 7e-4}[method])


# -- KGrid file and errors ------------------------------------------------------------------------
def test_kgrid_roundtrip(tmp_path, three_points):
    data, ref = three_points
    kg = regrid_polar(data, KX, KY, pixel_m=GRID.dx, shape=GRID.shape)
    path = tmp_path / "k.h5"
    write_kgrid(path, kg)
    back = read_kgrid(path)
    assert np.array_equal(back.samples, kg.samples)
    assert back.parameters == kg.parameters and back.kc == kg.kc
    assert _rel(pfa_image(back, GRID), ref) < 1e-5


def test_kgrid_rejects_bad_files(tmp_path):
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as h5:
        h5.attrs["format"] = "sarcli-image"
        h5.attrs["version"] = 1
    with pytest.raises(InputFileError, match="not a k-grid"):
        read_kgrid(foreign)
    broken = tmp_path / "broken.h5"
    broken.write_bytes(b"not hdf5 at all")
    with pytest.raises(InputFileError):
        read_kgrid(broken)
    partial = tmp_path / "partial.h5"
    with h5py.File(partial, "w") as h5:
        h5.attrs["format"] = "sarcli-kgrid"
        h5.attrs["version"] = 1
    with pytest.raises(InputFileError, match="cannot read"):
        read_kgrid(partial)
    with pytest.raises(InputFileError):
        read_kgrid(tmp_path / "missing.h5")


def test_pfa_errors(monkeypatch, three_points):
    data, _ = three_points
    kg = regrid_polar(data, KX, KY, pixel_m=GRID.dx, shape=GRID.shape)
    with pytest.raises(SarcliInputError, match="pixels"):
        pfa_image(kg, Grid.square(8.0, 32))
    with pytest.raises(SarcliInputError, match="field of view"):
        pfa_image(kg, Grid(64, 64, 0.25, 0.25, 40.0, 0.0))
    with pytest.raises(SarcliInputError, match="kaiser, linear"):
        regrid_polar(data, KX, KY, pixel_m=0.25, shape=(8, 8), options=PfaOptions(kernel="cubic"))
    monkeypatch.setattr(pfa, "MAX_KGRID_CELLS", 100)
    with pytest.raises(SarcliInputError, match="NUFFT"):
        regrid_polar(data, KX, KY, pixel_m=0.25, shape=(8, 8))


def test_pfa_wide_aperture_warns_but_stays_correct():
    p, m = 60, 8
    az = np.deg2rad(np.linspace(0, 120, p))
    el = np.full(p, np.deg2rad(30))
    freq = 1e10 + np.linspace(-3e7, 3e7, m)
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    grid = Grid.square(0.5, 8)
    data = np.exp(-1j * geometry.signal_phase(freq, az, el, np.array([[0.125, 0.0, 0.0]])))[..., 0]
    with pytest.warns(SarcliWarning, match=r"120\.0°"):
        kg = regrid_polar(data, kx, ky, pixel_m=grid.dx, shape=grid.shape)
    ref = direct_farfield(data, kx, ky, grid)
    assert _rel(pfa_image(kg, grid), ref) < 1e-4
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        regrid_polar(data[:5], kx[:5], ky[:5], pixel_m=grid.dx, shape=grid.shape)  # 8°: silent


def test_pfa_gridding_chunks_do_not_change_result(monkeypatch, three_points):
    data, _ = three_points
    whole = regrid_polar(data, KX, KY, pixel_m=GRID.dx, shape=GRID.shape)
    monkeypatch.setattr(pfa, "_SPREAD_CHUNK", 1000)
    chunked = regrid_polar(data, KX, KY, pixel_m=GRID.dx, shape=GRID.shape)
    assert np.abs(chunked.samples - whole.samples).max() <= 1e-12 * np.abs(whole.samples).max()
