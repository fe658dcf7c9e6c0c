"""Complex shrinkage: the exact g-update of ADMM (paper Proposition in section ``sec: g``)."""

from __future__ import annotations

import numpy as np

__all__ = ["shrink", "complex_shrinkage"]


def shrink(z, threshold, *, group_axis: int | None = None) -> np.ndarray:
    """Soft-threshold complex values: ``max(|z| - t, 0) · z / |z|`` (0 where ``z = 0``).

    Parameters
    ----------
    z : ndarray, complex or real
    threshold : float
        ``t ≥ 0``.
    group_axis : int, optional
        Shrink the vectors along this axis by their Euclidean norm (isotropic TV: the vector of
        differences at each pixel); default: every entry on its own (anisotropic, ℓ1).

    Returns
    -------
    ndarray
        Same shape and dtype as ``z``.
    """
    z = np.asarray(z)
    if group_axis is None:
        mag = np.abs(z)
    else:
        mag = np.sqrt(np.sum(z.real**2 + z.imag**2, axis=group_axis, keepdims=True)) \
            if np.iscomplexobj(z) else np.sqrt(np.sum(z**2, axis=group_axis, keepdims=True))
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.maximum(mag - threshold, 0.0) / mag
    factor = np.where(mag > 0, factor, 0.0)
    return z * factor


def complex_shrinkage(z0, sigma, beta: float, lam: float = 1.0, *, group_axis=None) -> np.ndarray:
    """Minimiser of ``β/2 |z - z0|² + λ|z| + Re(conj(σ) z)`` (eq. ``eq: updateg``).

    ``z = max(|z0 - σ/β| - λ/β, 0) · sign(z0 - σ/β)``; with ``group_axis`` the same for the
    Euclidean norm of vectors (isotropic TV).
    """
    return shrink(np.asarray(z0) - np.asarray(sigma) / beta, lam / beta, group_axis=group_axis)
