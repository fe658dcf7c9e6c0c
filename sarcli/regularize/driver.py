"""Regularised reconstruction (paper section ``sec: reg``, Appendices A-B): :func:`regularize`.

:class:`Regularization` is the application (SigPy's App): a :class:`~sarcli.regularize.problem.Problem`
(operator, normal equations, scaling, prior), then λ (given, or chosen on the warm-started path of
:mod:`sarcli.regularize.lampath`), then the final solve (ADMM, or CG for Tikhonov), each stage
counting its ``AᴴA`` products and advancing one progress bar. :func:`regularize` is its one-call form.
The problem, its scaling and the meaning of λ are described in :mod:`sarcli.regularize.problem`.
"""

from __future__ import annotations

import time

import numpy as np

from ..core.grid import Grid, resolve_grid
from ..core.types import Image, PhaseHistory
from ..errors import SarcliInputError
from ..formers.planning.cost import regularize_bytes
from ..solvers import ADMM, Reestimate, tikhonov
from ..linops import sparsifying_operator
from .forecast import Forecast, solver_overhead
from .lampath import PATH_FIRST_ITERS, PATH_ITERS, auto_lambda
from .options import (DEFAULT_BETA_RATIO, DEFAULT_LAM, OPERATORS, PRIORS, RegularizeOptions)
from .problem import Problem, matched_filter, scale_problem
from .regparam import SELECT_PATH

__all__ = ["regularize", "Regularization", "RegularizeOptions", "PRIORS", "OPERATORS", "DEFAULT_LAM",
           "DEFAULT_BETA_RATIO", "matched_filter", "scale_problem"]


def _outcome(params: dict, hist: dict, prior: str) -> None:
    """What a user should know of the run, as fields and as one line each.

    Sets ``params['iteration_cap_reached']`` (the final solve stopped at ``iters`` before ``tol``),
    ``params['final_relative_change']`` and ``params['advice']``: a list of ``{'code', 'line'}`` with
    the codes ``'lam_at_smallest'`` / ``'lam_at_largest'`` (λ auto sits at a path end it could not
    extend past) and ``'iteration_cap'``; each line says what it means and what to do.
    """
    its, iters, tol = params["iterations"], params["iters"], params["tol"]
    change = hist.get("relative_change")
    last = float(change[-1]) if change is not None and len(change) else float("nan")
    # CG (tikhonov) stops on its residual: reaching the cap is not converging
    capped = its >= iters and (prior == "tikhonov" or not last < tol)
    params["iteration_cap_reached"], params["final_relative_change"] = bool(capped), last
    advice = []
    sel = params.get("lam_selection")
    if sel is not None and sel.get("at_path_end") == "smallest":
        advice.append({"code": "lam_at_smallest", "line": (
            f"lam {sel['lam']:.3g} is the smallest the path tried (floor {sel['lam_floor']:g}) and the "
            f"{sel['criterion']} criterion still falls there: the data are fitted down to their noise "
            f"(nearly noiseless, or noise underestimated); check the image for noise, give --lam to choose, "
            f"or store the data's noise power in the file (attribute noise_power)")})
    if sel is not None and sel.get("at_path_end") == "largest":
        advice.append({"code": "lam_at_largest", "line": (
            f"lam {sel['lam']:.3g} is the largest the path tried (ceiling {sel['lam_ceiling']:g}): the "
            f"{sel['criterion']} criterion prefers a smoother image still, the prior may not suit the "
            f"scene; try --prior ptv or give --lam")})
    if capped:
        more = f" (relative change {last:.2g} > --tol {tol:g})" if np.isfinite(last) else ""
        advice.append({"code": "iteration_cap", "line": (
            f"the final solve stopped at its {iters}-iteration cap{more}: give --iters {2 * iters} "
            f"(the image may still change) or a larger --tol")})
    params["advice"] = advice


