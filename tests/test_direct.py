"""The exact matched filter (eq. ``mf``) against brute-force sums, far-field and spherical."""

import numpy as np
import pytest

from sarcli.core import geometry
from sarcli.formers.direct import direct_farfield, direct_spherical
from sarcli.core.grid import Grid
from sarcli.core.windows import window_weights


def _tiny(p=5, m=4, r0=2.0e3):
    az = np.deg2rad(50 + np.linspace(-1.5, 1.5, p))
    el = np.deg2rad(30 + np.linspace(0, 0.4, p))
    freq = 1e10 + np.linspace(-3e8, 3e8, m)
    rng = np.random.default_rng(1)
    data = rng.standard_normal((p, m)) + 1j * rng.standard_normal((p, m))
    ant = geometry.antenna_positions_circle(az, el, r0)
    return az, el, freq, data, ant


def test_farfield_equals_triple_sum():
    az, el, freq, data, _ = _tiny()
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    grid = Grid(7, 6, 0.3, 0.25, 1.1, -0.7)
    w = window_weights(*data.shape, "hamming")
    ref = np.zeros(grid.shape, dtype=complex)
    for r, y in enumerate(grid.y):
        for c, x in enumerate(grid.x):
            for p in range(data.shape[0]):
                for j in range(data.shape[1]):
                    ref[r, c] += w[p, j] * data[p, j] * np.exp(1j * (kx[p, j] * x + ky[p, j] * y))
    ref /= w.sum()
    for chunk in (None, 1, 3):
        image = direct_farfield(data, kx, ky, grid, w, chunk=chunk)
        assert np.abs(image - ref).max() < 1e-13 * np.abs(ref).max()   # measured 2.2e-14


def test_spherical_equals_triple_sum():
    az, el, freq, data, ant = _tiny()
    r0 = np.linalg.norm(ant, axis=1) + np.array([0.0, 0.1, -0.2, 0.05, 0.0])  # motion-compensated r0
    grid = Grid(5, 4, 0.5, 0.4, -0.3, 0.6)
    w = window_weights(*data.shape, "hann")
    w[w == 0] = 0.5
    ref = np.zeros(grid.shape, dtype=complex)
    for r, y in enumerate(grid.y):
        for c, x in enumerate(grid.x):
            dr = geometry.differential_range(ant, r0, np.array([x, y, 0.0]))  # [P]
            for p in range(data.shape[0]):
                for j in range(data.shape[1]):
                    ref[r, c] += w[p, j] * data[p, j] * np.exp(1j * 4 * np.pi * freq[j] / geometry.C * dr[p])
    ref /= w.sum()
    for chunk in (None, 1, 2):
        image = direct_spherical(data, freq, ant, r0, grid, w, chunk=chunk)
        assert np.abs(image - ref).max() < 2e-13 * np.abs(ref).max()   # measured 4.4e-14
    # per-pulse frequencies give the same result as a shared vector
    freq2 = np.broadcast_to(freq, data.shape).copy()
    image2 = direct_spherical(data, freq2, ant, r0, grid, w)
    assert np.abs(image2 - ref).max() < 2e-13 * np.abs(ref).max()   # measured 4.0e-14


def _point_data(point, model, r0=1.0e4):
    p, m = 48, 64
    az = np.deg2rad(50 + np.linspace(-1.5, 1.5, p))
    el = np.full(p, np.deg2rad(30))
    freq = 1e10 + np.linspace(-3e8, 3e8, m)
    ant = geometry.antenna_positions_circle(az, el, r0)
    rr = np.full(p, r0)
    psi = geometry.signal_phase(freq, az, el, np.array([point]), model=model,
                                antenna_position_m=ant, range_to_center_m=rr)
    return az, el, freq, ant, rr, np.exp(-1j * psi[..., 0])


@pytest.mark.parametrize("model", ["farfield", "spherical"])
def test_unit_point_peak_one(model):
    grid = Grid.square(6.0, 48)
    point = (1.25, -2.0, 0.0)
    az, el, freq, ant, rr, data = _point_data(point, model)
    if model == "farfield":
        kx, ky = geometry.kspace_coordinates(freq, az, el)
        image = direct_farfield(data, kx, ky, grid)
    else:
        image = direct_spherical(data, freq, ant, rr, grid)
    row, col = grid.index_of(point[0], point[1])
    assert np.unravel_index(np.argmax(np.abs(image)), image.shape) == (row, col)
    assert abs(image[row, col]) == pytest.approx(1.0, abs=1e-12)   # measured exactly 1.0


def test_spherical_far_range_approaches_farfield():
    """At 10 000 km the spherical matched filter of far-field-like data matches the far-field one."""
    grid = Grid.square(3.0, 16)
    az, el, freq, ant, rr, data = _point_data((0.5, 0.25, 0.0), "spherical", r0=1.0e7)
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    a = direct_spherical(data, freq, ant, rr, grid)
    b = direct_farfield(data, kx, ky, grid)
    bound = geometry.farfield_phase_error(rr, freq.max(), grid.half_diagonal)
    assert bound < 1e-3
    assert np.linalg.norm(a - b) / np.linalg.norm(a) < 2 * bound


def test_bad_inputs():
    az, el, freq, data, ant = _tiny()
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    grid = Grid.square(1.0, 4)
    with pytest.raises(ValueError, match="weights shape"):
        direct_farfield(data, kx, ky, grid, np.ones((2, 2)))
    with pytest.raises(ValueError, match="positive sum"):
        direct_farfield(data, kx, ky, grid, np.zeros(data.shape))
    with pytest.raises(ValueError, match="do not match"):
        direct_farfield(data, kx[:2], ky, grid)
    with pytest.raises(ValueError, match="pulses"):
        direct_spherical(data, freq, ant[:2], np.ones(2), grid)


def test_kernel_sine_and_cosine_within_two_ulp():
    """The spherical sum's own sine and cosine (vectorised polynomials) against the C library's."""
    from sarcli._native import load

    rng = np.random.default_rng(4)
    x = np.concatenate([rng.uniform(-lim, lim, 20000) for lim in (1.0, 1e3, 1e5, 1e7, 9e7)]
                       + [np.pi / 4 * np.arange(-9, 10), [0.0, -0.0, 1e-300]])
    s, c = load("direct").sin_cos(x)
    assert np.max(np.abs(s - np.sin(x))) <= 2 ** -52 and np.max(np.abs(c - np.cos(x))) <= 2 ** -52


@pytest.mark.parametrize("scale", [1.0, 1e6])
def test_spherical_kernel_matches_numpy(scale):
    """Pixels not a multiple of the kernel's group of 8; ranges so large (scale 1e6) that the
    phases leave the polynomials' range and the C library's sine and cosine take over."""
    from sarcli._native import load

    rng = np.random.default_rng(5)
    P, M, n = 6, 33, 29
    dr = rng.uniform(-50, 50, (P, n)) * scale
    k4 = 4 * np.pi * (9.8e9 + 3e6 * rng.random((P, M))) / geometry.C
    wd = rng.standard_normal((P, M)) + 1j * rng.standard_normal((P, M))
    out = np.full(n, 1.0 - 2.0j)
    load("direct").accumulate_spherical(out, dr, k4, wd)
    ref = 1.0 - 2.0j + np.einsum("pj,pjn->n", wd, np.exp(1j * k4[:, :, None] * dr[:, None, :]))
    assert np.max(np.abs(out - ref)) < 5e-15 * np.sqrt(P * M)   # measured 1.5e-14 = 1.0e-15 √(P M)
