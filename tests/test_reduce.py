"""The operators' and ADMM's compiled streaming kernels (:mod:`sarcli.linops._reduce`) against NumPy.

Sizes cover a lane tail (not a multiple of 8 values), several blocks with a short last one, and a
single element; every reduction gives the same float64 for one thread and for several.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarcli._native import threads
from sarcli.linops import _reduce as R

RNG = np.random.default_rng(20261202)
SIZES = [1, 13, 3 * 8192 + 5]


def _c(*shape):
    return RNG.standard_normal(shape) + 1j * RNG.standard_normal(shape)


def _close(a, b, scale):
    return abs(a - b) <= 1e-13 * scale


@pytest.mark.parametrize("n", SIZES)
def test_reductions_match_numpy(n):
    x, y, a, b = (_c(n) for _ in range(4))
    s = np.sum(np.abs(x) ** 2) + np.sum(np.abs(y) ** 2) + np.sum(np.abs(a) ** 2) + np.sum(np.abs(b) ** 2)
    assert _close(R.rdot(x, y), np.vdot(x, y).real, s)
    assert _close(R.norm2(x), np.sum(np.abs(x) ** 2), s)
    assert _close(R.rdot_diff(x, a, b), np.vdot(x, a - b).real, s)
    assert _close(R.norm2_diff(a, b), np.sum(np.abs(a - b) ** 2), s)
    assert _close(R.rdot_diff2(x, y, a, b), np.vdot(x - y, a - b).real, s)
    f, fo, g, go, atb = x, y, a, b, _c(n)
    ref = (np.sum(np.abs(f) ** 2), np.sum(np.abs(f - fo) ** 2), np.vdot(f - fo, g - go).real,
           np.vdot(f, g).real, np.vdot(f, atb).real)
    assert all(_close(u, v, s + np.sum(np.abs(atb) ** 2)) for u, v in zip(R.step_dots(f, fo, g, go, atb), ref))


@pytest.mark.parametrize("n", SIZES)
def test_axpy_and_add_twice_diff(n):
    x, y, a, b, v = (_c(n) for _ in range(5))
    assert np.max(np.abs(R.axpy(x, 0.37, y) - (x - 0.37 * y))) < 1e-15
    ref = 2.0 * (a - b) + v
    s = R.add_twice_diff(a, b, v)
    assert np.max(np.abs(v - ref)) < 1e-14
    assert _close(s, np.sum(np.abs(ref) ** 2), np.sum(np.abs(ref) ** 2))


def test_reductions_accept_any_layout_and_real_input():
    x = _c(40, 30)
    assert _close(R.norm2(x.T), np.sum(np.abs(x) ** 2), np.sum(np.abs(x) ** 2))
    r = RNG.standard_normal(50)
    assert _close(R.rdot(r, r), r @ r, r @ r)
    with pytest.raises(ValueError, match="different sizes"):
        R.rdot(_c(5), _c(6))
    with pytest.raises(ValueError):
        R.add_twice_diff(_c(5), _c(5), _c(10)[::2])


@pytest.mark.parametrize("shape", [(1, 1), (3, 7), (130, 257)])
def test_first_differences_match_roll(shape):
    x, y, d = _c(*shape), _c(2, *shape), np.exp(1j * RNG.uniform(0, 6.3, shape))
    fwd = np.stack([np.roll(x, -1, 0) - x, np.roll(x, -1, 1) - x])
    adj = (np.roll(y[0], 1, 0) - y[0]) + (np.roll(y[1], 1, 1) - y[1])
    assert np.max(np.abs(R.diff2d_forward(x) - fwd)) < 1e-14
    assert np.max(np.abs(R.diff2d_adjoint(y) - adj)) < 1e-14
    dx = d * x
    assert np.max(np.abs(R.diff2d_diag_forward(x, d) - np.stack([np.roll(dx, -1, 0) - dx,
                                                                 np.roll(dx, -1, 1) - dx]))) < 1e-14
    assert np.max(np.abs(R.diff2d_diag_adjoint(y, d) - np.conj(d) * adj)) < 1e-14
    # adjoint pair: <D x, y> = <x, Dᴴ y>
    assert abs(np.vdot(R.diff2d_diag_forward(x, d), y) - np.vdot(x, R.diff2d_diag_adjoint(y, d))) \
        < 1e-12 * np.linalg.norm(x) * np.linalg.norm(y)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_shrink_update_matches_numpy(k):
    n = 8192 * 2 + 3
    tf, sigma = _c(k, n), _c(k, n)
    beta, thr = 1.3, 1.1
    v = tf - sigma / beta
    m = np.sqrt(np.sum(np.abs(v) ** 2, axis=0))
    g = v * np.where(m > thr, (m - thr) / np.where(m > 0, m, 1.0), 0.0)
    sig = sigma - beta * (tf - g)
    w = R.empty(tf.shape)
    g_k, sig_k, reg = R.shrink_update(tf, sigma, beta, thr, True, w=w)
    assert np.max(np.abs(g_k - g)) < 1e-14 and np.max(np.abs(sig_k - sig)) < 1e-13
    assert np.max(np.abs(w - (beta * (tf - g) - sig))) < 1e-13
    assert reg == pytest.approx(np.sum(np.sqrt(np.sum(np.abs(tf) ** 2, axis=0))), rel=1e-13)
    # σ' written over σ: every entry read before it is written
    s_in = sigma.copy()
    g2, s2, reg2 = R.shrink_update(tf, s_in, beta, thr, True, sigma_out=s_in)
    assert s2 is s_in and np.array_equal(s2, sig_k) and np.array_equal(g2, g_k) and reg2 == reg


def test_results_do_not_depend_on_the_thread_count():
    n = 5 * 8192 + 77
    x, y, a, b, c = (_c(n) for _ in range(5))
    tf, sigma = _c(2, n), _c(2, n)
    img = _c(300, 301)

    def run():
        return (R.rdot(x, y), R.norm2(x), R.rdot_diff2(x, y, a, b), R.step_dots(x, y, a, b, c),
                R.shrink_update(tf, sigma, 0.9, 0.8, True)[2], R.diff2d_forward(img).tobytes())

    old = threads()
    try:
        threads(1)
        one = run()
        threads(3)
        several = run()
    finally:
        threads(old)
    assert one == several


def test_shrink_update_refuses_overlapping_outputs():
    tf, sigma = _c(2, 50), _c(2, 50)
    out = R.empty(tf.shape)
    with pytest.raises(ValueError, match="distinct"):
        R.shrink_update(tf, sigma, 1.0, 0.5, True, g_out=out, sigma_out=out)
    with pytest.raises(ValueError, match="distinct"):
        R.shrink_update(tf, sigma, 1.0, 0.5, True, w=out, g_out=out)