class Regularization:
    """A regularised reconstruction as an application: :meth:`run` → :class:`~sarcli.core.types.Image`.

    Stages, each its own method: the problem and its scaling (:meth:`prepare`), λ (:meth:`choose_lambda`:
    the given value, or the path), the final solve (:meth:`solve`), the image and its record
    (:meth:`image`). Arguments as :func:`regularize`, with the settings in ``options``.
    """

    def __init__(self, ph: PhaseHistory, options: RegularizeOptions, grid: Grid, *, init=None, callback=None,
                 progress=None, notice=None):
        self.ph, self.options, self.grid = ph, options.resolved(), grid
        self.init = None if init is None else np.asarray(init.image if isinstance(init, Image) else init,
                                                         np.complex128)
        if self.init is not None and self.init.shape != grid.shape:
            raise SarcliInputError(f"initial image shape {self.init.shape} does not match the grid {grid.shape}")
        self.callback, self.progress, self.notice = callback, progress, notice
        o = self.options
        self.lam = DEFAULT_LAM[o.prior] if o.auto else float(o.lam)
        self.beta = float(o.beta)   # resolved: the given β, or DEFAULT_BETA_RATIO times the (starting) λ
        self.problem = self.forecast = self.u0 = self.path_normal = self.path_counter = None
        self._path_start = 0
        self.params, self.products = {}, {}

    def tick(self, k: int) -> None:
        if self.progress is not None:
            self.progress.update(k)

    def run(self) -> Image:
        """All stages; the image of the scaled problem's solution in physical units."""
        t0 = time.perf_counter()
        if not self.prepare():
            return self.image(np.zeros(self.grid.shape, np.complex128), {}, t0)
        if self.options.auto:
            self.choose_lambda()
        u, hist = self.solve()
        return self.image(u * (self.problem.s_b / self.problem.s_a), hist, t0)

    def prepare(self) -> bool:
        """Build the problem, scale it (power iterations, timed for the forecast) and announce a long
        run. False when there are no data to fit (every prior's solution is then 0)."""
        o = self.options
        self.problem = pb = Problem(self.ph, self.grid, o, self.init)
        if self.progress is not None:
            path_cap = 2 * (PATH_ITERS * (len(SELECT_PATH) - 1) + PATH_FIRST_ITERS) if o.auto else 0
            self.progress.reset(total=pb.power_iters + path_cap + o.iters)
            self.progress.set_description(f"regularize {o.prior}: scaling")
        self.forecast = Forecast(o.prior, pb.operator, pb.power_iters, o.iters, o.auto, self.notice, self.tick)
        scaled = pb.scale(callback=self.forecast.on_power)
        self.params = {**pb.parameters(), "lam": self.lam, "beta": self.beta}
        self.products = {"scaling": pb.counter.count}
        if not scaled:
            return False
        self.u0 = None if self.init is None else self.init * (pb.s_a / pb.s_b)
        self.T, self.D = pb.transforms()
        memory = regularize_bytes(*self.ph.data.shape, self.grid, pb.operator, np.dtype(self.ph.data.dtype).itemsize,
                                  auto=o.auto)
        overhead = solver_overhead(self.T, self.D, pb.mf)
        if o.auto:
            self._time_path(overhead)
        self.forecast.announce(overhead, memory)
        self.params.update(self.forecast.estimate)
        return True

    def _time_path(self, overhead: float) -> None:
        """The λ path's normal equations (:meth:`Problem.path_normal`), and one of its products timed
        for the forecast's path term (counted with the path's)."""
        pb = self.problem
        self._path_start = pb.counter.count
        self.path_normal, self.path_counter = pb.path_normal(self.params)
        t0 = time.perf_counter()
        self.path_normal.gram.forward(pb.mf * (pb.s_a / pb.s_b))
        self.forecast.path_timed(time.perf_counter() - t0, overhead)

    def choose_lambda(self) -> None:
        """λ (and β at the kept ratio) by the warm-started path; its last solution warm-starts the
        final solve (:func:`~sarcli.regularize.lampath.auto_lambda`)."""
        pb, o = self.problem, self.options
        if self.progress is not None:
            self.progress.set_description(f"regularize {o.prior}: lam path")
        self.lam, self.beta, self.u0 = auto_lambda(pb, self.path_normal, self.T, self.D, self.u0, self.params,
                                                   self.tick)
        counter = self.path_counter
        self.products["path"] = pb.counter.count - self._path_start + (counter.count if counter is not pb.counter else 0)
        self.path_normal = self.path_counter = None
        if self.progress is not None:
            # the path stopped early: the total shrinks to what is left (not reset, so the bar's rate
            # and time estimate carry on)
            self.progress.total = getattr(self.progress, "n", 0) + o.iters
            self.progress.set_description(f"regularize {o.prior} lam={self.lam:.3g}")

    def solve(self):
        """The final solve at λ: ``(u, history)`` of the scaled problem."""
        pb, o = self.problem, self.options
        before = pb.counter.count

        def report(i, objective):
            self.tick(1)
            if self.callback is not None:
                self.callback(i, objective)

        if o.prior == "tikhonov":
            u, hist = tikhonov(pb.scaled, self.D, self.lam, x0=self.u0, tol=o.tol, max_iter=o.iters, callback=report)
        else:
            reest = None
            if o.prior == "ptv" and o.reestimate_every > 0:
                reest = Reestimate(o.reestimate_every,
                                   lambda f: sparsifying_operator("ptv", self.grid.shape, order=o.order, f0=f))
            solver = ADMM(pb.scaled, self.T, self.lam, self.beta, x0=self.u0, isotropic=o.isotropic, tol=o.tol,
                          max_iter=o.iters, inner_iters=o.inner_iters, reestimate=reest)
            u = solver.run(lambda state: report(state.iteration, state.history["objective"][-1]))
            hist = solver.history_arrays()
        self.products["final"] = pb.counter.count - before
        return u, hist

    def image(self, f, hist: dict, t0: float) -> Image:
        """The :class:`~sarcli.core.types.Image` with its record (:func:`_outcome`)."""
        p, prod = self.params, self.products
        p["lam"], p["beta"] = self.lam, self.beta
        prod.setdefault("path", 0)
        prod.setdefault("final", 0)
        p["gram_products"] = {**prod, "total": prod["scaling"] + prod["path"] + prod["final"]}
        if self.problem.scaled is not None:
            p["iterations"] = int(len(hist.get("objective", [])))
            _outcome(p, hist, self.options.prior)
        return Image(f, self.grid.x, self.grid.y, method=f"regularize-{self.options.prior}", parameters=p,
                     runtime_s=time.perf_counter() - t0, history=hist)


