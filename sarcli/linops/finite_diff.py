"""Sparsifying transforms T of the regularised problem (paper section ``sec: reg``).

- :class:`FiniteDifference`: periodic k-th order differences along every axis, stacked along a
  new leading axis (``oshape = (ndim, *shape)``). Order 1 is the TV operator D of eq.
  ``eq: Dmatrix`` (made circulant); orders 2 and 3 are the higher-order TV operators Dᵏ.
- :func:`phase_operator`: ``Θ = diag(exp(-i arg f0))`` of phase-corrected TV, and
  :class:`PhaseCorrectedDifference`, the composition ``Dᵏ Θ`` (one compiled pass for k = 1).
- :func:`sparsifying_operator`: T for a prior name (``l1``, ``tv``, ``hotv``, ``ptv``).

Scaling of Dᵏ: the k-th order difference is scaled by ``2^(1-k)``, as in Toby Sanders' HOTV
solver (the paper's reference MATLAB code), so that ``‖Dᵏ‖₂ = 2`` per axis for every k (the
largest Fourier symbol of ``(e^{iω}-1)^k`` is ``2^k``) and one λ suits all orders.
Boundaries are periodic (the image wraps), which makes Dᵏ circulant and its adjoint exact;
the reference solver likewise works with periodic differences.
"""

from __future__ import annotations

import numpy as np

from ._reduce import diff2d_adjoint, diff2d_diag_adjoint, diff2d_diag_forward, diff2d_forward
from .base import Compose, Diagonal, Identity, Linop

__all__ = ["FiniteDifference", "PhaseCorrectedDifference", "phase_operator", "sparsifying_operator",
           "PRIORS"]

#: Priors solved by ADMM (Tikhonov is the smooth baseline solved by CG).
PRIORS = ("l1", "tv", "hotv", "ptv")


class FiniteDifference(Linop):
    """Periodic k-th order finite differences along each axis, stacked on axis 0.

    ``(Dᵏ f)[a] = 2^(1-k) (S_a - I)^k f`` with ``(S_a f)[j] = f[j + e_a]`` (wrapping).

    Parameters
    ----------
    shape : tuple of int
        Image shape (1-D signals and 2-D images alike).
    order : {1, 2, 3}
        Difference order k (1 = TV).
    axes : sequence of int, optional
        Axes to difference (default all).
    """

    def __init__(self, shape, order: int = 1, axes=None, dtype=np.complex128):
        shape = tuple(int(s) for s in (shape if np.iterable(shape) else (shape,)))
        if int(order) not in (1, 2, 3):
            raise ValueError(f"difference order must be 1, 2 or 3, got {order}")
        self.axes = tuple(range(len(shape))) if axes is None else tuple(int(a) for a in axes)
        super().__init__(shape, (len(self.axes),) + shape, dtype)
        self.order = int(order)
        self.scale = 2.0 ** (1 - self.order)

    def _fast(self, x):
        return self.order == 1 and len(self.ishape) == 2 and self.axes == (0, 1) \
            and self.dtype == np.complex128 and x.dtype.kind in "fc"

    def _forward(self, x):
        if self._fast(x):
            return diff2d_forward(x)
        out = np.empty(self.oshape, dtype=np.result_type(x.dtype, self.dtype))
        for i, ax in enumerate(self.axes):
            d = x
            for _ in range(self.order):
                d = np.roll(d, -1, axis=ax) - d
            out[i] = d
        if self.order > 1:
            out *= self.scale
        return out

    def _adjoint(self, y):
        if self._fast(y):
            return diff2d_adjoint(y)
        out = np.zeros(self.ishape, dtype=np.result_type(y.dtype, self.dtype))
        for i, ax in enumerate(self.axes):
            d = y[i]
            for _ in range(self.order):
                d = np.roll(d, 1, axis=ax) - d
            out += d
        if self.order > 1:
            out *= self.scale
        return out


class PhaseCorrectedDifference(Compose):
    """``Dᵏ Θ`` of phase-corrected TV: a :class:`Compose` of ``Dᵏ`` and ``Θ``.

    For first differences of a complex128 2-D image, forward and adjoint run as one compiled pass
    each (no ``Θ f`` or ``Dᴴ y`` intermediate); otherwise as the composition.

    Parameters
    ----------
    D : FiniteDifference
    theta : Diagonal
    """

    def __init__(self, D: FiniteDifference, theta: Diagonal):
        super().__init__(D, theta)
        self._fused = (isinstance(D, FiniteDifference) and isinstance(theta, Diagonal)
                       and D.order == 1 and len(D.ishape) == 2 and D.axes == (0, 1)
                       and D.dtype == np.complex128 and theta.d.dtype == np.complex128)

    def _forward(self, x):
        if self._fused and x.dtype.kind in "fc":
            return diff2d_diag_forward(x, self.b.d)
        return super()._forward(x)

    def _adjoint(self, y):
        if self._fused and y.dtype.kind in "fc":
            return diff2d_diag_adjoint(y, self.b.d)
        return super()._adjoint(y)


def phase_operator(f0) -> Diagonal:
    """``Θ = diag(exp(-i arg f0))`` so that ``Θ f0 = |f0|`` (phase-corrected TV).

    Pixels where ``f0 = 0`` get phase 0.
    """
    f0 = np.asarray(f0)
    return Diagonal(np.exp(-1j * np.angle(f0)))


def sparsifying_operator(prior: str, shape, *, order: int = 1, f0=None) -> Linop:
    """The operator T of ``min ‖Af-b‖² + λ‖Tf‖₁`` for a prior name.

    Parameters
    ----------
    prior : {'l1', 'tv', 'hotv', 'ptv'}
        Identity, D, Dᵏ, or Dᵏ Θ (phase-corrected TV, ``f0`` required).
    shape : tuple
        Image shape.
    order : int
        k for 'hotv' and 'ptv' (1 for 'tv').
    f0 : ndarray, optional
        First image whose phases define Θ ('ptv').
    """
    if prior == "l1":
        return Identity(shape)
    if prior == "tv":
        return FiniteDifference(shape, 1)
    if prior == "hotv":
        return FiniteDifference(shape, order)
    if prior == "ptv":
        if f0 is None:
            raise ValueError("the 'ptv' prior needs a first image f0 for its phases")
        return PhaseCorrectedDifference(FiniteDifference(shape, order), phase_operator(f0))
    raise ValueError(f"unknown prior {prior!r}; expected one of {PRIORS}")
