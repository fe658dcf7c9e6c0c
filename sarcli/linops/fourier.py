"""The far-field SAR forward operator on the image grid as a NUFFT pair (FINUFFT).

Pixel model (paper eqs. ``fund-freq`` and ``2D-DFT``): with ``x = cx + j1 hx``, ``y = cy + j2 hy``
(``j = index - N//2``) the far-field data of an image ``f[j2, j1]`` are

    d[p, m] = exp(-i (kx cx + ky cy)) Σ_j f[j2, j1] exp(-i (k1 j1 + k2 j2)),
    (k1, k2) = (kx hx, ky hy) wrapped into [-π, π),

which is the data model of docs/conventions.md evaluated at pixel centres; the wrap is exact on the
grid (section ``sec: alias``). The forward map is a FINUFFT type-2 transform (sign -1), the adjoint
a type-1 transform (sign +1) at the same points; both plans are made once and reused.
``Aᴴ d / (P M)`` is the matched filter image (eq. ``mf``) at the pixel centres.
"""

from __future__ import annotations

import numpy as np
import finufft

from ..core import geometry
from ..core.grid import Grid
from ..formers.planning.cost import NUFFT_EPS
from .base import Linop
from .toeplitz import ToeplitzGram

__all__ = ["NufftOperator", "SubsampledDFT", "wrapped_pixel_frequencies"]


def wrapped_pixel_frequencies(kx, ky, grid: Grid):
    """Dimensionless frequencies ``(k1, k2) = (kx hx, ky hy)`` wrapped into [-π, π) (eq. ``fund-freq``)."""
    k1 = geometry.wrap_phase(np.asarray(kx, np.float64) * grid.dx)
    k2 = geometry.wrap_phase(np.asarray(ky, np.float64) * grid.dy)
    return k1, k2


class NufftOperator(Linop):
    """``A``: image ``[ny, nx]`` -> phase history ``[P, M]`` by a FINUFFT type-2/type-1 pair.

    Parameters
    ----------
    kx, ky : ndarray, shape (P, M)
        Physical k-space coordinates (rad/m), e.g. from :meth:`Acquisition.kspace`.
    grid : Grid
        Image grid; its centre offset ``(cx, cy)`` becomes a phase ramp on the data.
    eps : float
        FINUFFT relative tolerance.
    nthreads : int, optional
        FINUFFT threads (default: FINUFFT's own choice).
    """

    def __init__(self, kx, ky, grid: Grid, *, eps: float = NUFFT_EPS, nthreads: int | None = None):
        kx = np.asarray(kx, np.float64)
        ky = np.asarray(ky, np.float64)
        super().__init__(grid.shape, kx.shape, np.complex128)
        self.grid = grid
        self.eps = float(eps)
        k1, k2 = wrapped_pixel_frequencies(kx, ky, grid)
        self.k1 = np.ascontiguousarray(k1.ravel())
        self.k2 = np.ascontiguousarray(k2.ravel())
        # phase of the grid centre: exp(-i k·c), float64 before the exponential
        self.center_phase = np.exp(-1j * (kx * grid.cx + ky * grid.cy)).ravel()
        kw = {} if nthreads is None else {"nthreads": int(nthreads)}
        # FINUFFT's first mode axis is our row (y) axis, so its "x" points are k2
        self._plan2 = finufft.Plan(2, grid.shape, eps=self.eps, isign=-1, **kw)
        self._plan2.setpts(self.k2, self.k1)
        self._plan1 = finufft.Plan(1, grid.shape, eps=self.eps, isign=+1, **kw)
        self._plan1.setpts(self.k2, self.k1)

    @classmethod
    def from_acquisition(cls, acq, grid: Grid | None = None, **kwargs) -> "NufftOperator":
        """The operator of an :class:`~sarcli.core.acquisition.Acquisition` on ``grid`` (default its own)."""
        kx, ky = geometry.kspace_coordinates(acq.frequency_hz, acq.azimuth_rad, acq.elevation_rad)
        return cls(kx, ky, acq.grid if grid is None else grid, **kwargs)

    @property
    def n_samples(self) -> int:
        return int(self.k1.size)

    def _forward(self, x):
        c = self._plan2.execute(np.ascontiguousarray(x, dtype=np.complex128))
        return (c * self.center_phase).reshape(self.oshape)

    def _adjoint(self, y):
        c = np.ascontiguousarray(y, dtype=np.complex128).ravel() * np.conj(self.center_phase)
        return self._plan1.execute(c).reshape(self.ishape)

    def toeplitz_gram(self, fft_dtype=None) -> "ToeplitzGram":
        """``AᴴA`` in the pre-gridded (Toeplitz-embedded) form on the same points and ``eps``.

        ``fft_dtype``: see :class:`~sarcli.linops.toeplitz.ToeplitzGram` (default by ``eps``).
        """
        return ToeplitzGram(self.k1, self.k2, self.ishape, eps=self.eps, fft_dtype=fft_dtype)


class SubsampledDFT(Linop):
    """``A = P F``: the unitary DFT of an array followed by a selection of its coefficients.

    The test operator of Appendix A (half the rows of the unitary DFT chosen at random).

    Parameters
    ----------
    mask : ndarray of bool
        Which coefficients (in ``numpy.fft`` order) are kept; shape = image shape.
    """

    def __init__(self, mask):
        self.mask = np.asarray(mask, dtype=bool)
        super().__init__(self.mask.shape, (int(self.mask.sum()),), np.complex128)

    def _forward(self, x):
        return np.fft.fftn(x, norm="ortho")[self.mask]

    def _adjoint(self, y):
        full = np.zeros(self.ishape, dtype=np.complex128)
        full[self.mask] = y
        return np.fft.ifftn(full, norm="ortho")
