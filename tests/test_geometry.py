"""Geometry against hand-computed numbers for the three-points acquisition (paper section 3.3)."""

from __future__ import annotations

import numpy as np
import pytest

import sarcli
from sarcli.core import geometry

from .conftest import CONFIGS


@pytest.fixture(scope="module")
def acq():
    return sarcli.load_acquisition(CONFIGS / "three-points.yaml")


def test_wavenumbers_by_hand(acq):
    k = acq.wavenumbers()
    # 4π · 9.7e9 · cos 30° / 299792458 and 4π · 10.3e9 · cos 30° / c, worked out by hand
    assert k[0, 0] == pytest.approx(352.1207, rel=1e-6)
    assert k[0, -1] == pytest.approx(373.9013, rel=1e-6)
    assert np.ptp(k[:, 0]) < 1e-9  # constant elevation: same k for every pulse
    dk = np.diff(k[0])
    assert np.allclose(dk, (373.9013 - 352.1207) / 511, rtol=1e-5)


def test_kspace_coordinates_rotate_with_azimuth(acq):
    kx, ky = acq.kspace()
    k = acq.wavenumbers()
    assert np.allclose(np.hypot(kx, ky), k)
    assert np.allclose(np.degrees(np.arctan2(ky[:, 0], kx[:, 0])), np.linspace(48.5, 51.5, 128))


def test_alias_free_radii_and_resolution_by_hand(acq):
    r_rg, r_cr = acq.alias_free_radii()
    # c / (4 Δα cos φ), Δα = 600 MHz / 511;  c / (4 α_M cos φ Δθ), Δθ = 3°/127, α_M = 10.3 GHz
    assert r_rg == pytest.approx(73.7055, rel=1e-5)
    assert r_cr == pytest.approx(20.3797, rel=1e-5)
    rho_r, rho_cr = acq.resolutions()
    # c / (2 B cos φ) and c / (4 α_c cos φ sin(Θ/2)) with Θ = 3°
    assert rho_r == pytest.approx(0.288475, rel=1e-5)
    assert rho_cr == pytest.approx(0.330606, rel=1e-5)


def test_grid_convention(acq):
    g = acq.grid
    assert g.shape == (500, 500) and g.dx == pytest.approx(0.02)
    assert g.x[250] == 0.0 and g.x[0] == pytest.approx(-5.0) and g.x[-1] == pytest.approx(4.98)
    assert g.index_of(1.0, 4.0) == (450, 300)


def test_antenna_geometry_matches_look_direction(acq):
    a = acq.antenna_position_m
    u = geometry.look_directions(acq.azimuth_rad, acq.elevation_rad)
    assert np.allclose(-a / np.linalg.norm(a, axis=1)[:, None], u)
    # the antenna sits at azimuth θ + π
    assert np.allclose(np.mod(np.arctan2(a[:, 1], a[:, 0]) - acq.azimuth_rad, 2 * np.pi), np.pi)
    assert np.allclose(acq.range_to_center_m, 10_000.0)


def test_differential_range_is_cancellation_free():
    a = np.array([[-1.0e5, 2.0e4, 3.0e4]])
    r0 = np.linalg.norm(a, axis=1)
    x = np.array([[3.0, -2.0, 0.0], [1e-3, 0.0, 0.0]])
    dr = geometry.differential_range(a, r0, x)[0]
    ref = [float(np.linalg.norm(a[0].astype(np.longdouble) - xi.astype(np.longdouble)) - np.longdouble(r0[0]))
           for xi in x]
    assert np.allclose(dr, ref, rtol=0, atol=1e-11)
    # also exact in float32 inputs' sense: the naive float32 difference loses ~1e-2 m, ours does not
    naive32 = np.linalg.norm((a - x).astype(np.float32), axis=1) - np.float32(r0[0])
    assert np.max(np.abs(naive32 - ref)) > 1e-3
    assert np.max(np.abs(dr - ref)) < 1e-9


def test_farfield_phase_error_formula():
    # (4π α/c) |x|² / (2 r0): 10 GHz (419.2 rad/m), 50 m, 10 km → 419.2 · 0.125 = 52.4 rad
    assert geometry.farfield_phase_error([1e4], 10e9, 50.0) == pytest.approx(52.40, rel=1e-3)


def test_dimensionless_frequencies_wrap():
    k1, k2 = geometry.dimensionless_frequencies([10e9], [0.3], [0.5], 0.5)
    assert np.all(np.abs(k1) <= np.pi) and np.all(np.abs(k2) <= np.pi)
    kx, ky = geometry.kspace_coordinates([10e9], [0.3], [0.5])
    assert np.allclose(np.exp(1j * k1), np.exp(1j * kx * 0.5))


def test_image_sampling_is_the_nyquist_spacing_of_the_band():
    """One look along x: the band's extent in x is 4π B cos φ / c, so the spacing is the range
    resolution c / (2 B cos φ); it has no extent in y. Two looks 90° apart: the same in both axes."""
    f = np.linspace(9.5e9, 10.1e9, 64)
    el = np.radians(30.0)
    dx, dy = geometry.image_sampling(f, np.array([0.0]), np.array([el]))
    assert dx == pytest.approx(geometry.C / (2 * 0.6e9 * np.cos(el)), rel=1e-12) and dy == np.inf
    dx, dy = geometry.image_sampling(f, np.array([0.0, np.pi / 2]), np.full(2, el))
    k1 = 4 * np.pi * 10.1e9 * np.cos(el) / geometry.C
    assert dx == pytest.approx(2 * np.pi / k1, rel=1e-12) and dy == pytest.approx(dx, rel=1e-12)
