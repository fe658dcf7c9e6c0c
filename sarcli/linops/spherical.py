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
from ..core.collection import Collection
from ..core.grid import Grid
from .base import Linop

__all__ = ["SphericalOperator"]


class SphericalOperator(Linop):
    """``A``: image ``[ny, nx]`` -> spherical phase history ``[P, M]`` (reprojection).

    Parameters
    ----------
    collection : Collection
        Frequencies (M,) or (P, M), equally spaced per pulse, antenna positions (P, 3), reference
        ranges (P,) and, optionally, receive positions (:class:`sarcli.core.collection.Collection`;
        without weights: ``W = P M``).
    grid : Grid
    options : BackprojectionOptions, optional
        The backprojection pair's knobs (:class:`sarcli.formers.options.BackprojectionOptions`;
        None: those of :func:`~sarcli.formers.backprojection.backproject`).
    nthreads : int, optional
        Threads of the kernels.
    """

    def __init__(self, collection, grid: Grid, options=None, nthreads=None):
        a = np.asarray(collection.antenna_position_m, np.float64)
        f = np.asarray(collection.frequency_hz, np.float64)
        if collection.weights is not None:
            raise ValueError("the spherical operator is the unweighted model (W = P M): give a collection without weights")
        super().__init__(grid.shape, (a.shape[0], f.shape[-1]), np.complex128)
        self.collection = Collection(f, a, np.asarray(collection.range_to_center_m, np.float64),
                                     receive_position_m=collection.receive_position_m)
        self.grid = grid
        self.options, self.nthreads = options, nthreads
        self.total_weight = float(self.oshape[0] * self.oshape[1])

    @classmethod
    def from_acquisition(cls, acq, grid: Grid | None = None, options=None, nthreads=None) -> "SphericalOperator":
        """The operator of an acquisition's range model (:meth:`~sarcli.core.acquisition.Acquisition.collection`):
        its frequencies, reference ranges and antenna positions, transmit and receive apart when bistatic."""
        if not acq.has_positions:
            raise ValueError("the spherical operator needs antenna positions")
        return cls(acq.collection(), acq.grid if grid is None else grid, options, nthreads)

    # the kernels draw no bar of their own here: an operator is applied inside an iteration that has one

    def _forward(self, x):
        from ..formers.backprojection import reproject

        with no_bars():
            return self.total_weight * reproject(x, self.collection, self.grid, self.options, nthreads=self.nthreads)

    def _adjoint(self, y):
        from ..formers.backprojection import backproject

        with no_bars():
            return self.total_weight * backproject(y, self.collection, self.grid, self.options, nthreads=self.nthreads)
