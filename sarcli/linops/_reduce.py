"""Streaming kernels for the operators and solvers (C++, ``src/native/linops.cpp``).

BLAS ``vdot`` on complex arrays is slow and thread-hungry on small shared machines, and NumPy
expressions such as ``‖a - b‖²`` allocate temporaries; these loops read their inputs once and
allocate nothing. All accumulate in float64, in blocks whose boundaries do not depend on the
thread count, so every result is the same whatever the number of threads
(:func:`sarcli._native.threads`).

Outputs come from :func:`empty`: large arrays from ``malloc`` all start at the same offset in a
page, so a loop over several of them (the g-step reads 4 and writes 6 image-sized streams) maps
every stream to the same cache set and thrashes the 8-way caches; staggering the start of each
array by a few cache lines halves the time of such loops.
"""

from __future__ import annotations

import itertools

import numpy as np

from .._native import load

_K = load("linops")

__all__ = ["empty", "rdot", "norm2", "rdot_diff", "norm2_diff", "rdot_diff2", "shrink_update",
           "diff2d_forward", "diff2d_adjoint", "diff2d_diag_forward", "diff2d_diag_adjoint",
           "axpy", "add_twice_diff", "step_dots"]

_PAGE = 4096
_STAGGER = itertools.count()


def empty(shape, dtype=np.complex128) -> np.ndarray:
    """A C-contiguous uninitialised array whose start is staggered within its page.

    Successive calls start 5 cache lines apart (cycling through 56 offsets that avoid the one
    ``malloc`` gives large blocks), so the arrays one loop streams through fall in different
    cache sets. Small arrays come from :func:`numpy.empty`.
    """
    dtype = np.dtype(dtype)
    shape = tuple(int(v) for v in (shape if np.iterable(shape) else (shape,)))
    nbytes = int(np.prod(shape)) * dtype.itemsize
    if nbytes < 64 * _PAGE:
        return np.empty(shape, dtype)
    raw = np.empty(nbytes + 2 * _PAGE, np.uint8)
    start = (-raw.ctypes.data) % _PAGE + 256 + 64 * ((5 * next(_STAGGER)) % 56)
    return raw[start:start + nbytes].view(dtype).reshape(shape)


def _flat(a):
    a = np.asarray(a)
    if a.dtype != np.complex128:
        a = a.astype(np.complex128)
    return np.ascontiguousarray(a).reshape(-1)


def rdot(x, y) -> float:
    """``Re ⟨x, y⟩ = Re Σ conj(x) y``."""
    return float(_K.rdot(_flat(x), _flat(y)))


def norm2(x) -> float:
    """``‖x‖² = Σ |x|²``."""
    return float(_K.norm2(_flat(x)))


def rdot_diff(x, a, b) -> float:
    """``Re ⟨x, a - b⟩`` without forming ``a - b``."""
    return float(_K.rdot_diff(_flat(x), _flat(a), _flat(b)))


def norm2_diff(a, b) -> float:
    """``‖a - b‖²`` without forming ``a - b``."""
    return float(_K.norm2_diff(_flat(a), _flat(b)))


def rdot_diff2(a, b, c, d) -> float:
    """``Re ⟨a - b, c - d⟩`` without temporaries."""
    return float(_K.rdot_diff2(_flat(a), _flat(b), _flat(c), _flat(d)))


