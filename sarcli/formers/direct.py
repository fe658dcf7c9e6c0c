"""The exact matched filter (paper eq. ``mf``), the reference every faster former is measured against.

``f(x) = (1/W) Σ_p Σ_j w_pj d[p, j] e_pj(x)`` with ``e_pj(x) = exp(+i k_pj ξ_θp·x)`` (far-field) or
``exp(+i (4π α_pj / c)(|a_p - x| - r0_p))`` (spherical) and ``W = Σ w_pj`` (docs/conventions.md), so a
unit point scatterer gives a peak of 1 at its own position. Phases are float64 throughout.
"""

from __future__ import annotations

import numpy as np

from ..core import geometry, sampling
from .._util.progress import progress
from ._samples import WeightedSamples, check_kspace, weighted_samples

__all__ = ["weighted_samples", "direct_farfield", "direct_spherical", "direct_points"]

#: complex128 elements a chunk of the far-field exponentials may hold (~32 MiB each)
_FARFIELD_BUDGET = 1 << 21
#: float64 pulse x pixel elements a chunk of spherical ranges may hold (~32 MiB)
_SPHERICAL_BUDGET = 1 << 22
#: pulse x frequency x pixel terms one compiled call may sum (one step of the progress bar)
_SPHERICAL_WORK = 1 << 27


def _kernel():
    from .._native import load

    return load("direct")


