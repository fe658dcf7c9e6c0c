"""FINUFFT's spreading kernel outside FINUFFT: its values, per-point weights and Fourier series.

The warped operator (:mod:`sarcli.linops.warped`) spreads pixels onto uniform grids with
FINUFFT's exponential-of-semicircle kernel φ (Barnett, Magland & af Klinteberg 2019) at σ = 2.
Its Gram repeats the same spreading hundreds of times on the same points, so the kernel's weights
are computed once per point here (read back from FINUFFT itself, so they are its kernel) and the
spreading runs in a compiled loop (``sarcli._native._spread``). The deconvolution of a spread grid
needs the kernel's Fourier series, :func:`kernel_series`.
"""

from __future__ import annotations

import functools

import finufft
import numpy as np

from .._native import load

__all__ = ["SIGMA", "kernel_table", "kernel_weights", "kernel_series"]

#: Grid oversampling over the band (FINUFFT's kernel is designed for it).
SIGMA = 2.0


@functools.lru_cache(maxsize=8)
def kernel_table(eps: float, per_unit: int = 8192) -> tuple[int, np.ndarray, np.ndarray]:
    """FINUFFT's spreading kernel at ``eps`` (σ = 2), read back from its interpolator: its taps
    ``w`` and its values ``φ(z)`` at ``z = −w/2 … w/2`` (node minus point) in steps of ``1/per_unit`` grid cells
    (linear interpolation between them is exact to ~4e-8 of the peak). Cached (the arrays read-only)."""
    n, reach = 64, 8
    z = np.arange(-reach * per_unit, reach * per_unit + 1) / per_unit
    delta = np.zeros(n, np.complex128)
    delta[n // 2] = 1.0
    v = finufft.nufft1d2(2 * np.pi * (n // 2 + z) / n - np.pi, delta, eps=eps, spreadinterponly=1,
                         upsampfac=SIGMA, modeord=0).real
    v = v[::-1]  # v was φ(node − point) at node − point = −z
    support = z[v != 0]
    taps = int(round(support[-1] - support[0]))
    keep = np.abs(z) <= taps / 2
    z, v = z[keep], v[keep]
    z.flags.writeable = v.flags.writeable = False
    return taps, z, v


def kernel_weights(x: np.ndarray, table) -> tuple[np.ndarray, np.ndarray]:
    """The first node ``⌈x − w/2⌉`` (int32) and the ``w`` kernel weights ``φ(node + j − x)``
    (float32, ``[len(x), w]``) of points at grid coordinates ``x`` (:func:`kernel_table`,
    interpolated linearly; compiled: ``sarcli._native._spread``)."""
    taps, z, v = table
    x = np.ascontiguousarray(x, np.float64)
    first, w = np.empty(x.size, np.int32), np.empty((x.size, taps), np.float32)
    load("spread").kernel_weights(x, taps, np.ascontiguousarray(v, np.float64), float(z[0]),
                                          float((z[-1] - z[0]) / (z.size - 1)), first, w)
    return first, w


def kernel_series(eps: float, t: np.ndarray) -> np.ndarray:
    """``Φ̂(t) = Σ_j φ(j) e^{i t j}``: the Fourier series of FINUFFT's spreading kernel sampled at the
    grid nodes around a point on a node (:func:`kernel_table` at the integers), at ``t``; real
    (the values are real and the sum is taken as cosines)."""
    taps, z, v = kernel_table(eps)
    per_unit = int(round(1.0 / (z[1] - z[0])))
    j = np.arange(-(taps // 2), taps // 2 + 1)
    at = np.round((j - z[0]) * per_unit).astype(int)
    inside = (at >= 0) & (at < z.size)
    phi = np.where(inside, v[np.clip(at, 0, z.size - 1)], 0.0)
    return np.cos(np.multiply.outer(np.asarray(t, np.float64), j)) @ phi
