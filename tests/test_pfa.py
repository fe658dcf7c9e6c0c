"""The polar format algorithm's compiled gridding loop and its kernel taps against NumPy."""

from __future__ import annotations

import numpy as np
import pytest

from sarcli._native import load, threads
from sarcli.formers import pfa

RNG = np.random.default_rng(20261202)
K = load("pfa")


def _taps(u, kernel, width, beta):
    """First grid index and taps [S, width] of the kernel centred at fractional indices u."""
    first = np.floor(u - width / 2.0).astype(np.int64) + 1
    offs = first[:, None] + np.arange(width)[None, :] - u[:, None]  # in (-w/2, w/2]
    if kernel == "linear":
        return first, np.maximum(0.0, 1.0 - np.abs(offs))
    return first, np.i0(beta * np.sqrt(np.clip(1.0 - (2.0 * offs / width) ** 2, 0.0, None)))


def _positions(S, nky, nkx, width):
    u = RNG.uniform(width / 2, nkx - width / 2 - 1, S)  # every tap inside the grid
    v = RNG.uniform(width / 2, nky - width / 2 - 1, S)
    return u, v, RNG.standard_normal(S) + 1j * RNG.standard_normal(S)


def _reference(shape, u, v, c, kernel, width, beta):
    fx, tx = _taps(u, kernel, width, beta)
    fy, ty = _taps(v, kernel, width, beta)
    g = np.zeros(shape, complex)
    rows = fy[:, None, None] + np.arange(width)[None, :, None]
    cols = fx[:, None, None] + np.arange(width)[None, None, :]
    vals = c[:, None, None] * ty[:, :, None] * tx[:, None, :]
    np.add.at(g, (np.broadcast_to(rows, vals.shape), np.broadcast_to(cols, vals.shape)), vals)
    return g


CASES = [("kaiser", 6, pfa._kaiser_beta(6, 2.0)), ("kaiser", 3, pfa._kaiser_beta(3, 1.25)),
         ("kaiser", 16, pfa._kaiser_beta(16, 2.0)), ("linear", 2, 0.0)]


@pytest.mark.parametrize("kernel, width, beta", CASES)
def test_kernel_taps_match_numpy(kernel, width, beta):
    u = np.concatenate([RNG.uniform(-50, 50, 3000), np.arange(-3, 4) * 0.5])
    first, taps = np.empty(u.size, np.int64), np.empty((u.size, width))
    K.kernel_taps(u, kernel, width, beta, first, taps)
    ref_first, ref = _taps(u, kernel, width, beta)
    assert np.array_equal(first, ref_first)
    assert np.max(np.abs(taps - ref) / np.max(ref)) < 1e-14


@pytest.mark.parametrize("kernel, width, beta", CASES)
def test_spread_matches_numpy(kernel, width, beta):
    shape = (37, 53)
    u, v, c = _positions(2000, *shape, width)
    g = np.full(shape, 0.5 + 0.5j)
    K.spread(g, u, v, c, kernel, width, beta)
    ref = _reference(shape, u, v, c, kernel, width, beta) + (0.5 + 0.5j)
    # measured 6.1e-16, 4.7e-16, 1.2e-15, 2.1e-16 (kaiser 6, 3, 16, linear) of the peak
    assert np.max(np.abs(g - ref)) < 5e-15 * np.max(np.abs(ref))


def test_spread_is_the_same_for_any_thread_count():
    shape = (211, 97)
    u, v, c = _positions(20000, *shape, 6)
    grids = []
    old = threads()
    try:
        for n in (1, 2, 5):
            threads(n)
            g = np.zeros(shape, complex)
            K.spread(g, u, v, c, "kaiser", 6, 13.0)
            grids.append(g)
    finally:
        threads(old)
    assert all(np.array_equal(grids[0], g) for g in grids[1:])


def test_spread_refuses_bad_input():
    u, v, c = _positions(10, 20, 20, 6)
    g = np.zeros((20, 20), complex)
    u[3] = 17.5
    with pytest.raises(ValueError, match="outside the grid"):
        K.spread(g, u, v, c, "kaiser", 6, 13.0)
    u[3] = np.nan
    with pytest.raises(ValueError, match="not finite"):
        K.spread(g, u, v, c, "kaiser", 6, 13.0)
    with pytest.raises(ValueError, match="kernel"):
        K.spread(g, v, v, c, "gauss", 6, 13.0)
    assert not g.any()


def test_next_fast_len_is_scipys():
    from scipy.fft import next_fast_len

    assert all(pfa._next_fast_len(n) == next_fast_len(n) for n in list(range(1, 2000)) + [65537, 99991])