def direct_farfield(data, kx, ky, grid, weights=None, *, chunk=None) -> np.ndarray:
    """Exact far-field matched filter on a grid (eq. ``mf`` with ``e = exp(+i k ξ_θ·x)``).

    The exponential is separable, ``exp(i (kx x + ky y)) = exp(i kx x) exp(i ky y)``, so each
    chunk of S samples costs one matrix product ``Ey^T · diag(w d) · Ex`` with
    ``Ex = exp(i kx x)`` [S, nx] and ``Ey = exp(i ky y)`` [S, ny]; memory is bounded by the chunk.

    Parameters
    ----------
    data : array_like, shape (P, M)
        Phase history.
    kx, ky : array_like, shape (P, M)
        k-space coordinates (rad/m) from :func:`sarcli.core.geometry.kspace_coordinates`.
    grid : sarcli.core.grid.Grid
        Output pixel grid.
    weights : array_like, shape (P, M), optional
        Window weights (:func:`sarcli.core.windows.window_weights`).
    chunk : int, optional
        Samples per matrix product; default keeps each exponential block near 32 MiB.

    Returns
    -------
    image : ndarray, shape (ny, nx), complex128
    """
    wd, total = weighted_samples(data, weights)
    kx, ky = check_kspace(wd.shape, kx, ky)
    x, y = grid.x, grid.y
    c, kxf, kyf = wd.ravel(), kx.ravel(), ky.ravel()
    n = c.size
    if chunk is None:
        chunk = max(1, _FARFIELD_BUDGET // (x.size + y.size))
    chunk = max(1, int(chunk))
    image = np.zeros((y.size, x.size), dtype=np.complex128)
    starts = range(0, n, chunk)
    for s in progress(starts, total=len(starts), desc="direct far-field", unit="chunk"):
        sl = slice(s, min(s + chunk, n))
        ex = np.exp(1j * (kxf[sl, None] * x[None, :]))  # [S, nx], float64 phase
        ey = np.exp(1j * (kyf[sl, None] * y[None, :]))  # [S, ny]
        image += ey.T @ (c[sl, None] * ex)
    return image / total


def direct_spherical(data, freq_hz, antenna_position_m, range_to_center_m, grid, weights=None, *,
                     chunk=None, receive_position_m=None) -> np.ndarray:
    """Exact spherical-wave matched filter (eq. ``mf`` with the exact range of every pixel).

    ``f(x) = (1/W) Σ_pj w_pj d[p, j] exp(+i (4π α_pj / c)(|a_p - x| - r0_p))``, the differential
    range from :func:`sarcli.core.geometry.differential_range` (cancellation-free), the phase in
    float64, summed by a compiled loop over chunks of pulses so memory stays bounded
    (``src/native/direct.cpp``: threads over pixels, vectors over groups of 8 pixels, each term's
    cosine and sine within 2 ulp, no reassociation).

    Parameters
    ----------
    data : array_like, shape (P, M)
    freq_hz : array_like, shape (M,) or (P, M)
        Frequencies α (Hz).
    antenna_position_m : array_like, shape (P, 3)
    range_to_center_m : array_like, shape (P,)
    grid : sarcli.core.grid.Grid
        Output grid (pixels in the plane z = 0).
    weights : array_like, shape (P, M), optional
    chunk : int, optional
        Pulses per chunk; default keeps the range block near 32 MiB.
    receive_position_m : array_like, shape (P, 3), optional
        Separate receive positions q_p: then ``antenna_position_m`` holds the transmit positions
        t_p and the range is ``(|t_p - x| + |q_p - x|)/2 - r0_p``
        (:func:`sarcli.core.geometry.bistatic_differential_range`).

    Returns
    -------
    image : ndarray, shape (ny, nx), complex128
    """
    return direct_points(data, freq_hz, antenna_position_m, range_to_center_m, grid.points(), weights,
                         chunk=chunk, receive_position_m=receive_position_m)


def direct_points(data, freq_hz, antenna_position_m, range_to_center_m, points_m, weights=None, *,
                  chunk=None, receive_position_m=None) -> np.ndarray:
    """:func:`direct_spherical` at pixels anywhere in 3-D: ``points_m`` (..., 3) in the local frame
    (a map grid on terrain, :mod:`sarcli.formers.points`); returns shape ``points_m.shape[:-1]``."""
    wd = WeightedSamples(data, weights)  # read by blocks of pulses when the data are on disk
    total = wd.total
    n_p, n_f = wd.shape
    a_rcv = None
    if receive_position_m is not None:
        a_rcv = np.asarray(receive_position_m, dtype=np.float64)
        if a_rcv.shape != (n_p, 3):
            raise ValueError(f"receive positions {a_rcv.shape} do not match {n_p} pulses")
    a = np.asarray(antenna_position_m, dtype=np.float64)
    r0 = np.asarray(range_to_center_m, dtype=np.float64)
    if a.shape != (n_p, 3) or r0.shape != (n_p,):
        raise ValueError(f"antenna positions {a.shape} / ranges {r0.shape} do not match {n_p} pulses")
    freq = np.asarray(freq_hz, dtype=np.float64)
    if freq.shape not in ((n_f,), (n_p, n_f)):
        raise ValueError(f"frequencies of shape {freq.shape} do not match the data {wd.shape}")
    k4 = np.ascontiguousarray(np.broadcast_to(sampling.range_wavenumbers(freq), (n_p, n_f)))
    pts_in = np.asarray(points_m, dtype=np.float64)
    pts = pts_in.reshape(-1, 3)
    n_pix = pts.shape[0]
    if chunk is None:
        chunk = max(1, min(_SPHERICAL_BUDGET // n_pix, _SPHERICAL_WORK // max(1, n_pix * n_f)))
    chunk = max(1, int(chunk))
    out = np.zeros(n_pix, dtype=np.complex128)
    starts = range(0, n_p, chunk)
    for s in progress(starts, total=len(starts), desc="direct spherical", unit="chunk"):
        sl = slice(s, min(s + chunk, n_p))
        if a_rcv is None:
            dr = geometry.differential_range(a[sl], r0[sl], pts)
        else:
            dr = geometry.bistatic_differential_range(a[sl], a_rcv[sl], r0[sl], pts)
        dr = np.ascontiguousarray(dr)
        wd_sl, k4_sl = np.ascontiguousarray(wd[sl]), k4[sl]
        _kernel().accumulate_spherical(out, dr, k4_sl, wd_sl)
    return (out / total).reshape(pts_in.shape[:-1])
