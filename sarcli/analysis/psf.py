"""The point spread function of the matched filter (Theorem ``main-theorem``) and its IPR figures.

Theorem ``main-theorem`` (eqs. ``H-kernel``, ``main-2D-conv``): for frequencies equally spaced per
pulse, the far-field matched filter is the convolution ``f_MF = f * K / (M P)`` with

    K(x) = Σ_θ H(ξ_θ · x),   H(t) = e^{i K_c t} sin(M Δk t / 2) / sin(Δk t / 2),

``K_c = (k_1 + k_M) / 2`` and ``Δk`` the wavenumber step of the pulse (both per pulse here, so a
varying elevation is allowed). Normalised by ``1/(M P)`` it *is* the matched-filter image of a
unit point (docs/conventions.md), peak 1 at the point. With window weights ``w_pj`` no closed form
exists; the kernel is then the weighted sum ``Σ w_pj e^{i k_pj ξ_θp·x} / W``, computed exactly
(a matrix product of the separable phases) or with a type-1 NUFFT (FINUFFT, tolerance 1e-12).

Public API
----------
psf_kernel(acq_or_arrays, grid, *, weights=None, center=(0, 0), method='auto') -> ndarray
grid_method(acq_or_arrays, grid, *, weights=None, center=(0, 0), method='auto') -> str
psf_image(acq, grid=None, *, window='none', nbar=4, sll_db=-35, center=None, method='auto') -> Image
kernel_at(acq_or_arrays, points_m, *, weights=None, center=(0, 0), method='auto') -> ndarray
dirichlet_ratio(u, m) -> ndarray
predicted_ipr(acq, *, window='none', ...) -> dict
"""

from __future__ import annotations

import math

import numpy as np

from ..core import geometry
from ..core.acquisition import Acquisition
from ..errors import SarcliInputError
from ..core.grid import Grid
from .._util.progress import progress
from ..core.windows import IRW_FACTOR_UNIFORM
from .ipr import ISLR_DEFINITION, center_azimuth, profile_metrics, window_textbook

__all__ = ["psf_kernel", "grid_method", "kernel_at", "dirichlet_ratio", "theorem_parameters", "predicted_ipr",
           "psf_image", "window_weights_for"]

_CHUNK_ELEMENTS = 4_000_000  # complex elements per temporary block (64 MB)


# --------------------------------------------------------------------------------------------
# the 1-D kernel
# --------------------------------------------------------------------------------------------
def dirichlet_ratio(u, m: int) -> np.ndarray:
    """``sin(m u) / sin(u)`` evaluated stably, with its limit at the zeros of ``sin u``.

    The argument is reduced exactly as ``u = nπ + r`` with ``|r| <= π/2``; then
    ``sin(m u)/sin(u) = (-1)^{n(m-1)} sin(m r)/sin(r)``, and for ``|r| < 1e-8`` the series
    ``m (1 - (m² - 1) r² / 6)`` replaces the quotient (so ``u = nπ`` gives ``±m``, never 0/0).

    Parameters
    ----------
    u : array_like
        Half the phase step, ``Δk t / 2`` (float64).
    m : int
        Number of terms M.

    Returns
    -------
    ndarray, float64
    """
    u = np.asarray(u, dtype=np.float64)
    n = np.rint(u / np.pi)
    r = u - n * np.pi
    sign = np.where(np.mod(n * (m - 1), 2) == 0, 1.0, -1.0)
    small = np.abs(r) < 1e-8
    safe = np.where(small, 1.0, r)
    ratio = np.where(small, m * (1.0 - (m * m - 1.0) * r * r / 6.0), np.sin(m * safe) / np.sin(safe))
    return sign * ratio


def _as_arrays(acq_or_arrays):
    """(freq_hz, azimuth_rad, elevation_rad) from an Acquisition or a 3-tuple."""
    if isinstance(acq_or_arrays, Acquisition):
        a = acq_or_arrays
        return a.frequency_hz, a.azimuth_rad, a.elevation_rad
    try:
        freq, az, el = acq_or_arrays
    except (TypeError, ValueError):
        raise SarcliInputError("expected an Acquisition or (frequency_hz, azimuth_rad, elevation_rad)") from None
    az = np.atleast_1d(np.asarray(az, dtype=np.float64))
    el = np.broadcast_to(np.asarray(el, dtype=np.float64), az.shape)
    return np.asarray(freq, dtype=np.float64), az, el


