"""The polar format algorithm's compiled gridding loop against a NumPy reference."""

from __future__ import annotations

import numpy as np
import pytest

from sarcli._native import load, threads
from sarcli.formers import pfa

RNG = np.random.default_rng(20261202)


def _samples(S, nky, nkx, width, kernel="kaiser", beta=13.0):
    u = RNG.uniform(width / 2, nkx - width / 2 - 1, S)  # every tap inside the grid
    v = RNG.uniform(width / 2, nky - width / 2 - 1, S)
    fx, tx = pfa._kernel_taps(u, kernel, width, beta)
    fy, ty = pfa._kernel_taps(v, kernel, width, beta)
    c = RNG.standard_normal(S) + 1j * RNG.standard_normal(S)
    return fx, fy, tx, ty, c


def _reference(shape, fx, fy, tx, ty, c):
    g = np.zeros(shape, complex)
    rows = fy[:, None, None] + np.arange(ty.shape[1])[None, :, None]
    cols = fx[:, None, None] + np.arange(tx.shape[1])[None, None, :]
    vals = c[:, None, None] * ty[:, :, None] * tx[:, None, :]
    np.add.at(g, (np.broadcast_to(rows, vals.shape), np.broadcast_to(cols, vals.shape)), vals)
    return g


@pytest.mark.parametrize("kernel, width", [("kaiser", 6), ("kaiser", 3), ("linear", 2)])
def test_spread_matches_numpy(kernel, width):
    shape = (37, 53)
    fx, fy, tx, ty, c = _samples(2000, *shape, width, kernel)
    g = np.full(shape, 0.5 + 0.5j)
    load("pfa").spread(g, fx, fy, tx, ty, c)
    ref = _reference(shape, fx, fy, tx, ty, c) + (0.5 + 0.5j)
    assert np.max(np.abs(g - ref)) < 1e-12 * np.max(np.abs(ref))


def test_spread_is_the_same_for_any_thread_count():
    shape = (211, 97)
    args = _samples(20000, *shape, 6)
    grids = []
    old = threads()
    try:
        for n in (1, 2, 5):
            threads(n)
            g = np.zeros(shape, complex)
            load("pfa").spread(g, *args)
            grids.append(g)
    finally:
        threads(old)
    assert all(np.array_equal(grids[0], g) for g in grids[1:])


def test_spread_refuses_taps_outside_the_grid():
    fx, fy, tx, ty, c = _samples(10, 20, 20, 6)
    fx[3] = 16
    with pytest.raises(ValueError, match="outside the grid"):
        load("pfa").spread(np.zeros((20, 20), complex), fx, fy, tx, ty, c)
