"""Constrained minimum-entropy autofocus.

With the stack of single-pulse images ``B[p, s]`` (:func:`pulse_images`) the image of the data
corrected by ``φ`` is ``f(φ) = Σ_p exp(-i φ_p) B[p]``, its intensity ``I_s = |f_s|²`` and its
entropy ``H = -Σ_s (I_s/E) ln(I_s/E)`` (``E = Σ I``). The gradient is exact and costs one product
with the stack:

.. math::

    \\frac{\\partial H}{\\partial φ_p} = -\\frac{2}{E} \\sum_s (\\ln p_s + H)\\,
        \\operatorname{Im}\\big(\\overline{f_s}\\, e^{-iφ_p} B_{ps}\\big),

and L-BFGS minimises ``H(φ) + λ Σ_p (1 - cos(φ_p - φ0_p))``.

The constraints. Minimum entropy alone drifts: on a point scene imaged on a window just holding
it, started from the true answer, it reached an entropy below the clean image's while moving
0.6 rad rms from the truth, mostly by pushing sidelobe energy out of the window. Two constraints
stop that: (1) the entropy is measured on the grid widened by a guard band
(:func:`~sarcli.autofocus._common.guarded_grid`, 1.5 times, up to the alias-free size), which
alone brings the same case to 0.01 rad; (2) the search starts from the PGA estimate ``φ0`` and a
penalty keeps each pulse's phase near it (at zero instead when PGA did not sharpen the image), in a ``cos`` form blind to 2π wraps, with
``λ = strength / P`` (``strength`` 1 by default; 0 is unconstrained). The constant and linear
part of the result are removed (unobservable), and the result is kept only if it sharpens the
image.
"""

from __future__ import annotations

import numpy as np

from ..core.grid import Grid
from ._common import (AutofocusResult, estimation_grid, form, guarded_grid, keep_if_sharper, pulse_images,
                      remove_linear_phase, sharpness)

__all__ = ["min_entropy", "entropy_and_gradient"]


def entropy_and_gradient(phi, stack):
    """Image entropy of ``Σ_p exp(-i φ_p) B[p]`` and its gradient with respect to ``φ``."""
    e = np.exp(-1j * phi)
    f = e.astype(stack.dtype) @ stack
    inten = (f.real.astype(np.float64) ** 2 + f.imag.astype(np.float64) ** 2)
    total = inten.sum()
    p = inten / total
    logp = np.log(np.where(p > 0, p, 1.0))
    h = float(-np.sum(p * logp))
    w = -(logp + h) / total
    v = stack @ (w * np.conj(f)).astype(stack.dtype)
    grad = 2.0 * np.imag(e * v)
    return h, grad


def min_entropy(ph, *, grid: Grid | None = None, start=None, strength: float = 1.0,
                max_iter: int = 200, tol: float = 1e-9, guard: bool = True, pga_options=None):
    """Minimum-entropy autofocus constrained to the neighbourhood of a PGA start.

    Parameters
    ----------
    ph : PhaseHistory
    grid : Grid, optional
        Estimation grid (default the acquisition's, cut to :func:`estimation_grid`).
    start : array_like, optional
        Starting estimate and centre of the constraint (default: :func:`sarcli.autofocus.pga.pga`'s
        estimate if it lowers the entropy, else zero).
    strength : float
        Constraint weight (``λ = strength / P``); 0 is unconstrained (drifts, not recommended).
    max_iter, tol : int, float
        L-BFGS iteration cap and tolerance.
    guard : bool
        Keep the estimate only when it sharpens the image.

    Returns
    -------
    AutofocusResult
        ``history`` holds the entropy of the start and of the optimum.
    """
    from scipy.optimize import minimize

    acq = ph.acquisition
    grid = estimation_grid(grid or acq.grid)
    P = ph.data.shape[0]
    pga_res = None
    if start is None:
        from .pga import pga

        pga_res = pga(ph, grid=grid, guard=False, **(pga_options or {}))
        start = pga_res.phase_rad
        # anchor at PGA only where PGA sharpened the image (entropy down, peak-to-mean not down);
        # otherwise at no correction
        (h0, m0), (h1, m1) = sharpness(form(ph, grid)), sharpness(form(ph, grid, start))
        if not (h1 < h0 and m1 >= m0):
            start = np.zeros(P)
    phi0 = np.asarray(start, np.float64)
    stack = pulse_images(ph, guarded_grid(grid, acq))
    lam = float(strength) / P

    def fun(phi):
        h, g = entropy_and_gradient(phi, stack)
        d = phi - phi0
        return h + lam * np.sum(1.0 - np.cos(d)), g + lam * np.sin(d)

    h_start = fun(phi0)[0]
    opt = minimize(fun, phi0, jac=True, method="L-BFGS-B", options={"maxiter": max_iter, "ftol": tol, "gtol": 1e-10})
    phi = remove_linear_phase(opt.x, acq.azimuth_rad)
    hist = {"objective_start": h_start, "objective_end": float(opt.fun), "lbfgs_iterations": int(opt.nit)}
    if pga_res is not None:
        hist["pga_iterations"] = pga_res.iterations
    res = AutofocusResult(phi, "min-entropy", iterations=int(opt.nit), history=hist)
    if guard:
        res = keep_if_sharper(ph, grid, res, [phi0, phi] if pga_res is not None else [phi])
    return res
