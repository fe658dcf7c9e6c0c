"""The regularised problem on one grid: its operator, normal equations, scaling and prior.

Solves, on an image grid,

    min_f ‖A f - b‖² + λ ‖T f‖₁          (ADMM; priors 'l1', 'tv', 'hotv', 'ptv')
    min_f ‖A f - b‖² + λ ‖Dᵏ f‖²         (conjugate gradients; prior 'tikhonov')

with A the forward model of the data (far-field pixel model as a NUFFT pair or its pre-gridded
Toeplitz form; for spherical data the sub-aperture NUFFTs on warped pixel positions of
:mod:`sarcli.linops.warped`, held to a tolerance, or the exact reprojection/backprojection pair)
and T the identity, D, Dᵏ or D Θ with Θ = diag(exp(-i arg f0)) and f0 the matched filter
(phase-corrected TV, the paper's choice for SAR, whose pixels have random phases).

Scaling (so that λ and β mean the same whatever the units of b): as in the paper's reference
solver the operator is normalised to ``‖Â‖₂ = 1`` (``Â = A / s_A``, ``s_A`` by power iteration)
and the data are scaled, ``b̂ = b / s_b``; here ``s_b`` makes ``max |Âᴴ b̂| = 1`` (the reference
uses the data's dynamic range; the back-projected maximum is the quantity the ℓ1 threshold acts
on). The problem is solved for ``u`` with ``Â``, ``b̂``; then ``f = u s_b / s_A``. Consequences:
for the ℓ1 prior every λ ≥ 2 gives f = 0, so λ is a fraction of that.

Normalisation of the output: f is the pixel reflectivity of the pixel model (eq. ``2D-DFT``):
the least-squares image of a unit point scatterer at a pixel centre is exactly 1 at that pixel,
the same peak the matched filter (``Aᴴb / (P M)``) gives, so regularised and matched-filter
images share one scale.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..core.grid import Grid
from ..core.types import PhaseHistory
from ..errors import DefocusWarning, SarcliInputError
from ..formers.planning.cost import NUFFT_EPS
from ..linops import NufftOperator, SphericalOperator, gram_eigmax, norm2, normal_equations, sparsifying_operator
from ..linops.finite_diff import FiniteDifference
from ..linops.toeplitz import NormalEquations
from .forecast import CountedGram
from .options import DEFOCUS_WARN_RAD, MIN_PULSES_PER_RUN, RegularizeOptions

__all__ = ["Problem", "choose_operator", "scale_problem", "matched_filter"]


def choose_operator(ph: PhaseHistory, grid: Grid, operator: str, tolerance: float):
    """``(operator, far-field phase error, runs)``; ``runs``, for 'warped' only, the chooser's
    ``(sub-apertures, AᴴA error, {count: operator it built})``.

    'auto' takes the Toeplitz form where the far-field model holds (phase error at the grid corner
    at most :data:`DEFOCUS_WARN_RAD`), else the warped operator where it meets ``tolerance`` with at
    least :data:`MIN_PULSES_PER_RUN` pulses per sub-aperture, else the exact spherical pair."""
    from ..linops.warped import choose_subapertures

    acq = ph.acquisition
    err = acq.farfield_phase_error(grid.half_diagonal) if (ph.model == "spherical" and acq.has_positions) else 0.0
    runs = None
    if operator == "auto":
        operator = "spherical" if err > DEFOCUS_WARN_RAD else "toeplitz"
        if operator == "spherical" and acq.n_pulses >= MIN_PULSES_PER_RUN:
            built = {}
            count, err_gram = choose_subapertures(acq, grid, tolerance, built=built)
            if count is not None and acq.n_pulses // count >= MIN_PULSES_PER_RUN:
                operator, runs = "warped", (count, err_gram, built)
    if operator in ("nufft", "toeplitz") and err > DEFOCUS_WARN_RAD:
        warnings.warn(f"far-field operator '{operator}' on spherical data: predicted phase error {err:.3g} rad "
                      f"at the grid corner ({grid.half_diagonal:.3g} m from the centre); use --operator "
                      f"spherical", DefocusWarning, stacklevel=6)   # regularize()'s caller
    if operator in ("spherical", "warped") and not acq.has_positions:
        raise SarcliInputError(f"operator '{operator}' needs antenna positions; this file has none")
    return operator, err, runs


def scale_problem(normal, *, power_iters: int = 30, callback=None):
    """Normalise ``‖A‖₂ = 1`` and ``max |Âᴴ b̂| = 1`` (module docstring).

    ``power_iters`` power iterations on ``AᴴA`` estimate ``‖A‖₂`` (from below; 30 give a few
    digits, 10 within a few per cent, which is all a scaling needs); ``callback(i)`` after each.

    Returns
    -------
    scaled : NormalEquations or None
        The normal equations of ``Â = A / s_A`` and ``b̂ = b / s_b`` (None when ``Aᴴb = 0``).
    s_a, s_b : float
        The scalings; an image ``u`` of the scaled problem is ``f = u s_b / s_a``.
    """
    s_a = float(np.sqrt(gram_eigmax(normal.gram, iters=power_iters, callback=callback)))
    s_b = float(np.max(np.abs(normal.atb))) / s_a if s_a > 0 else 0.0
    if s_b == 0.0 or not np.isfinite(s_b):
        return None, s_a, s_b
    return normal.scaled(s_a, s_b), s_a, s_b


def matched_filter(ph: PhaseHistory, grid: Grid | None = None, *, operator: str = "nufft",
                   eps: float = NUFFT_EPS) -> np.ndarray:
    """``Aᴴb / (P M)``: the matched filter (eq. ``mf``) of the operator pair used here."""
    grid = ph.acquisition.grid if grid is None else grid
    op = SphericalOperator.from_acquisition(ph.acquisition, grid) if operator in ("spherical", "warped") \
        else NufftOperator.from_acquisition(ph.acquisition, grid, eps=eps)
    return op.adjoint(ph.data) / ph.data.size


class Problem:
    """``‖Af − b‖² + λ R(f)`` on one grid: the operator chosen and built, its normal equations
    (every ``AᴴA`` product counted), the scaling, and the prior's transform.

    Parameters
    ----------
    ph : PhaseHistory
    grid : Grid
    options : RegularizeOptions
        Resolved (:meth:`RegularizeOptions.resolved`).
    init : ndarray, optional
        Initial image (physical units); for 'ptv' also the f0 whose phases define Θ.

    Attributes
    ----------
    operator : str
        The operator in use ('auto' resolved).
    op : Linop
        ``A``.
    normal : NormalEquations
        ``AᴴA`` (a :class:`~sarcli.regularize.forecast.CountedGram`), ``Aᴴb``, ``‖b‖²``.
    counter : CountedGram
    mf : ndarray
        The matched filter ``Aᴴb / (P M)``.
    phase_error : float
        The far-field model's phase error at the grid corner (rad).
    scaled, s_a, s_b
        After :meth:`scale`: the scaled normal equations and the scalings.
    """

    def __init__(self, ph: PhaseHistory, grid: Grid, options: RegularizeOptions, init=None):
        self.ph, self.grid, self.options, self.init = ph, grid, options, init
        self.operator, self.phase_error, runs = choose_operator(ph, grid, options.operator, options.tolerance)
        self.op, normal, self._half = self._build(runs)
        if not options.auto:
            self._half = None
        self.counter = CountedGram(normal.gram)
        self.normal = NormalEquations(self.counter, normal.atb, normal.bnorm2)
        self.mf = normal.atb / ph.data.size
        self.scaled, self.s_a, self.s_b = None, None, None

    def _build(self, runs):
        """``(A, normal equations, the half-count warped operator the chooser built or None)``."""
        ph, grid, opts = self.ph, self.grid, self.options
        acq = ph.acquisition
        if self.operator == "spherical":
            op = SphericalOperator.from_acquisition(acq, grid)
            return op, normal_equations(op, ph.data, form="nufft"), None
        if self.operator == "warped":
            # AᴴA by the warped operator; Aᴴb by the exact pair (one backprojection), so that the only
            # approximation in the normal equations is AᴴA's, whose error the tolerance bounds
            from ..linops.warped import EPS_MIN, WarpedNufftOperator

            count, err, built = (None, None, {}) if runs is None else runs
            op = built.get(count)
            if op is None or op.eps != max(opts.tolerance / 10, EPS_MIN):
                op = WarpedNufftOperator(acq, grid, subapertures="auto" if count is None else count,
                                         tolerance=opts.tolerance, predicted_error=err)
            else:
                op.predicted_error = float(err)
            atb = SphericalOperator.from_acquisition(acq, grid).adjoint(ph.data)
            # the λ path's operator (half the sub-apertures) where the chooser made it; the others go
            half = built.get(max(1, op.subapertures // 2)) if op.subapertures > 1 else None
            return op, NormalEquations(op.gram(), atb, norm2(np.asarray(ph.data))), half
        op = NufftOperator.from_acquisition(acq, grid, eps=opts.eps)
        return op, normal_equations(op, ph.data, form=self.operator), None

    @property
    def power_iters(self) -> int:
        """Power iterations of the scaling: the spherical AᴴA is two backprojections, so fewer (the
        far-field forms share 30 so that 'nufft' and 'toeplitz' scale identically)."""
        return 10 if self.operator in ("spherical", "warped") else 30

    def scale(self, callback=None) -> bool:
        """Compute the scaling (:func:`scale_problem`); False when there are no data to fit."""
        self.scaled, self.s_a, self.s_b = scale_problem(self.normal, power_iters=self.power_iters,
                                                        callback=callback)
        return self.scaled is not None

    def transforms(self):
        """``(T, D)``: the sparsifying transform of an ℓ1-type prior, or Tikhonov's ``Dᵏ`` (the
        other None). 'ptv' takes its phases from ``init`` or the matched filter."""
        prior, order, shape = self.options.prior, self.options.order, self.grid.shape
        if prior == "tikhonov":
            return None, FiniteDifference(shape, order)
        f0 = self.init if self.init is not None else self.mf
        return sparsifying_operator(prior, shape, order=order, f0=f0 if prior == "ptv" else None), None

    def path_normal(self, params: dict):
        """The scaled normal equations the λ path solves and their counter (``path_counter is
        counter`` where the path shares the final operator).

        For a warped operator: the same ``Aᴴb`` and scaling, ``AᴴA`` from half the sub-apertures (a
        product at about half the final one's cost, an error about 4 × the tolerance: the residual
        grows as the square of a sub-aperture's angle). The path only ranks λ and warm-starts the
        final solve, which runs on the operator held to the tolerance."""
        if self.operator != "warped" or self.op.subapertures == 1:
            return self.scaled, self.counter
        from ..linops.warped import WarpedNufftOperator

        path_op, self._half = self._half, None
        if path_op is None or path_op.eps != self.op.eps:
            path_op = WarpedNufftOperator(self.op.acquisition, self.grid,
                                          subapertures=max(1, self.op.subapertures // 2), eps=self.op.eps)
        counter = CountedGram(path_op.gram())
        params["path_operator"] = {"subapertures": path_op.subapertures,
                                   "predicted_error": path_op.predicted_error}
        normal = NormalEquations(counter, self.normal.atb, self.normal.bnorm2)
        return normal.scaled(self.s_a, self.s_b), counter

    def parameters(self) -> dict:
        """The problem's part of an image's ``parameters``."""
        o, p = self.options, {}
        p.update(prior=o.prior, order=o.order, lam=o.lam, beta=o.beta, iters=o.iters, tol=o.tol,
                 operator=self.operator, isotropic=bool(o.isotropic), inner_iters=int(o.inner_iters),
                 reestimate_every=int(o.reestimate_every), eps=o.eps, grid=self.grid.as_dict(),
                 init=self.init is not None, scale_operator=self.s_a, scale_data=self.s_b,
                 scale_power_iterations=self.power_iters, farfield_phase_error_rad=self.phase_error,
                 model=self.ph.model)
        if self.operator == "warped":
            p.update(operator_tolerance=o.tolerance, subapertures=self.op.subapertures,
                     operator_predicted_error=self.op.predicted_error)
        p["normalisation"] = ("pixel-model reflectivity f = u * scale_data / scale_operator: a unit point at a "
                              "pixel centre recovered exactly is 1, the matched filter's peak")
        return p