def theorem_parameters(freq_hz, elevation_rad):
    """Per-pulse parameters of ``H`` (eq. ``H-kernel``) and how far the frequencies are from equal spacing.

    Returns
    -------
    k_center : ndarray (P,)
        ``K_c = (k_1 + k_M) / 2`` (rad/m).
    dk : ndarray (P,)
        ``Δk = (k_M - k_1) / (M - 1)`` (0 for M = 1).
    m : int
        M.
    deviation : float
        ``max |k_pj - (k_p1 + j Δk_p)|`` (rad/m): 0 for exactly equal spacing.
    """
    k = geometry.wavenumbers(freq_hz, elevation_rad)
    m = k.shape[1]
    k_center = 0.5 * (k[:, 0] + k[:, -1])
    dk = (k[:, -1] - k[:, 0]) / (m - 1) if m > 1 else np.zeros(k.shape[0])
    lin = k[:, :1] + np.arange(m)[None, :] * dk[:, None]
    return k_center, dk, m, float(np.max(np.abs(k - lin)))


# --------------------------------------------------------------------------------------------
# the 2-D kernel at points
# --------------------------------------------------------------------------------------------
def _theorem(freq, az, el, xr, yr):
    """Σ_p H_p(ξ_p·x) / (M P) at relative coordinates xr, yr (any equal shapes)."""
    kc, dk, m, _ = theorem_parameters(freq, el)
    out = np.zeros(xr.shape, dtype=np.complex128)
    c, s = np.cos(az), np.sin(az)
    for p in progress(range(az.size), desc="psf (theorem)", unit="pulse"):
        t = c[p] * xr + s[p] * yr
        out += np.exp(1j * (kc[p] * t)) * dirichlet_ratio(0.5 * dk[p] * t, m)
    return out / (m * az.size)


