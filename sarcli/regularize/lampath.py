"""The λ path of ``lam='auto'``: two solvers side by side and the record of the choice.

:class:`PathSolver` solves the regularised problem at each λ of the path twice, iteration for
iteration, on the data and on the data plus a seeded probe, each warm-started from its own
previous solution, and returns the residual and the Monte-Carlo degrees of freedom
(:func:`sarcli.regularize.regparam.mc_dof`); :func:`auto_lambda` runs
:func:`sarcli.regularize.regparam.select_lambda` on it and records the choice in
``parameters['lam_selection']`` (docs/regularize.md, "Choosing λ").
"""

from __future__ import annotations

import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .._native import threads, using_threads
from ..errors import ConvergenceWarning
from ..linops.toeplitz import NormalEquations
from ..solvers import ADMM, tikhonov
from . import regparam
from .regparam import LAM_MIN, mc_dof

__all__ = ["PathSolver", "auto_lambda", "PATH_ITERS", "PATH_TOL", "PATH_CG_TOL", "PATH_FIRST_ITERS", "LAM_MAX",
           "PROBE_SEED", "PROBE_STEP"]

#: Iteration cap and tolerance of each solve on the λ path of ``lam='auto'`` (each warm-started
#: from the previous λ; CG for 'tikhonov' runs to its own tolerance, capped the same).
PATH_ITERS, PATH_TOL, PATH_CG_TOL = 25, 1e-3, 1e-4
#: Iteration cap of the path's first solve, the only one not warm-started from a neighbouring λ:
#: after 25 iterations from zero at λ = 0.3 its residual is still far above its limit (SURE 84
#: against −122 after 100 on a benchmark scene), which drives the criterion away from large λ.
PATH_FIRST_ITERS = 100
#: Largest λ the path of ``lam='auto'`` extends to when its criterion is smallest at the top
#: (ℓ1: λ ≥ 2 zeroes the image).
LAM_MAX = {"l1": 1.0, "tv": 10.0, "hotv": 10.0, "ptv": 10.0, "tikhonov": 10.0}
#: Monte-Carlo probe of the degrees of freedom: seed (the same λ for the same data) and the step δ
#: relative to the RMS of the scaled data.
PROBE_SEED, PROBE_STEP = 26, 1e-2

