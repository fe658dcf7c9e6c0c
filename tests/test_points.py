"""Formers at 3-D pixel positions (sarcli.formers.points): backprojection onto terrain measured
against the exact matched filter at the same points, its adjoint, and the plane case."""

import numpy as np
import pytest

from sarcli.core import geometry
from sarcli.core.grid import Grid
from sarcli.formers.backprojection import backproject
from sarcli.formers.direct import direct_points
from sarcli.formers.points import backproject_points, reproject_points
from sarcli.core.collection import Collection
from sarcli.formers.options import BackprojectionOptions


def _collection(P=40, M=48, bistatic=False):
    f = 9.6e9 + 3e6 * np.arange(M)   # window c/(4Δα) = 25 m: the terrain stays inside it
    az = np.radians(np.linspace(-2.0, 2.0, P)) - np.pi / 3
    el = np.full(P, np.radians(35.0))
    a = geometry.antenna_positions_circle(az, el, 6e3)
    b = a + np.array([3.0, -2.0, 1.0]) if bistatic else None
    r0 = np.linalg.norm(a, axis=1)
    return f, a, b, r0


def _terrain(n=24, h=0.6):
    x = (np.arange(n) - n / 2) * h
    xx, yy = np.meshgrid(x + 3.0, x - 2.0)
    zz = 12.0 + 25.0 * np.exp(-(xx ** 2 + yy ** 2) / 50.0) + 0.5 * xx   # a hill on a slope
    return np.stack([xx, yy, zz], axis=-1)


@pytest.mark.parametrize("bistatic", [False, True])
def test_points_backprojection_meets_the_exact_matched_filter_on_terrain(bistatic):
    f, a, b, r0 = _collection(bistatic=bistatic)
    pts = _terrain()
    targets = pts[[5, 12, 18], [7, 12, 3]]
    psi = geometry.signal_phase(f, None, None, targets, model="spherical", antenna_position_m=a,
                                range_to_center_m=r0, receive_position_m=b)
    d = np.exp(-1j * psi).sum(axis=-1)
    ref = direct_points(d, f, a, r0, pts, receive_position_m=b)
    img = backproject_points(d, Collection(f, a, r0, receive_position_m=b), pts,
                             BackprojectionOptions(upsample=16, interp="cubic", precision="float64"))
    err = np.linalg.norm(img - ref) / np.linalg.norm(ref)
    assert err < 1e-3, err
    # each target peaks at 1 at its own pixel
    np.testing.assert_allclose(np.abs(ref[[5, 12, 18], [7, 12, 3]]), 1.0, atol=0.05)
    np.testing.assert_allclose(np.abs(img[[5, 12, 18], [7, 12, 3]]), np.abs(ref[[5, 12, 18], [7, 12, 3]]),
                               atol=2e-3)


def test_points_on_the_plane_equal_the_tiled_kernel():
    f, a, _, r0 = _collection()
    grid = Grid(32, 20, 0.5, 0.5, 2.0, -1.0)
    rng = np.random.default_rng(1)
    d = rng.standard_normal((a.shape[0], f.size)) + 1j * rng.standard_normal((a.shape[0], f.size))
    col, opts = Collection(f, a, r0), BackprojectionOptions(upsample=8, interp="lanczos", precision="float64")
    tiled = backproject(d, col, grid, opts)
    pts = backproject_points(d, col, grid.points(), opts)
    # the tiles' range model within its tolerance for this interpolator (Lanczos-3 at 8x errs 2.8e-3:
    # 2.8e-5), the points' exact in float64
    from sarcli.formers.backprojection._kernels import model_tolerance

    assert np.linalg.norm(pts - tiled) / np.linalg.norm(tiled) < model_tolerance("lanczos", 8)


@pytest.mark.parametrize("interp, precision", [("linear", "float64"), ("cubic", "float32"), ("lanczos", "float64"),
                                              ("lagrange", "float64")])
def test_reproject_points_is_the_exact_adjoint(interp, precision):
    f, a, b, r0 = _collection(P=12, M=20, bistatic=True)
    pts = _terrain(n=10)
    rng = np.random.default_rng(2)
    d = rng.standard_normal((12, 20)) + 1j * rng.standard_normal((12, 20))
    g = rng.standard_normal(pts.shape[:-1]) + 1j * rng.standard_normal(pts.shape[:-1])
    w = rng.uniform(0.5, 1.0, (12, 20))
    col = Collection(f, a, r0, w, receive_position_m=b)
    opts = BackprojectionOptions(upsample=4, interp=interp, precision=precision)
    lhs = np.vdot(g, backproject_points(d, col, pts, opts))
    rhs = np.vdot(reproject_points(g, col, pts, opts), d)
    tol = 1e-12 if precision == "float64" else 1e-5
    assert abs(lhs - rhs) <= tol * abs(lhs)


def test_bad_points_are_one_line():
    from sarcli.errors import SarcliInputError

    f, a, _, r0 = _collection(P=4, M=8)
    with pytest.raises(SarcliInputError, match="pixel positions"):
        backproject_points(np.ones((4, 8)), Collection(f, a, r0), np.zeros((5, 2)))
