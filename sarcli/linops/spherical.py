"""The spherical-model SAR forward operator as a Linop pair: reprojection and backprojection.

Wraps :func:`sarcli.formers.backprojection.reproject` / :func:`~sarcli.formers.backprojection.backproject`:
``backproject`` is the matched filter ``B d = (1/W) Σ d e_pj(x)`` (``W = P M``) and ``reproject``
its exact adjoint (same profile FFT size and interpolation, transposed). The forward model
``A f = Σ_x f(x) exp(-i 4π α (|a_p - x| - r0_p) / c)`` is approximated by ``A = W · reproject``, so
``Aᴴ = W · backproject`` and ``Aᴴ d / W`` is the backprojected matched filter. The pair is exact
adjoint to rounding whatever the interpolation error of the approximation itself. Use it for
near-field data (GOTCHA: r0 ≈ 10 km) where the far-field NUFFT pair defocuses.
"""

from __future__ import annotations

import numpy as np

from .._util.progress import no_bars
from ..core.grid import Grid
from .base import Linop

__all__ = ["SphericalOperator"]


class SphericalOperator(Linop):
    """``A``: image ``[ny, nx]`` -> spherical phase history ``[P, M]`` (reprojection).

    Parameters
    ----------
    freq_hz : ndarray, shape (M,) or (P, M)
        Frequencies (equally spaced per pulse).
    antenna_position_m : ndarray, shape (P, 3)
    range_to_center_m : ndarray, shape (P,)
    grid : Grid
    upsample, interp, precision, nthreads
        Passed to the backprojection kernels (defaults: theirs).
    """

    def __init__(self, freq_hz, antenna_position_m, range_to_center_m, grid: Grid, **kwargs):
        a = np.asarray(antenna_position_m, np.float64)
        f = np.asarray(freq_hz, np.float64)
        super().__init__(grid.shape, (a.shape[0], f.shape[-1]), np.complex128)
        self.freq_hz, self.antenna_position_m = f, a
        self.range_to_center_m = np.asarray(range_to_center_m, np.float64)
        self.grid = grid
        self.kwargs = kwargs
        self.total_weight = float(self.oshape[0] * self.oshape[1])

    @classmethod
    def from_acquisition(cls, acq, grid: Grid | None = None, **kwargs) -> "SphericalOperator":
        if not acq.has_positions:
            raise ValueError("the spherical operator needs antenna positions")
        return cls(acq.frequency_hz, acq.antenna_position_m, acq.range_to_center_m,
                   acq.grid if grid is None else grid, **kwargs)

    # the kernels draw no bar of their own here: an operator is applied inside an iteration that has one

    def _forward(self, x):
        from ..formers.backprojection import reproject

        with no_bars():
            return self.total_weight * reproject(x, self.freq_hz, self.antenna_position_m,
                                                 self.range_to_center_m, self.grid, **self.kwargs)

    def _adjoint(self, y):
        from ..formers.backprojection import backproject

        with no_bars():
            return self.total_weight * backproject(y, self.freq_hz, self.antenna_position_m,
                                                   self.range_to_center_m, self.grid, **self.kwargs)
