"""The far-field matched filter as one type-1 non-uniform FFT (FINUFFT).

On the pixel lattice ``x = cx + (col - nx//2) dx``, ``y = cy + (row - ny//2) dy`` the far-field
matched filter (eq. ``mf``) is

``f[row, col] = (1/W) Σ_s c_s exp(i (kx_s cx + ky_s cy)) exp(i (k1_s (col - nx//2) + k2_s (row - ny//2)))``

with ``c = w d`` and the dimensionless frequencies ``(k1, k2) = (kx dx, ky dy)`` of eq. ``fund-freq``.
That is a 2-D type-1 NUFFT with ``isign = +1``. Wrapping ``k1, k2`` into [-π, π) changes nothing on
the integer lattice (section ``sec: alias``). FINUFFT's default mode order (``modeord=0``) gives
modes ``-N//2 .. (N-1)//2``, which is exactly ``col - nx//2`` for even and odd ``nx``.
"""

from __future__ import annotations

import finufft
import numpy as np

from ..core import geometry
from ..errors import SarcliInputError
from ._samples import check_kspace, weighted_samples
from .planning.cost import NUFFT_EPS

__all__ = ["nufft_farfield", "nufft_options", "FFTW_FLAGS"]

#: Below this tolerance FINUFFT's default upsampling (2) is kept; at or above it the smaller
#: fine grid of ``upsampfac = 1.25`` is used with half the tolerance (measured on 1024² x 131k
#: random points: error 0.2-0.6 eps from 1e-2 to 1e-9, about twice as fast, 0.39x the grid memory).
LOW_UPSAMPLING_MIN_EPS = 1e-9
#: At or above this tolerance the transform runs in single precision (float32 FINUFFT reaches ~5e-5
#: at best, so only loose tolerances may use it; half the memory again).
SINGLE_PRECISION_MIN_EPS = 1e-3


def nufft_options(eps: float) -> dict:
    """FINUFFT settings that meet relative error ``eps`` with the least memory: ``upsampfac``,
    ``precision`` ('single' or 'double') and the tolerance handed to FINUFFT.

    Examples
    --------
    >>> nufft_options(1e-6)
    {'upsampfac': 1.25, 'precision': 'double', 'tol': 5e-07}
    >>> nufft_options(1e-12)["upsampfac"]
    2.0
    """
    eps = float(eps)
    if eps >= LOW_UPSAMPLING_MIN_EPS:
        return {"upsampfac": 1.25, "precision": "single" if eps >= SINGLE_PRECISION_MIN_EPS else "double",
                "tol": eps / 2}
    return {"upsampfac": 2.0, "precision": "double", "tol": eps}


#: FFTW planner flags by name (FINUFFT's ``fftw`` option; ignored by builds that use DUCC0 FFTs)
FFTW_FLAGS = {"estimate": 64, "measure": 0, "patient": 32, "exhaustive": 8}


def _prepare(c, kx, ky, dx, dy, cx, cy):
    """Centre phase ``c exp(i (kx cx + ky cy))`` and wrapped ``(kx dx, ky dy)``, float64 (plain NumPy:
    a few milliseconds for 10⁵–10⁶ samples, and no compiled kernel to load at start-up)."""
    out = c * np.exp(1j * (kx * cx + ky * cy)) if (cx or cy) else c.astype(np.complex128, copy=True)
    return out, geometry.wrap_phase(kx * dx), geometry.wrap_phase(ky * dy)


def nufft_farfield(data, kx, ky, grid, weights=None, *, eps=NUFFT_EPS, nthreads=None,
                   fftw="estimate") -> np.ndarray:
    """Far-field matched filter by one type-1 NUFFT; equals :func:`direct_farfield` to ~``eps``.

    Parameters
    ----------
    data : array_like, shape (P, M)
        Phase history.
    kx, ky : array_like, shape (P, M)
        k-space coordinates (rad/m), :func:`sarcli.core.geometry.kspace_coordinates`.
    grid : sarcli.core.grid.Grid
        Output grid; any centre ``(cx, cy)`` and rectangular pixels. The centre offset is applied
        as the float64 phase factor ``exp(i (kx cx + ky cy))`` on the data.
    weights : array_like, shape (P, M), optional
        Window weights.
    eps : float
        Relative accuracy asked for. The default 1e-9 keeps the relative ℓ2 error against the exact
        matched filter far below 1e-5 (measured ~1e-10 on the test geometries). The FINUFFT
        upsampling, precision and tolerance that meet it with the least memory come from
        :func:`nufft_options`.
    nthreads : int, optional
        Threads for FINUFFT (its default, all cores, when omitted).
    fftw : {'estimate', 'measure', 'patient', 'exhaustive'} or int
        FFTW planner effort. ``'estimate'`` suits one-shot calls: planning with ``'measure'`` costs
        more than one transform. Builds of FINUFFT that use DUCC0 FFTs ignore it.

    Returns
    -------
    image : ndarray, shape (ny, nx), complex128
    """
    wd, total = weighted_samples(data, weights)
    kx, ky = check_kspace(wd.shape, kx, ky)
    flag = FFTW_FLAGS.get(fftw, fftw) if isinstance(fftw, str) else int(fftw)
    if isinstance(flag, str):
        raise ValueError(f"unknown fftw planner {fftw!r}; choose one of {', '.join(FFTW_FLAGS)}")
    if not (0 < eps < 1):
        raise SarcliInputError(f"NUFFT --eps must lie in (0, 1), got {eps}")
    c, k1, k2 = _prepare(np.ascontiguousarray(wd).ravel(), np.ascontiguousarray(kx).ravel(),
                         np.ascontiguousarray(ky).ravel(), float(grid.dx), float(grid.dy),
                         float(grid.cx), float(grid.cy))
    choice = nufft_options(eps)
    opts = {"fftw": flag, "upsampfac": choice["upsampfac"]}
    if nthreads is not None:
        opts["nthreads"] = int(nthreads)
    if choice["precision"] == "single":
        k1, k2, c = k1.astype(np.float32), k2.astype(np.float32), c.astype(np.complex64)
    # first coordinate <-> first output axis: rows (y) first, so the result is [ny, nx]
    image = finufft.nufft2d1(k2, k1, c, (int(grid.ny), int(grid.nx)), eps=choice["tol"], isign=1, **opts)
    image = image.astype(np.complex128, copy=False)
    image *= 1.0 / total
    return image
