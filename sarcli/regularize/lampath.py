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

import numpy as np

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
#: against −122 after 100 on a benchmark scene), which drives the criterion away from large λ;
#: 50 chose as well as 100 on the λ benchmarks (docs/regularize.md) at a quarter less path.
PATH_FIRST_ITERS = 50
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
    """

    def __init__(self, problem, scaled, T, D, u0, tick):
        op, data, s_a, s_b = problem.op, problem.ph.data, problem.s_a, problem.s_b
        iters = problem.options.iters
        rng = np.random.default_rng(PROBE_SEED)
        eps = (rng.standard_normal(data.shape) + 1j * rng.standard_normal(data.shape)) / np.sqrt(2.0)
        self.delta = PROBE_STEP * float(np.sqrt(scaled.bnorm2 / data.size))
        self.probe_adjoint = np.asarray(op.adjoint(eps), np.complex128) / s_a
        b_pert = data / s_b + self.delta * eps
        self.perturbed = NormalEquations(scaled.gram, scaled.atb + self.delta * self.probe_adjoint,
                                         float(np.vdot(b_pert, b_pert).real))
        self.scaled, self.D, self.T = scaled, D, T
        self.beta_ratio, self.isotropic = problem.options.beta_ratio, problem.options.isotropic
        self.u = self.up = u0
        self.path_iters, self.tick = min(iters, PATH_ITERS), tick
        self.first_iters = max(self.path_iters, min(iters, PATH_FIRST_ITERS))
        self.iterations = []
        self.solutions = []  # (u, u perturbed) of every call, for warm starts out of order

    def __call__(self, lam, start=None):
        if start is not None:
            self.u, self.up = self.solutions[start]
        cap = self.path_iters if self.solutions else self.first_iters

        if self.D is not None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)  # a path point need not converge
                u, hist = tikhonov(self.scaled, self.D, lam, x0=self.u, tol=PATH_CG_TOL, max_iter=cap)
                up, hp = tikhonov(self.perturbed, self.D, lam, x0=self.up, tol=PATH_CG_TOL, max_iter=cap)
            its = len(hist.get("objective", []))
            self.tick(its + len(hp.get("objective", [])))
            r2 = self.scaled.residual_norm2(u, self.scaled.gram.forward(u))
        else:
            a = ADMM(self.scaled, self.T, lam, self.beta_ratio * lam, x0=self.u, isotropic=self.isotropic,
                     tol=PATH_TOL, max_iter=cap)
            b = ADMM(self.perturbed, self.T, lam, self.beta_ratio * lam, x0=self.up, isotropic=self.isotropic,
                     tol=PATH_TOL, max_iter=cap)
            while not a.done():
                a.step()
                b.step()
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
    choice = regparam.select_lambda(path, n, noise=regparam.Noise(s2_scaled, kappa, scaled.bnorm2 / n),
                                    lam_max=LAM_MAX[prior], lam_min=LAM_MIN)
    criterion = "sure" if sigma2 is not None else "gcv"
    end = {"at the smallest λ": "smallest", "at the largest λ": "largest"}.get(choice.status)
    record = {"criterion": criterion,
              "gamma": None if sigma2 is not None else regparam.GCV_GAMMA,
              "noise_power": sigma2 if sigma2 is not None else choice.noise_power * s_b**2,
              "noise_code": regparam.NOISE_CODES.get(source, "gcv") if sigma2 is not None else "gcv",
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
              "path_iterations": list(path.iterations), "probe_step": path.delta * s_b}
    params["lam_selection"] = record
    return choice.lam, beta_ratio * choice.lam, choice.start
