"""Compiled streaming kernels for the operators and solvers (numba).

BLAS ``vdot`` on complex arrays is slow and thread-hungry on small shared machines, and NumPy
expressions such as ``‖a - b‖²`` allocate temporaries; these loops read their inputs once and
allocate nothing. All accumulate in float64.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["rdot", "norm2", "rdot_diff", "norm2_diff", "rdot_diff2", "shrink_update",
           "diff2d_forward", "diff2d_adjoint"]

_JIT = dict(cache=True, nogil=True)


@numba.njit(**_JIT)
def _rdot(x, y):  # pragma: no cover - compiled
    s = 0.0
    for i in range(x.size):
        s += x[i].real * y[i].real + x[i].imag * y[i].imag
    return s


@numba.njit(**_JIT)
def _norm2(x):  # pragma: no cover - compiled
    s = 0.0
    for i in range(x.size):
        s += x[i].real * x[i].real + x[i].imag * x[i].imag
    return s


@numba.njit(**_JIT)
def _rdot_diff(x, a, b):  # pragma: no cover - compiled
    s = 0.0
    for i in range(x.size):
        d = a[i] - b[i]
        s += x[i].real * d.real + x[i].imag * d.imag
    return s


@numba.njit(**_JIT)
def _norm2_diff(a, b):  # pragma: no cover - compiled
    s = 0.0
    for i in range(a.size):
        d = a[i] - b[i]
        s += d.real * d.real + d.imag * d.imag
    return s


@numba.njit(**_JIT)
def _rdot_diff2(a, b, c, d):  # pragma: no cover - compiled
    s = 0.0
    for i in range(a.size):
        u = a[i] - b[i]
        v = c[i] - d[i]
        s += u.real * v.real + u.imag * v.imag
    return s


@numba.njit(**_JIT)
def _shrink_update(tf, sigma, beta, thr, g, sig_out):  # pragma: no cover - compiled
    K, n = tf.shape
    reg = 0.0
    inv_beta = 1.0 / beta
    for i in range(n):
        s2 = 0.0
        v2 = 0.0
        for k in range(K):
            t = tf[k, i]
            v = t - sigma[k, i] * inv_beta
            s2 += t.real * t.real + t.imag * t.imag
            v2 += v.real * v.real + v.imag * v.imag
        reg += math.sqrt(s2)
        m = math.sqrt(v2)
        fac = (m - thr) / m if m > thr else 0.0
        for k in range(K):
            t = tf[k, i]
            gk = (t - sigma[k, i] * inv_beta) * fac
            g[k, i] = gk
            sig_out[k, i] = sigma[k, i] - beta * (t - gk)
    return reg


@numba.njit(**_JIT)
def _diff2d_forward(x, out):  # pragma: no cover - compiled
    ny, nx = x.shape
    for r in range(ny):
        rn = r + 1 if r + 1 < ny else 0
        for c in range(nx):
            cn = c + 1 if c + 1 < nx else 0
            v = x[r, c]
            out[0, r, c] = x[rn, c] - v
            out[1, r, c] = x[r, cn] - v


@numba.njit(**_JIT)
def _diff2d_adjoint(y, out):  # pragma: no cover - compiled
    _, ny, nx = y.shape
    for r in range(ny):
        rp = r - 1 if r > 0 else ny - 1
        for c in range(nx):
            cp = c - 1 if c > 0 else nx - 1
            out[r, c] = (y[0, rp, c] - y[0, r, c]) + (y[1, r, cp] - y[1, r, c])


def _flat(a):
    a = np.asarray(a)
    if a.dtype != np.complex128:
        a = a.astype(np.complex128)
    return np.ascontiguousarray(a).reshape(-1)


def rdot(x, y) -> float:
    """``Re ⟨x, y⟩ = Re Σ conj(x) y``."""
    return float(_rdot(_flat(x), _flat(y)))


def norm2(x) -> float:
    """``‖x‖² = Σ |x|²``."""
    return float(_norm2(_flat(x)))


def rdot_diff(x, a, b) -> float:
    """``Re ⟨x, a - b⟩`` without forming ``a - b``."""
    return float(_rdot_diff(_flat(x), _flat(a), _flat(b)))


def norm2_diff(a, b) -> float:
    """``‖a - b‖²`` without forming ``a - b``."""
    return float(_norm2_diff(_flat(a), _flat(b)))


def rdot_diff2(a, b, c, d) -> float:
    """``Re ⟨a - b, c - d⟩`` without temporaries."""
    return float(_rdot_diff2(_flat(a), _flat(b), _flat(c), _flat(d)))


def shrink_update(tf, sigma, beta: float, threshold: float, group: bool):
    """Fused g-step and multiplier update of ADMM (eqs. ``eq: updateg`` and ``eq: iters``).

    ``g = shrink(Tf - σ/β, threshold)`` (grouped over axis 0 when ``group``), ``σ' = σ - β(Tf - g)``.

    Returns
    -------
    g, sigma_new : ndarray
        Shape of ``tf``.
    reg : float
        ``‖Tf‖₁`` (grouped: sum of the per-pixel vector norms).
    """
    tf = np.ascontiguousarray(tf, dtype=np.complex128)
    sigma = np.ascontiguousarray(sigma, dtype=np.complex128)
    shape = tf.shape
    k = shape[0] if (group and tf.ndim > 1) else 1
    t2, s2 = tf.reshape(k, -1), sigma.reshape(k, -1)
    g = np.empty_like(t2)
    sig = np.empty_like(s2)
    reg = _shrink_update(t2, s2, float(beta), float(threshold), g, sig)
    return g.reshape(shape), sig.reshape(shape), float(reg)


def diff2d_forward(x) -> np.ndarray:
    """Periodic first differences of a 2-D array stacked as ``(2, ny, nx)`` (rows, then columns)."""
    x = np.ascontiguousarray(x, dtype=np.complex128)
    out = np.empty((2,) + x.shape, np.complex128)
    _diff2d_forward(x, out)
    return out


def diff2d_adjoint(y) -> np.ndarray:
    """Adjoint of :func:`diff2d_forward`."""
    y = np.ascontiguousarray(y, dtype=np.complex128)
    out = np.empty(y.shape[1:], np.complex128)
    _diff2d_adjoint(y, out)
    return out
