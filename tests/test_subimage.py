"""Sub-image NUFFT against the exact spherical matched filter at r0 = 10 km, and its error model."""

from __future__ import annotations

import numpy as np
import pytest

from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.core.grid import Grid
from sarcli.core.types import PhaseHistory
from sarcli.errors import SarcliInputError
from sarcli.formers.direct import direct_spherical
from sarcli.formers.formation import form_image, image_error
from sarcli.formers.subimage import choose_tile, predict_tile_error, subimage_nufft
from sarcli.core.collection import Collection
from sarcli.formers.options import SubimageOptions

GRID = Grid(64, 64, 0.5, 0.5)            # 32 m: the far-field model is off by > 1 rad at its corner
FREQ = 9.6e9 + 4e6 * np.arange(128)
RNG = np.random.default_rng(5)
POINTS = np.column_stack([RNG.uniform(-15, 15, 10), RNG.uniform(-15, 15, 10), np.zeros(10)])
AMPS = RNG.normal(size=10) + 1j * RNG.normal(size=10)


@pytest.fixture(scope="module")
def scene():
    P = 128
    az = np.radians(np.linspace(-2.5, 2.5, P))
    a = geometry.antenna_positions_circle(az, np.radians(30), 10e3)
    r0 = np.linalg.norm(a, axis=1)
    dr = geometry.differential_range(a, r0, POINTS)
    data = (np.exp(-1j * 4 * np.pi / geometry.C * FREQ[None, :, None] * dr[:, None, :]) * AMPS).sum(-1)
    return data, a, r0, direct_spherical(data, FREQ, a, r0, GRID)


@pytest.mark.parametrize("tol", [1e-2, 2e-3])
def test_subimage_meets_tolerance_and_model(scene, tol):
    data, a, r0, ref = scene
    img, info = subimage_nufft(data, Collection(FREQ, a, r0), GRID, SubimageOptions(tolerance=tol),
                               return_info=True)
    err = image_error(img, ref)
    assert err <= tol
    assert info["predicted_error"] / 3 <= err <= 3 * info["predicted_error"], (err, info)
    assert info["n_tiles"] > 1    # the far-field model alone would not do


@pytest.mark.parametrize("tile", [64, 32, 16])
def test_tile_error_model_within_3x(scene, tile):
    data, a, r0, ref = scene
    img = subimage_nufft(data, Collection(FREQ, a, r0), GRID, SubimageOptions(tile=tile, eps=1e-9))
    err = image_error(img, ref)
    pred = predict_tile_error(a, None, r0, FREQ, GRID, tile, eps=1e-9)
    assert pred / 3 <= err <= 3 * pred, (tile, err, pred)


def test_smaller_tiles_predicted_more_accurate(scene):
    _, a, r0, _ = scene
    errs = [predict_tile_error(a, None, r0, FREQ, GRID, s) for s in (64, 32, 16, 8)]
    assert all(e1 > e2 for e1, e2 in zip(errs, errs[1:]))
    tile, pred = choose_tile(a, None, r0, FREQ, GRID, 1e-2)
    assert pred <= 1e-2 and tile in (32, 24, 16, 12, 8)


def test_subimage_refuses_unreachable_tolerance(scene):
    data, a, r0, _ = scene
    with pytest.raises(SarcliInputError, match="tolerance"):
        subimage_nufft(data, Collection(FREQ, a, r0), GRID, SubimageOptions(tolerance=1e-7))


def test_form_image_subimage(scene):
    data, a, r0, ref = scene
    az, el, _ = geometry.angles_from_positions(a)
    ph = PhaseHistory(data, Acquisition(FREQ, az, el, GRID, antenna_position_m=a, range_to_center_m=r0,
                                        model="spherical"))
    img = form_image(ph, "subimage", tolerance=5e-3)
    assert image_error(img.image, ref) <= 5e-3
    assert img.parameters["tile"] >= 8 and img.parameters["eps"] == pytest.approx(5e-4)
    # far-field data: one tile, the NUFFT itself
    ff = PhaseHistory(data, Acquisition(FREQ, az, el, GRID, model="farfield"))
    out = form_image(ff, "subimage")
    assert out.parameters["n_tiles"] == 1
    assert image_error(out.image, form_image(ff, "nufft").image) < 1e-12