class PathSolver:
    """``solve(lam) -> (u, ‖Âu − b̂‖², dof)`` for :func:`sarcli.regularize.regparam.select_lambda`.

    Two solvers run iteration for iteration: one on the scaled data b̂, one on ``b̂ + δε`` (ε a
    seeded complex circular probe); both warm-start from their own previous path solution, so the
    Monte-Carlo degrees of freedom (:func:`sarcli.regularize.regparam.mc_dof`) are those of the path's map
    from data to image. ``Âᴴε`` is computed once; no forward application of A is needed.

    Where the Gram can be applied from two threads at once (:meth:`~sarcli.linops.base.Linop.concurrent`)
    and the kernels have two threads or more (:func:`sarcli._native.threads`), the probe's solver
    runs in a thread of its own with half of them: the two solvers are independent between
    iterations, and a product split between two solvers scales better than one product split in
    two (a transform of this size gains little from a second thread). :meth:`close` ends it.
    """

    def __init__(self, problem, scaled, T, D, u0, tick):
        op, data, s_a, s_b = problem.op, problem.ph.data, problem.s_a, problem.s_b
        iters = problem.options.iters
        rng = np.random.default_rng(PROBE_SEED)
        eps = (rng.standard_normal(data.shape) + 1j * rng.standard_normal(data.shape)) / np.sqrt(2.0)
        self.delta = PROBE_STEP * float(np.sqrt(scaled.bnorm2 / data.size))
        self.probe_adjoint = np.asarray(op.adjoint(eps), np.complex128) / s_a
        b_pert = data / s_b + self.delta * eps
        n = threads()
        twin = scaled.gram.concurrent() if n > 1 else None
        self.perturbed = NormalEquations(scaled.gram if twin is None else twin,
                                         scaled.atb + self.delta * self.probe_adjoint,
                                         float(np.vdot(b_pert, b_pert).real))
        # (threads of the calling thread, of the probe's) while the path runs
        self.split = None if twin is None else (n - n // 2, n // 2)
        self._pool = None if twin is None else ThreadPoolExecutor(1, initializer=threads, initargs=(n // 2,))
        self.scaled, self.D, self.T = scaled, D, T
        self.beta_ratio, self.isotropic = problem.options.beta_ratio, problem.options.isotropic
        self.u = self.up = u0
        self.path_iters, self.tick = min(iters, PATH_ITERS), tick
        self.first_iters = max(self.path_iters, min(iters, PATH_FIRST_ITERS))
        self.iterations = []
        self.solutions = []  # (u, u perturbed) of every call, for warm starts out of order

    def close(self):
        """End the probe's thread (where there is one)."""
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def _both(self, first, second):
        """``(first(), second())``, the second in the probe's thread where there is one."""
        if self._pool is None:
            return first(), second()
        with using_threads(self.split[0]):
            later = self._pool.submit(second)
            try:
                a = first()
            finally:
                b = later.result()
        return a, b

    def __call__(self, lam, start=None):
        if start is not None:
            self.u, self.up = self.solutions[start]
        cap = self.path_iters if self.solutions else self.first_iters

        if self.D is not None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)  # a path point need not converge
                (u, hist), (up, hp) = self._both(
                    lambda: tikhonov(self.scaled, self.D, lam, x0=self.u, tol=PATH_CG_TOL, max_iter=cap),
                    lambda: tikhonov(self.perturbed, self.D, lam, x0=self.up, tol=PATH_CG_TOL, max_iter=cap))
            its = len(hist.get("objective", []))
            self.tick(its + len(hp.get("objective", [])))
            r2 = self.scaled.residual_norm2(u, self.scaled.gram.forward(u))
        else:
            a, b = self._both(
                lambda: ADMM(self.scaled, self.T, lam, self.beta_ratio * lam, x0=self.u, isotropic=self.isotropic,
                             tol=PATH_TOL, max_iter=cap),
                lambda: ADMM(self.perturbed, self.T, lam, self.beta_ratio * lam, x0=self.up,
                             isotropic=self.isotropic, tol=PATH_TOL, max_iter=cap))
            while not a.done():
                self._both(a.step, b.step)
                self.tick(2)
            u, up, its, r2 = a.f, b.f, a.iteration, a.data_residual2()
        self.u, self.up = u, up
        self.solutions.append((u, up))
        self.iterations.append(int(its))
        return u, r2, mc_dof(self.probe_adjoint, self.delta, u, up)


def auto_lambda(problem, scaled, T, D, u0, params, tick):
    """λ by SURE (noise power known) or modified GCV (:func:`sarcli.regularize.regparam.select_lambda`)
    on the path of ``problem`` (a scaled :class:`~sarcli.regularize.problem.Problem`) solved with
    the normal equations ``scaled``; records the choice in ``params['lam_selection']``.
    Returns ``(lam, beta, warm start)``."""
    ph, grid, prior, s_b = problem.ph, problem.grid, problem.options.prior, problem.s_b
    beta_ratio, iters = problem.options.beta_ratio, problem.options.iters
    sigma2, source = regparam.noise_power(ph, grid)
    n = ph.data.size
    path = PathSolver(problem, scaled, T, D, u0, tick)
    s2_scaled = None if sigma2 is None else sigma2 / s_b**2
    kappa = regparam.speckle_fraction(grid.nx * grid.ny, n)
    try:
        choice = regparam.select_lambda(path, n, sigma2=s2_scaled, speckle_fraction=kappa,
                                        data_power=scaled.bnorm2 / n, lam_max=LAM_MAX[prior], lam_min=LAM_MIN)
    finally:
        path.close()
    criterion = "sure" if sigma2 is not None else "gcv"
    end = {"at the smallest λ": "smallest", "at the largest λ": "largest"}.get(choice.status)
    record = {"criterion": criterion,
              "gamma": None if sigma2 is not None else regparam.GCV_GAMMA,
              "noise_power": sigma2 if sigma2 is not None else choice.noise_power * s_b**2,
              "noise_source": source if sigma2 is not None else
              "GCV residual ||Af-b||^2 / (n - dof) at the chosen lam (no range bin outside the scene)",
              "speckle_fraction": kappa, "speckle_power": choice.speckle * s_b**2,
              "walk_scores": [float(v) if np.isfinite(v) else None for v in choice.walk_scores],
              "status": choice.status, "at_path_end": end, "at_limit": bool(choice.at_limit),
              "lam_floor": LAM_MIN, "lam_ceiling": LAM_MAX[prior], "lam": choice.lam, "lams": list(choice.lams),
              "scores": [float(v) if np.isfinite(v) else None for v in choice.scores],
              "dofs": list(choice.dofs), "residuals": [r * s_b**2 for r in choice.residuals],
              "n_data": int(n), "path_iters": min(int(iters), PATH_ITERS),
              "path_first_iters": path.first_iters,
              "path_iterations": list(path.iterations), "probe_step": path.delta * s_b,
              "path_threads": None if path.split is None else list(path.split)}
    params["lam_selection"] = record
    return choice.lam, beta_ratio * choice.lam, choice.start