def shrink_update(tf, sigma, beta: float, threshold: float, group: bool, *, w=None, g_out=None,
                  sigma_out=None):
    """Fused g-step and multiplier update of ADMM (eqs. ``eq: updateg`` and ``eq: iters``).

    ``g = shrink(Tf - σ/β, threshold)`` (grouped over axis 0 when ``group``), ``σ' = σ - β(Tf - g)``.

    Parameters
    ----------
    w : ndarray, optional
        C-contiguous complex128 array of ``tf``'s shape, filled with ``β(Tf - g) - σ'``: what the
        next gradient applies ``Tᴴ`` to (eq. ``eq: grad``), at no extra read.
    g_out, sigma_out : ndarray, optional
        Arrays (C-contiguous complex128, ``tf``'s shape) to write ``g`` and ``σ'`` into instead of
        new ones; ``sigma_out`` may be ``sigma`` itself (each entry is read before it is written).
        The outputs (with ``w``) must not overlap one another.

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
    g, sig = (empty(t2.shape) if a is None else _out(a, shape).reshape(t2.shape) for a in (g_out, sigma_out))
    w2 = None if w is None else _out(w, shape).reshape(k, -1)
    outs = [a for a in (g, sig, w2) if a is not None]
    if any(np.may_share_memory(a, b) for i, a in enumerate(outs) for b in outs[i + 1:]):
        raise ValueError("g_out, sigma_out and w must be distinct arrays")
    reg = _K.shrink_update(t2, s2, float(beta), float(threshold), g, sig, w2)
    return (g.reshape(shape) if g_out is None else g_out, sig.reshape(shape) if sigma_out is None else sigma_out,
            float(reg))


def diff2d_forward(x) -> np.ndarray:
    """Periodic first differences of a 2-D array stacked as ``(2, ny, nx)`` (rows, then columns)."""
    x = np.ascontiguousarray(x, dtype=np.complex128)
    out = empty((2,) + x.shape)
    _K.diff2d_forward(x, None, out)
    return out


def diff2d_adjoint(y) -> np.ndarray:
    """Adjoint of :func:`diff2d_forward`."""
    y = np.ascontiguousarray(y, dtype=np.complex128)
    out = empty(y.shape[1:])
    _K.diff2d_adjoint(y, None, out)
    return out


def _out(a, shape):
    if not isinstance(a, np.ndarray) or a.shape != shape or a.dtype != np.complex128 \
            or not a.flags.c_contiguous or not a.flags.writeable:
        raise ValueError(f"output arrays must be writeable C-contiguous complex128 of shape {shape}")
    return a


def diff2d_diag_forward(x, d) -> np.ndarray:
    """:func:`diff2d_forward` of ``d · x`` without forming ``d · x`` (phase-corrected TV, ``D Θ``)."""
    x = np.ascontiguousarray(x, dtype=np.complex128)
    out = empty((2,) + x.shape)
    _K.diff2d_forward(x, np.ascontiguousarray(d, dtype=np.complex128), out)
    return out


def diff2d_diag_adjoint(y, d) -> np.ndarray:
    """``conj(d) ·`` :func:`diff2d_adjoint` ``(y)`` in one pass (adjoint of :func:`diff2d_diag_forward`)."""
    y = np.ascontiguousarray(y, dtype=np.complex128)
    out = empty(y.shape[1:])
    _K.diff2d_adjoint(y, np.ascontiguousarray(d, dtype=np.complex128), out)
    return out


def axpy(x, a: float, y) -> np.ndarray:
    """``x - a y`` for a real ``a`` in one pass (a new complex128 array of ``x``'s shape)."""
    x = np.asarray(x)
    out = empty(x.shape)
    _K.axpy(_flat(x), float(a), _flat(y), out.reshape(-1))
    return out


def add_twice_diff(a, b, v) -> float:
    """``v ← 2(a - b) + v`` in place (``v`` C-contiguous complex128); returns ``‖v‖²`` after."""
    if v.dtype != np.complex128 or not v.flags.c_contiguous:
        raise ValueError("v must be a C-contiguous complex128 array")
    return float(_K.add_twice_diff(_flat(a), _flat(b), v.reshape(-1)))


def step_dots(f, f_old, gf, gf_old, atb):
    """One read of five arrays for the end of an ADMM iteration.

    Returns
    -------
    tuple of float
        ``‖f‖²``, ``‖f - f_old‖²``, ``Re⟨f - f_old, gf - gf_old⟩``, ``Re⟨f, gf⟩``, ``Re⟨f, atb⟩``.
    """
    return tuple(float(v) for v in _K.step_dots(_flat(f), _flat(f_old), _flat(gf), _flat(gf_old), _flat(atb)))