def _direct(freq, az, el, weights, xr, yr):
    """Σ_pj w_pj exp(i k_pj ξ_p·x) / W at relative coordinates (exact, chunked over pulses)."""
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    w = weights
    shape = xr.shape
    xf, yf = xr.ravel(), yr.ravel()
    out = np.zeros(xf.size, dtype=np.complex128)
    per = max(1, _CHUNK_ELEMENTS // max(1, xf.size * kx.shape[1]))
    for p0 in progress(range(0, az.size, per), desc="psf (direct)", unit="block"):
        sl = slice(p0, p0 + per)
        ph = kx[sl].reshape(-1, 1) * xf[None, :] + ky[sl].reshape(-1, 1) * yf[None, :]
        out += w[sl].reshape(-1) @ np.exp(1j * ph)
    return (out / np.sum(w)).reshape(shape)


def _weighted_cut(freq, az, el, weights, theta, step, n_half):
    """Σ w_pj e^{i k_pj ξ_p·(j step u)} / W for j = -n_half..n_half, u = (cos θ, sin θ).

    A 1-D type-1 NUFFT (FINUFFT, tolerance 1e-12): the cut is uniform, so the phases
    ``κ step j`` with ``κ = k ξ_p·u`` are exact after wrapping ``κ step`` into [-π, π).
    """
    import finufft

    kx, ky = geometry.kspace_coordinates(freq, az, el)
    kappa = (kx * math.cos(theta) + ky * math.sin(theta)).ravel() * step
    x = geometry.wrap_phase(kappa)
    w = np.asarray(weights, dtype=np.float64).ravel()
    out = finufft.nufft1d1(x, w.astype(np.complex128), 2 * n_half + 1, isign=1, eps=1e-12)
    return out / np.sum(w)


def _direct_grid(freq, az, el, weights, grid: Grid, center):
    """Separable exact sum on a grid: image = Vᵀ diag(w) U / W, chunked over samples."""
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    kx, ky, w = kx.ravel(), ky.ravel(), weights.ravel()
    xr = grid.x - float(center[0])
    yr = grid.y - float(center[1])
    out = np.zeros(grid.shape, dtype=np.complex128)
    per = max(1, _CHUNK_ELEMENTS // max(grid.nx, grid.ny))
    for s0 in progress(range(0, kx.size, per), desc="psf (direct)", unit="block"):
        sl = slice(s0, s0 + per)
        u = np.exp(1j * (kx[sl, None] * xr[None, :]))          # (S, nx)
        v = np.exp(1j * (ky[sl, None] * yr[None, :])) * w[sl, None]  # (S, ny)
        out += v.T @ u
    return out / np.sum(w)


def _nufft_grid(freq, az, el, weights, grid: Grid, center):
    """Type-1 NUFFT (FINUFFT, eps 1e-12) of the weighted samples onto the grid."""
    import finufft

    kx, ky = geometry.kspace_coordinates(freq, az, el)
    kx, ky, w = kx.ravel(), ky.ravel(), weights.ravel()
    # x = cx + n dx: exp(i kx (x - px)) = exp(i kx (cx - px)) exp(i (kx dx) n); wrapping kx dx is exact
    c = w * np.exp(1j * (kx * (grid.cx - float(center[0])) + ky * (grid.cy - float(center[1]))))
    tx = geometry.wrap_phase(kx * grid.dx)
    ty = geometry.wrap_phase(ky * grid.dy)
    out = finufft.nufft2d1(ty, tx, c.astype(np.complex128), grid.shape, isign=1, eps=1e-12)
    return out / np.sum(w)


def _uniform(weights) -> bool:
    return weights is None or float(np.ptp(weights)) == 0.0


def _resolve_method(method, weights, deviation, reach_m, tol_rad=1e-9):
    if method not in ("auto", "theorem", "direct", "nufft"):
        raise SarcliInputError(f"unknown PSF method {method!r}; expected auto, theorem, direct or nufft")
    equal = deviation * reach_m <= tol_rad
    if method == "theorem":
        if not _uniform(weights):
            raise SarcliInputError("the theorem kernel needs uniform weights; use method='direct' with a window")
        if not equal:
            raise SarcliInputError(f"the theorem kernel needs equally spaced frequencies (deviation "
                                   f"{deviation:.3g} rad/m gives a phase error {deviation * reach_m:.3g} rad)")
        return "theorem"
    if method == "auto":
        return "theorem" if _uniform(weights) and equal else "exact"
    return method


def _weights_array(weights, p, m):
    if weights is None:
        return np.ones((p, m))
    w = np.asarray(weights, dtype=np.float64)
    try:
        w = np.broadcast_to(w, (p, m))
    except ValueError:
        raise SarcliInputError(f"weights of shape {w.shape} do not match the {p} x {m} samples") from None
    if not np.all(np.isfinite(w)) or np.sum(w) <= 0:
        raise SarcliInputError("weights must be finite with a positive sum")
    return w


def kernel_at(acq_or_arrays, points_m, *, weights=None, center=(0.0, 0.0), method="auto") -> np.ndarray:
    """The normalised PSF ``K(x - center) / (M P)`` (or its weighted form) at arbitrary points.

    Parameters
    ----------
    acq_or_arrays : Acquisition or (frequency_hz, azimuth_rad, elevation_rad)
    points_m : array_like, shape (..., 2) or (..., 3)
        Ground points (z ignored: the kernel is that of the far-field model, eq. ``eq1``).
    weights : array_like, shape (P, M), optional
        Window weights w_pj (default: all 1).
    center : (float, float)
        Position of the unit point scatterer.
    method : {'auto', 'theorem', 'direct'}
        'theorem' = Theorem ``main-theorem`` (uniform weights, equally spaced frequencies);
        'direct' = exact weighted sum; 'auto' picks the theorem when it applies.

    Returns
    -------
    ndarray, complex128, shape (...)
    """
    freq, az, el = _as_arrays(acq_or_arrays)
    pts = np.asarray(points_m, dtype=np.float64)
    xr = pts[..., 0] - float(center[0])
    yr = pts[..., 1] - float(center[1])
    _, _, m, dev = theorem_parameters(freq, el)
    reach = float(np.max(np.hypot(xr, yr))) if xr.size else 0.0
    how = _resolve_method(method if method != "nufft" else "direct", weights, dev, reach)
    if how == "theorem":
        return _theorem(freq, az, el, xr, yr)
    return _direct(freq, az, el, _weights_array(weights, az.size, m), xr, yr)


def grid_method(acq_or_arrays, grid: Grid, *, weights=None, center=(0.0, 0.0), method="auto") -> str:
    """The evaluation :func:`psf_kernel` uses: 'theorem', 'direct' or 'nufft'.

    'auto' takes the theorem for uniform weights and frequencies equally spaced to a phase
    deviation below 1e-9 rad over the grid; otherwise the exact sum as a matrix product when
    samples × pixels <= 2e9, else FINUFFT type 1 (tolerance 1e-12).
    """
    freq, az, el = _as_arrays(acq_or_arrays)
    _, _, m, dev = theorem_parameters(freq, el)
    reach = grid.half_diagonal + math.hypot(*[float(v) for v in center]) + math.hypot(grid.cx, grid.cy)
    how = _resolve_method(method, weights, dev, reach)
    if how == "exact":
        how = "direct" if az.size * m * grid.nx * grid.ny <= 2e9 else "nufft"
    return how


def psf_kernel(acq_or_arrays, grid: Grid | None = None, *, weights=None, center=(0.0, 0.0),
               method="auto") -> np.ndarray:
    """The matched-filter point spread function on a grid (Theorem ``main-theorem``).

    Equals the exact far-field matched-filter image (eq. ``mf``, normalised by ``1/W``) of a
    unit point scatterer at ``center``: ``K(x - center) / (M P)`` with ``K`` of eq.
    ``main-2D-conv`` for uniform weights, the weighted sum ``Σ w_pj e^{i k_pj ξ_θp·(x-center)} / W``
    otherwise.

    Parameters
    ----------
    acq_or_arrays : Acquisition or (frequency_hz, azimuth_rad, elevation_rad)
    grid : Grid, optional
        Default: the acquisition's grid.
    weights : array_like, shape (P, M), optional
        Window weights (default uniform).
    center : (float, float)
        Position of the unit point (m).
    method : {'auto', 'theorem', 'direct', 'nufft'}
        'auto': the theorem for uniform weights and equally spaced frequencies (phase deviation
        below 1e-9 rad over the grid), otherwise the exact sum ('direct' on small problems,
        FINUFFT type 1 with tolerance 1e-12 on large ones).

    Returns
    -------
    ndarray, complex128, shape (ny, nx)
        Peak magnitude 1 at ``center``.

    Examples
    --------
    >>> import numpy as np
    >>> from sarcli.core.grid import Grid
    >>> f = np.linspace(9.7e9, 10.3e9, 64); az = np.radians(np.linspace(48.5, 51.5, 32))
    >>> k = psf_kernel((f, az, np.radians(30.0)), Grid.square(2.0, 64))
    >>> float(round(abs(k[32, 32]), 12))
    1.0
    """
    freq, az, el = _as_arrays(acq_or_arrays)
    if grid is None:
        if not isinstance(acq_or_arrays, Acquisition):
            raise SarcliInputError("psf_kernel needs a grid when given bare arrays")
        grid = acq_or_arrays.grid
    how = grid_method((freq, az, el), grid, weights=weights, center=center, method=method)
    if how == "theorem":
        xx, yy = np.meshgrid(grid.x - float(center[0]), grid.y - float(center[1]))
        return _theorem(freq, az, el, xx, yy)
    w = _weights_array(weights, az.size, np.shape(freq)[-1])
    if how == "direct":
        return _direct_grid(freq, az, el, w, grid, center)
    return _nufft_grid(freq, az, el, w, grid, center)


# --------------------------------------------------------------------------------------------
# predicted impulse-response figures
# --------------------------------------------------------------------------------------------
def window_weights_for(acq_or_arrays, window="none", *, nbar=4, sll_db=-35.0):
    """Window weights ``w_pj`` [P, M] for a window name (None for 'none'), via :mod:`sarcli.core.windows`.

    An array is passed through (validated against P × M).
    """
    freq, az, _ = _as_arrays(acq_or_arrays)
    p, m = az.size, np.shape(freq)[-1]
    if window is None or isinstance(window, str) and window.lower() in ("none", "uniform", "rect"):
        return None
    if not isinstance(window, str):
        return _weights_array(window, p, m)
    from ..core.windows import window_weights

    try:
        w = window_weights(p, m, window.lower(), nbar=nbar, sll_db=sll_db)
    except ValueError as exc:
        raise SarcliInputError(str(exc)) from None
    return _weights_array(w, p, m)


def predicted_ipr(acq, *, window="none", nbar=4, sll_db=-35.0, samples_per_cell=64,
                  sidelobe_extent_cells=10.0, max_samples=8001) -> dict:
    """Impulse-response figures predicted from the acquisition by the theorem kernel.

    The normalised kernel (Theorem ``main-theorem``; the exact weighted sum with a window) is
    sampled along the range direction ``ξ_θc`` (θc the centre look azimuth) and along
    cross-range through its peak, ``samples_per_cell`` samples per (finer) resolution cell and
    at most ``max_samples`` per cut, and measured with :func:`sarcli.analysis.ipr.profile_metrics`.
    The kernel is exact, so the figures hold where the textbook ones do not (wide apertures,
    narrow bands: there the aperture curvature also sets the range width).

    Parameters
    ----------
    acq : Acquisition or (frequency_hz, azimuth_rad, elevation_rad)
    window : str or array_like (P, M)
        Window name for :func:`sarcli.core.windows.window_weights` ('none' = uniform) or the weights.
    nbar, sll_db : Taylor window parameters.
    samples_per_cell : int
    sidelobe_extent_cells : float
        Sidelobes within this many resolution cells count for PSLR and ISLR.
    max_samples : int
        Cap on the samples per cut (the cut is shortened to respect it).

    Returns
    -------
    dict
        ``range`` / ``cross_range``: ``irw_m``, ``pslr_db``, ``islr_db``, ``first_nulls_m``,
        ``resolution_m`` (ρ of docs/conventions.md), ``cell_m`` (the resolution cell of the sidelobe
        extent: ``min(ρ, IRW / 0.886)``); ``textbook``: the continuous 1-D values of the window
        (:func:`window_textbook`; ``irw_factor`` × ρ; uniform: 0.886, -13.26 dB, -9.68 dB);
        ``range_direction_rad``, ``method`` ('theorem' or 'weighted sum'), ``window``.
    """
    freq, az, el = _as_arrays(acq)
    weights = window_weights_for((freq, az, el), window, nbar=nbar, sll_db=sll_db)
    rho = geometry.resolutions(freq, az, el)
    theta_c = center_azimuth(az)
    out = {"range_direction_rad": theta_c, "range_direction_deg": math.degrees(theta_c),
           "window": window if isinstance(window, str) or window is None else "custom",
           "sidelobe_extent_cells": float(sidelobe_extent_cells), "islr_definition": ISLR_DEFINITION}
    _, _, _, dev = theorem_parameters(freq, el)
    finite = [r for r in rho if np.isfinite(r)]
    # one step for both cuts, from the finer resolution (a wide aperture makes the range cut as
    # sharp as the cross-range one); at most max_samples per cut, shortening the cut if needed
    step = min(finite) / samples_per_cell if finite else 0.0
    for name, theta, r in (("range", theta_c, rho[0]), ("cross_range", theta_c + np.pi / 2, rho[1])):
        if not np.isfinite(r):
            out[name] = {"irw_m": None, "pslr_db": None, "islr_db": None, "resolution_m": None}
            continue
        half = min((sidelobe_extent_cells + 1.0) * r, step * (max_samples // 2))
        how = _resolve_method("auto", weights, dev, half)
        s = np.arange(-(half // step), half // step + 1) * step
        pts = s[:, None] * np.array([math.cos(theta), math.sin(theta)])[None, :]
        if how == "theorem":
            vals = kernel_at((freq, az, el), pts, method="theorem")
        else:
            w = _weights_array(weights, az.size, np.shape(freq)[-1])
            vals = _weighted_cut(freq, az, el, w, theta, step, s.size // 2)
        out["method"] = "theorem" if how == "theorem" else "weighted sum"
        met = profile_metrics(s, np.abs(vals), sidelobe_extent=min(sidelobe_extent_cells * r, float(s[-1])))
        # the resolution cell that sets the sidelobe extent: the formula's ρ, or IRW/IRW_FACTOR_UNIFORM where
        # the kernel is much sharper than the formula says (wide apertures, narrow bands)
        cell = r if met["irw_m"] is None else min(r, met["irw_m"] / IRW_FACTOR_UNIFORM)
        if cell < r:
            met = profile_metrics(s, np.abs(vals), sidelobe_extent=min(sidelobe_extent_cells * cell, float(s[-1])))
        met["resolution_m"] = float(r)
        met["cell_m"] = float(cell)
        out[name] = met
    key = "none" if weights is None else (window.lower() if isinstance(window, str) else None)
    if key is not None:
        factor, pslr, islr = window_textbook(key, nbar=nbar, sll_db=sll_db)
        out["textbook"] = {
            "irw_factor": factor,
            "irw_range_m": factor * rho[0] if np.isfinite(rho[0]) else None,
            "irw_cross_range_m": factor * rho[1] if np.isfinite(rho[1]) else None,
            "pslr_db": pslr, "islr_db": islr,
            "note": "1-D continuous-limit values of the window (IRW factor x rho); ISLR over an "
                    "infinite extent; they ignore the polar shape of the 2-D k-space support",
        }
    return out


# --------------------------------------------------------------------------------------------
# the PSF as an image file, and a picture of it
# --------------------------------------------------------------------------------------------
def psf_image(acq: Acquisition, grid: Grid | None = None, *, window="none", nbar=4, sll_db=-35.0,
              center=None, method="auto"):
    """The normalised PSF of a unit point as a :class:`sarcli.core.types.Image`, with predicted IPR figures.

    Parameters
    ----------
    acq : Acquisition
    grid : Grid, optional
        Default: the acquisition's grid.
    window : str
        Window name ('none', 'hann', 'hamming', 'taylor'; see :mod:`sarcli.core.windows`).
    nbar, sll_db : Taylor parameters.
    center : (float, float), optional
        Position of the unit point; default: the grid's centre ``(cx, cy)``.
    method : {'auto', 'theorem', 'direct', 'nufft'}
        See :func:`psf_kernel`.

    Returns
    -------
    sarcli.core.types.Image
        ``method='psf'``; ``parameters`` holds the window, the point, the evaluation method and
        the grid; ``attrs['predicted_ipr']`` the output of :func:`predicted_ipr`.
    """
    import time

    from ..core.types import Image

    grid = acq.grid if grid is None else grid
    center = (grid.cx, grid.cy) if center is None else (float(center[0]), float(center[1]))
    t0 = time.perf_counter()
    weights = window_weights_for(acq, window, nbar=nbar, sll_db=sll_db)
    how = grid_method(acq, grid, weights=weights, center=center, method=method)
    k = psf_kernel(acq, grid, weights=weights, center=center, method=method)
    runtime = time.perf_counter() - t0
    pred = predicted_ipr(acq, window=window, nbar=nbar, sll_db=sll_db)
    params = {"window": window, "point_m": list(center),
              "evaluation": "theorem (eq. main-2D-conv)" if how == "theorem" else f"weighted sum ({how})",
              "grid": grid.as_dict(), "normalisation": "1/W (peak 1 at the point)"}
    if window == "taylor":
        params.update({"taylor_nbar": int(nbar), "taylor_sll_db": float(sll_db)})
    return Image(image=k, x_m=grid.x, y_m=grid.y, method="psf", parameters=params, runtime_s=runtime,
                 attrs={"predicted_ipr": pred})