def regularize(ph: PhaseHistory, options: RegularizeOptions | None = None, *, grid: Grid | None = None,
               init=None, callback=None, progress=None, notice=None, **knobs) -> Image:
    """Regularised image of a phase history (paper eq. ``eq: reg`` / ``eq: main-L1``).

    Parameters
    ----------
    ph : PhaseHistory
    options : RegularizeOptions, optional
        The settings (prior, λ, β, iterations, operator, ...; see :class:`RegularizeOptions` for
        each and its default). ``lam='auto'`` (the default) chooses λ on a short warm-started path
        by SURE when the noise power is known (file attribute, or the range bins outside the
        scene) and otherwise by SURE with the noise power that modified generalised
        cross-validation's minimum implies, speckle counted as noise, with Monte-Carlo degrees of
        freedom (:mod:`sarcli.regularize.regparam`); the choice, the noise estimate and its source,
        the criterion, the path and whether λ sits at its end are recorded in
        ``parameters['lam_selection']``. ``operator='auto'``: Toeplitz when the far-field phase
        error at the grid corner is at most ``DEFOCUS_WARN_RAD``; else the warped sub-aperture
        NUFFTs (:class:`~sarcli.linops.warped.WarpedNufftOperator`) where they meet ``tolerance``
        with at least ``MIN_PULSES_PER_RUN`` pulses per sub-aperture; else the exact pair.
    grid : Grid, optional
        Image grid; default the acquisition's, modified by the knobs ``center``/``extent``/``pixel_size``
        (m), as for :func:`sarcli.formers.formation.form_image`.
    init : ndarray or Image, optional
        Initial image (physical units); for 'ptv' also the f0 whose phases define Θ
        (default f0: the matched filter).
    callback : callable, optional
        ``callback(iteration, objective)`` after each iteration of the final solve.
    progress : tqdm-like, optional
        A bar (``reset(total=)``, ``update(n)``, ``set_description(s)``, attributes ``n`` and
        ``total``) advanced once per power iteration of the scaling, per iteration of the λ path
        (both of its solvers) and of the final solve.
    notice : callable, optional
        ``notice(line)`` once, after the scaling (its products timed) and before the
        λ path, when the run is predicted to last longer than
        :data:`~sarcli.regularize.forecast.LONG_RUN_S`: the estimate, its bound and what would shorten it.
    **knobs
        Fields of :class:`RegularizeOptions` by name (``prior='tv', lam=0.05``), replacing those of
        ``options``; and ``center``, ``extent``, ``pixel_size`` for the grid.

    Returns
    -------
    Image
        ``method = 'regularize-<prior>'``, ``parameters`` with every setting and the scalings,
        the AᴴA products counted (``gram_products``), the time forecast (``predicted_s``,
        ``predicted_max_s``), ``iteration_cap_reached`` and ``advice`` (:func:`_outcome`);
        ``history`` (objective, data_residual, reg_norm, relative_change, step_size, elapsed_s).

    Warns
    -----
    DefocusWarning
        A far-field operator on spherical data with a predicted phase error above the threshold.
    ConvergenceWarning
        The iteration cap was reached before ``tol``.
    """
    if not isinstance(ph, PhaseHistory):
        raise SarcliInputError(f"regularize needs a PhaseHistory, got {type(ph).__name__}")
    where = {k: knobs.pop(k) for k in ("center", "extent", "pixel_size") if k in knobs}
    opts = RegularizeOptions.from_knobs(options, **knobs)
    opts.resolved()   # every mistake in the settings is reported before the grid's
    if grid is None:
        try:
            grid = resolve_grid(ph.acquisition.grid, **where)
        except ValueError as exc:
            raise SarcliInputError(str(exc)) from None
    return Regularization(ph, opts, grid, init=init, callback=callback, progress=progress, notice=notice).run()
