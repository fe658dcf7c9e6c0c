"""The compiled separable spreader of the warped operator's Gram (sarcli._native._spread with
sarcli.linops.warped.kernel_table / kernel_weights): the same grid as FINUFFT's own spreader, an
exact adjoint pair, any thread count, and taps outside the grid refused."""

from __future__ import annotations

import finufft
import numpy as np
import pytest

from sarcli._native import load, using_threads
from sarcli.linops.spreading import SIGMA, kernel_table, kernel_weights

SHAPE = (70, 52)


def points(n=3000, seed=0, taps=5):
    """Grid coordinates of a warped, rotated lattice well inside SHAPE, and complex values."""
    rng = np.random.default_rng(seed)
    m = taps // 2 + 2
    x = np.stack([rng.uniform(m, s - m - 1, n) for s in SHAPE], axis=1)
    f = (rng.standard_normal(n) + 1j * rng.standard_normal(n)).astype(np.complex64)
    ph = np.exp(1j * rng.uniform(0, 2 * np.pi, n)).astype(np.complex64)
    return x, f, ph


def prepared(x, eps):
    table = kernel_table(eps)
    (i0, wy), (j0, wx) = (kernel_weights(x[:, i], table) for i in (0, 1))
    return table, (i0, j0, wy, wx)


@pytest.mark.parametrize("eps", [1e-3, 1e-4, 1e-6])
def test_kernel_table_is_finufft_kernel(eps):
    taps, z, v = kernel_table(eps)
    assert 2 <= taps <= 16 and z[0] == -taps / 2 and z[-1] == taps / 2
    assert abs(v[np.argmin(np.abs(z))] - 1.0) < 1e-5 and v.min() >= 0.0
    # even (but at the ends: a node exactly w/2 after the point is not a tap), falling away from the centre
    assert v[0] > 0 and v[-1] == 0 and np.allclose(v[1:-1], v[-2:0:-1], atol=1e-12)
    assert np.all(np.diff(v[z >= 0]) <= 1e-12)


@pytest.mark.parametrize("eps", [1e-3, 1e-4, 1e-6])
def test_spread_equals_finufft_and_interp_is_its_adjoint(eps):
    kern = load("spread")
    x, f, ph = points()
    (taps, _, _), pts = prepared(x, eps)
    grid = np.empty(SHAPE, np.complex64)
    kern.spread(*pts, ph, f, grid, np.empty((1,) + SHAPE, np.complex64))
    tau = [np.ascontiguousarray(2 * np.pi * x[:, i] / SHAPE[i] - np.pi) for i in (0, 1)]
    ref = finufft.nufft2d1(*tau, (ph * f).astype(np.complex128), SHAPE, eps=eps, spreadinterponly=1,
                           upsampfac=SIGMA, modeord=0)
    assert np.linalg.norm(grid - ref) <= 2e-6 * np.linalg.norm(ref)
    # dot test: <spread f, g> = <f, interp g>, to float32 rounding
    rng = np.random.default_rng(1)
    g = (rng.standard_normal(SHAPE) + 1j * rng.standard_normal(SHAPE)).astype(np.complex64)
    back = np.empty(f.size, np.complex64)
    kern.interp(*pts, ph, g, back)
    lhs, rhs = np.vdot(g.astype(np.complex128), grid), np.vdot(back.astype(np.complex128), f)
    assert abs(lhs - rhs) <= 1e-5 * np.linalg.norm(g) * np.linalg.norm(grid)
    ref_back = np.conj(ph) * finufft.nufft2d2(*tau, g.astype(np.complex128), eps=eps, spreadinterponly=1,
                                              upsampfac=SIGMA, modeord=0)
    assert np.linalg.norm(back - ref_back) <= 2e-6 * np.linalg.norm(ref_back)


def test_spread_is_the_same_on_any_thread_count():
    kern = load("spread")
    x, f, ph = points(n=20000, seed=2)
    _, pts = prepared(x, 1e-4)
    grids = []
    for n in (1, 2, 3):
        grid = np.empty(SHAPE, np.complex64)
        with using_threads(n):
            kern.spread(*pts, ph, f, grid, np.empty((n - 1,) + SHAPE, np.complex64))
        grids.append(grid)
    for g in grids[1:]:
        assert np.linalg.norm(g - grids[0]) <= 1e-6 * np.linalg.norm(grids[0])
    # too little scratch: fewer threads, the same grid
    grid = np.empty(SHAPE, np.complex64)
    with using_threads(4):
        kern.spread(*pts, ph, f, grid, np.empty((0,) + SHAPE, np.complex64))
    assert np.linalg.norm(grid - grids[0]) <= 1e-6 * np.linalg.norm(grids[0])


def test_taps_outside_the_grid_are_refused():
    kern = load("spread")
    x, f, ph = points(n=10)
    x[3, 1] = 0.5  # its first tap would be at column -2
    _, pts = prepared(x, 1e-4)
    with pytest.raises(ValueError, match="leave the grid"):
        kern.spread(*pts, ph, f, np.empty(SHAPE, np.complex64), np.empty((0,) + SHAPE, np.complex64))
    with pytest.raises(ValueError, match="leave the grid"):
        kern.interp(*pts, ph, np.zeros(SHAPE, np.complex64), np.empty(10, np.complex64))
    i0, j0, wy, wx = pts
    with pytest.raises(ValueError, match="inconsistent"):
        kern.interp(i0, j0[:-1], wy, wx, ph, np.zeros(SHAPE, np.complex64), np.empty(10, np.complex64))
