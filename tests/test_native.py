"""The compiled kernels' runtime and the simulator's kernel against a NumPy reference."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from sarcli._native import load, simd_level, threads
from sarcli.core.geometry import C


def _reference_sum(freq, antenna, offset, xy, amp):
    pts = np.column_stack([xy, np.zeros(len(xy))])
    dist = np.linalg.norm(antenna[:, None, :] - pts[None, :, :], axis=2)      # [P, S]
    dr = dist - np.linalg.norm(antenna, axis=1)[:, None] + offset[:, None]
    ph = np.exp(-1j * 4 * np.pi * freq[:, :, None] * dr[:, None, :] / C)      # [P, M, S]
    return ph @ amp


@pytest.mark.parametrize("uniform", [True, False])
def test_spherical_sum_matches_numpy(uniform):
    rng = np.random.default_rng(3)
    P, M, S = 7, 150, 5
    f = 9.6e9 + 2e6 * np.arange(M)
    if not uniform:
        f = f + rng.uniform(-5e5, 5e5, M)
    freq = np.tile(f, (P, 1)) + 1e6 * np.arange(P)[:, None]
    ang = np.deg2rad(np.linspace(-2, 2, P))
    antenna = np.column_stack([1e4 * np.cos(ang), 1e4 * np.sin(ang), np.full(P, 3e3)])
    offset = rng.uniform(-1, 1, P)
    xy = rng.uniform(-20, 20, (S, 2))
    amp = rng.standard_normal(S) + 1j * rng.standard_normal(S)
    out = np.full((P, M), 0.5 + 0.25j)
    load("simulate").spherical_sum(freq, antenna, offset, xy, amp, out)
    ref = _reference_sum(freq, antenna, offset, xy, amp) + (0.5 + 0.25j)
    err = np.max(np.abs(out - ref)) / np.max(np.abs(ref))
    # the reference's own rounding (|a - x| taken directly, ~1e4 m) is ~1e-12 rad per 1e4 rad
    assert err < 1e-9


def test_spherical_sum_rejects_inconsistent_shapes():
    z = np.zeros((2, 3))
    with pytest.raises(ValueError, match="inconsistent shapes"):
        load("simulate").spherical_sum(z, np.zeros((3, 3)), np.zeros(2), np.zeros((1, 2)),
                                       np.ones(1, complex), np.zeros((2, 3), complex))


def test_thread_count_is_per_calling_thread():
    seen = {}

    def worker():
        seen["set"] = threads(1)

    before = threads()
    t = threading.Thread(target=worker)
    t.start()
    t.join()
    assert seen["set"] == 1
    assert threads() == before


def test_simd_level_is_named():
    assert simd_level() in ("avx512", "avx2", "baseline")


def test_missing_family_says_how_to_build():
    with pytest.raises(ImportError, match="make setup"):
        load("no_such_family")
