"""Regularised reconstruction (paper section ``sec: reg``, Appendices A-B): :func:`regularize`.

Solves, on an image grid,

    min_f ‖A f - b‖² + λ ‖T f‖₁          (ADMM; priors 'l1', 'tv', 'hotv', 'ptv')
    min_f ‖A f - b‖² + λ ‖Dᵏ f‖²         (conjugate gradients; prior 'tikhonov')

with A the forward model of the data (far-field pixel model as a NUFFT pair or its pre-gridded
Toeplitz form; for spherical data the sub-aperture NUFFTs on warped pixel positions of
:mod:`sarcli.linops.warped`, held to a tolerance, or the exact reprojection/backprojection pair)
and T the identity, D, Dᵏ or
D Θ with Θ = diag(exp(-i arg f0)) and f0 the matched filter (phase-corrected TV, the paper's
choice for SAR, whose pixels have random phases).

Scaling (so that λ and β mean the same whatever the units of b): as in the paper's reference
solver the operator is normalised to ``‖Â‖₂ = 1`` (``Â = A / s_A``, ``s_A`` by power iteration)
and the data are scaled, ``b̂ = b / s_b``; here ``s_b`` makes ``max |Âᴴ b̂| = 1`` (the reference
uses the data's dynamic range; the back-projected maximum is the quantity the ℓ1 threshold acts
on). The problem is solved for ``u`` with ``Â``, ``b̂``; then ``f = u s_b / s_A``. Consequences:
for the ℓ1 prior every λ ≥ 2 gives f = 0, so λ is a fraction of that; the defaults below are
fractions that work on the synthetic scenes of the tests.

Normalisation of the output: f is the pixel reflectivity of the pixel model (eq. ``2D-DFT``):
the least-squares image of a unit point scatterer at a pixel centre is exactly 1 at that pixel,
the same peak the matched filter (``Aᴴb / (P M)``) gives, so regularised and matched-filter
images share one scale.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from ..core import geometry
from ..errors import DefocusWarning, SarcliInputError
from ..core.grid import Grid, resolve_grid
from ..core.types import Image, PhaseHistory
from ..formers.planning.cost import regularize_bytes
from ..linops import (NufftOperator, SphericalOperator, gram_eigmax, normal_equations,
                     sparsifying_operator)
from ..linops.toeplitz import NormalEquations
from ..linops.finite_diff import FiniteDifference
from .forecast import CountedGram, Forecast, solver_overhead
from .lampath import PATH_FIRST_ITERS, PATH_ITERS, auto_lambda
from .regparam import SELECT_PATH
from ..solvers import ADMM, tikhonov

__all__ = ["regularize", "PRIORS", "OPERATORS", "DEFAULT_LAM", "DEFAULT_BETA_RATIO",
           "matched_filter", "scale_problem"]

PRIORS = ("l1", "tv", "hotv", "ptv", "tikhonov")
OPERATORS = ("auto", "nufft", "toeplitz", "warped", "spherical")
#: Relative error of AᴴA (against the exact spherical model) the 'warped' operator is held to.
DEFAULT_OPERATOR_TOLERANCE = 1e-3
#: 'auto' takes the warped operator only with at least this many pulses per sub-aperture: with
#: fewer, spreading every pixel once per sub-aperture costs about what backprojecting them does.
MIN_PULSES_PER_RUN = 32
#: Default λ per prior, in the normalised units above (ℓ1: λ ≥ 2 zeroes the image).
DEFAULT_LAM = {"l1": 0.05, "tv": 0.02, "hotv": 0.02, "ptv": 0.02, "tikhonov": 0.05}
#: Default β = ratio · λ: the shrinkage threshold λ/β is then 1/32 of the normalised image scale,
#: the reference solver's β = 2⁵ (with its data term μ/2 = 1/λ).
DEFAULT_BETA_RATIO = 32.0
#: Phase error (rad) above which 'auto' picks the spherical pair (and a far-field pair warns).
DEFOCUS_WARN_RAD = geometry.DEFOCUS_WARN_RAD


def _choose_operator(ph: PhaseHistory, grid: Grid, operator: str, tolerance: float):
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
                      f"spherical", DefocusWarning, stacklevel=3)
    if operator in ("spherical", "warped") and not acq.has_positions:
        raise SarcliInputError(f"operator '{operator}' needs antenna positions; this file has none")
    return operator, err, runs


def _build(ph: PhaseHistory, grid: Grid, operator: str, eps: float, tolerance: float, runs):
    """``(operator, normal equations, the half-count warped operator the chooser built or None)``."""
    acq = ph.acquisition
    if operator == "spherical":
        op = SphericalOperator.from_acquisition(acq, grid)
        return op, normal_equations(op, ph.data, form="nufft"), None
    if operator == "warped":
        # AᴴA by the warped operator; Aᴴb by the exact pair (one backprojection), so that the only
        # approximation in the normal equations is AᴴA's, whose error the tolerance bounds
        from ..linops import norm2
        from ..linops.warped import EPS_MIN, WarpedNufftOperator

        # the chooser's count, its AᴴA error and the operators it measured on
        count, err, built = (None, None, {}) if runs is None else runs
        op = built.get(count)
        if op is None or op.eps != max(tolerance / 10, EPS_MIN):
            op = WarpedNufftOperator(acq, grid, subapertures="auto" if count is None else count,
                                     tolerance=tolerance, predicted_error=err)
        else:
            op.predicted_error = float(err)
        atb = SphericalOperator.from_acquisition(acq, grid).adjoint(ph.data)
        # the λ path's operator (half the sub-apertures) where the chooser made it; the others go
        half = built.get(max(1, op.subapertures // 2)) if op.subapertures > 1 else None
        return op, NormalEquations(op.gram(), atb, norm2(np.asarray(ph.data))), half
    op = NufftOperator.from_acquisition(acq, grid, eps=eps)
    return op, normal_equations(op, ph.data, form=operator), None


def _path_normal_equations(op, normal, s_a: float, s_b: float, params: dict, half=None):
    """The scaled normal equations the λ path of a warped operator solves, and their counted Gram:
    the same ``Aᴴb`` and scaling, ``AᴴA`` from half the sub-apertures (a product at about half the
    final one's cost, an error about 4 × the tolerance: the residual grows as the square of a
    sub-aperture's angle). The path only ranks λ and warm-starts the final solve,
    which runs on the operator held to the tolerance. ``half``: that operator, where the
    sub-aperture chooser already built it."""
    from ..linops.warped import WarpedNufftOperator

    path_op = half
    if path_op is None or path_op.eps != op.eps:
        path_op = WarpedNufftOperator(op.acquisition, op.grid, subapertures=max(1, op.subapertures // 2), eps=op.eps)
    counter = CountedGram(path_op.gram())
    params["path_operator"] = {"subapertures": path_op.subapertures,
                               "predicted_error": path_op.predicted_error}
    return NormalEquations(counter, normal.atb, normal.bnorm2).scaled(s_a, s_b), counter


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
                   eps: float = 1e-9) -> np.ndarray:
    """``Aᴴb / (P M)``: the matched filter (eq. ``mf``) of the operator pair used here."""
    grid = ph.acquisition.grid if grid is None else grid
    op = SphericalOperator.from_acquisition(ph.acquisition, grid) if operator in ("spherical", "warped") \
        else NufftOperator.from_acquisition(ph.acquisition, grid, eps=eps)
    return op.adjoint(ph.data) / ph.data.size


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


def regularize(ph: PhaseHistory, *, prior: str = "ptv", order: int = 1, lam: float | str | None = "auto",
               beta: float | None = None, iters: int = 300, tol: float = 1e-4, operator: str = "auto",
               grid: Grid | None = None, center=None, extent=None, pixel_size=None, init=None,
               isotropic: bool = True, callback=None, inner_iters: int = 1, reestimate_every: int = 0,
               eps: float = 1e-9, tolerance: float = DEFAULT_OPERATOR_TOLERANCE, progress=None,
               notice=None) -> Image:
    """Regularised image of a phase history (paper eq. ``eq: reg`` / ``eq: main-L1``).

    Parameters
    ----------
    ph : PhaseHistory
    prior : {'l1', 'tv', 'hotv', 'ptv', 'tikhonov'}
        ℓ1 (T = I), TV (D), higher-order TV (Dᵏ), phase-corrected TV (Dᵏ Θ), Tikhonov (‖Dᵏf‖²).
    order : {1, 2, 3}
        k for 'hotv', 'ptv' and 'tikhonov'.
    lam : float, 'auto' or None
        λ in the normalised units of the module docstring. 'auto' (default): chosen on a short
        warm-started path by SURE when the noise power is known (file attribute, or the range
        bins outside the scene) and otherwise by SURE with the noise power that modified
        generalised cross-validation's minimum implies, speckle counted as noise, with
        Monte-Carlo degrees of freedom (:mod:`sarcli.regularize.regparam`); the choice, the noise
        estimate and its source, the criterion, the path and whether λ sits at its end are
        recorded in ``parameters['lam_selection']``. None: :data:`DEFAULT_LAM`.
    beta : float, optional
        ADMM penalty β (default ``DEFAULT_BETA_RATIO · λ``; with ``lam='auto'`` the ratio β/λ
        of a given β at the default λ is kept).
    iters, tol : int, float
        Iteration cap and relative-change tolerance (CG residual tolerance for 'tikhonov').
    operator : {'auto', 'nufft', 'toeplitz', 'warped', 'spherical'}
        Forward model: the far-field NUFFT pair or its pre-gridded Toeplitz form; for spherical
        data the warped sub-aperture NUFFTs (:class:`~sarcli.linops.warped.WarpedNufftOperator`,
        AᴴA within ``tolerance`` of the exact model) or the exact reprojection/backprojection pair.
        'auto': Toeplitz when the far-field phase error at the grid corner is at most
        :data:`DEFOCUS_WARN_RAD`; else warped where it meets ``tolerance`` with at least
        :data:`MIN_PULSES_PER_RUN` pulses per sub-aperture; else the exact pair.
    grid : Grid, optional
        Image grid; default the acquisition's, modified by ``center``/``extent``/``pixel_size``.
    center, extent, pixel_size : optional
        Grid overrides (m), as for :func:`sarcli.formers.formation.form_image`.
    init : ndarray or Image, optional
        Initial image (physical units); for 'ptv' also the f0 whose phases define Θ
        (default f0: the matched filter).
    isotropic : bool
        Isotropic (per-pixel vector) or anisotropic shrinkage of the differences.
    callback : callable, optional
        ``callback(iteration, objective)`` after each iteration.
    inner_iters : int
        Gradient steps per ADMM iteration.
    reestimate_every : int
        'ptv': re-estimate Θ from the iterate every this many iterations (0: never).
    eps : float
        NUFFT tolerance of the far-field operators.
    tolerance : float
        Relative error of AᴴA (against the exact spherical model) the warped operator is held to
        (its sub-apertures are chosen for it).
    progress : tqdm-like, optional
        A bar (``reset(total=)``, ``update(n)``, ``set_description(s)``, attributes ``n`` and
        ``total``) advanced once per power iteration of the scaling, per iteration of the λ path
        (both of its solvers) and of the final solve.
    notice : callable, optional
        ``notice(line)`` once, after the scaling (its second AᴴA product timed) and before the
        λ path, when the run is
        predicted to last longer than :data:`~sarcli.regularize.forecast.LONG_RUN_S`: the estimate, its bound and what would
        shorten it.

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
    t0 = time.perf_counter()
    if not isinstance(ph, PhaseHistory):
        raise SarcliInputError(f"regularize needs a PhaseHistory, got {type(ph).__name__}")
    if prior not in PRIORS:
        raise SarcliInputError(f"unknown prior {prior!r}; choose one of {', '.join(PRIORS)}")
    if operator not in OPERATORS:
        raise SarcliInputError(f"unknown operator {operator!r}; choose one of {', '.join(OPERATORS)}")
    if int(order) not in (1, 2, 3):
        raise SarcliInputError(f"order must be 1, 2 or 3, got {order}")
    auto = isinstance(lam, str)
    if auto and lam != "auto":
        raise SarcliInputError(f"lam must be a number >= 0 or 'auto', got {lam!r}")
    lam = DEFAULT_LAM[prior] if (lam is None or auto) else float(lam)
    if not (np.isfinite(lam) and lam >= 0):
        raise SarcliInputError(f"lam must be a finite number >= 0, got {lam}")
    beta_ratio = DEFAULT_BETA_RATIO if (beta is None or lam == 0) else float(beta) / lam
    beta = DEFAULT_BETA_RATIO * lam if beta is None else float(beta)
    if prior != "tikhonov" and beta == 0.0:
        beta = DEFAULT_BETA_RATIO * np.finfo(float).tiny ** 0.5  # λ = 0: any β > 0 works
    if prior != "tikhonov" and not (np.isfinite(beta) and beta > 0):
        raise SarcliInputError(f"beta must be a finite number > 0, got {beta}")
    if int(iters) < 1 or not (tol > 0):
        raise SarcliInputError(f"iters must be >= 1 and tol > 0, got {iters}, {tol}")
    if grid is None:
        try:
            grid = resolve_grid(ph.acquisition.grid, center=center, extent=extent, pixel_size=pixel_size)
        except ValueError as exc:
            raise SarcliInputError(str(exc)) from None
    if init is not None:
        init = np.asarray(init.image if isinstance(init, Image) else init, np.complex128)
        if init.shape != grid.shape:
            raise SarcliInputError(f"initial image shape {init.shape} does not match the grid {grid.shape}")
    if not (0 < tolerance < 1):
        raise SarcliInputError(f"tolerance must be in (0, 1), got {tolerance}")
    operator, phase_err, runs = _choose_operator(ph, grid, operator, tolerance)
    op, normal, half = _build(ph, grid, operator, eps, tolerance, runs)
    runs = None   # the chooser's other operators are not kept
    if not auto:
        half = None
    counter = CountedGram(normal.gram)
    normal = NormalEquations(counter, normal.atb, normal.bnorm2)
    n_samples = ph.data.size
    mf = normal.atb / n_samples
    # the spherical AᴴA is two backprojections: fewer power iterations (the far-field forms share 30
    # so that 'nufft' and 'toeplitz' scale identically)
    power_iters = 10 if operator in ("spherical", "warped") else 30
    if progress is not None:
        path_cap = 2 * (PATH_ITERS * (len(SELECT_PATH) - 1) + PATH_FIRST_ITERS) if auto else 0
        progress.reset(total=power_iters + path_cap + int(iters))
        progress.set_description(f"regularize {prior}: scaling")

    def tick(k):
        if progress is not None:
            progress.update(k)

    # a warped product costs about (runs + 1) units: the spreading per run, the FFTs of all runs
    # about one more (each run's grid widens as the runs lengthen); the path has half the runs
    path_cost = (max(1, op.subapertures // 2) + 1) / (op.subapertures + 1) if operator == "warped" else 1.0
    forecast = Forecast(prior, operator, power_iters, int(iters), auto, notice, tick, path_cost=path_cost)
    scaled, s_a, s_b = scale_problem(normal, power_iters=power_iters, callback=forecast.on_power)
    params = {"prior": prior, "order": int(order), "lam": lam, "beta": beta, "iters": int(iters),
              "tol": float(tol), "operator": operator, "isotropic": bool(isotropic),
              "inner_iters": int(inner_iters), "reestimate_every": int(reestimate_every), "eps": eps,
              "grid": grid.as_dict(), "init": init is not None, "scale_operator": s_a,
              "scale_data": s_b, "scale_power_iterations": power_iters,
              "farfield_phase_error_rad": phase_err, "model": ph.model,
              **({"operator_tolerance": tolerance, "subapertures": op.subapertures,
                  "operator_predicted_error": op.predicted_error} if operator == "warped" else {}),
              "normalisation": "pixel-model reflectivity f = u * scale_data / scale_operator: a unit point "
                               "at a pixel centre recovered exactly is 1, the matched filter's peak"}
    if scaled is None:
        # no data (or no operator): the solution of every prior is 0
        params["gram_products"] = {"scaling": counter.count, "path": 0, "final": 0, "total": counter.count}
        return Image(np.zeros(grid.shape, np.complex128), grid.x, grid.y, method=f"regularize-{prior}",
                     parameters=params, runtime_s=time.perf_counter() - t0, history={})
    products = {"scaling": counter.count}
    u0 = None if init is None else init * (s_a / s_b)
    D = FiniteDifference(grid.shape, order) if prior == "tikhonov" else None
    f0 = init if init is not None else mf
    T = None if D is not None else sparsifying_operator(prior, grid.shape, order=order,
                                                        f0=f0 if prior == "ptv" else None)
    memory = regularize_bytes(*ph.data.shape, grid, operator, np.dtype(ph.data.dtype).itemsize, auto=auto)
    forecast.announce(solver_overhead(T, D, mf), memory)
    params.update(forecast.estimate)
    if progress is not None:
        progress.set_description(f"regularize {prior}" + (": lam path" if auto else ""))
    if auto:
        path_normal, path_counter = scaled, counter
        if operator == "warped" and op.subapertures > 1:
            path_normal, path_counter = _path_normal_equations(op, normal, s_a, s_b, params, half)
        half = None
        lam, beta, u0 = auto_lambda(ph, grid, op, path_normal, s_a, s_b, D, T, prior, beta_ratio, isotropic, u0,
                                    iters, params, tick)
        if path_counter is not counter:
            products["path_subapertures"] = path_counter.count
        if progress is not None:
            # the path stopped early: the total shrinks to what is left (not reset, so the bar's rate
            # and time estimate carry on)
            progress.total = getattr(progress, "n", 0) + int(iters)
            progress.set_description(f"regularize {prior} lam={lam:.3g}")
    products["path"] = counter.count - products["scaling"] + products.get("path_subapertures", 0)
    if prior == "tikhonov":
        def cg_cb(i, obj):
            tick(1)
            if callback is not None:
                callback(i, obj)

        u, hist = tikhonov(scaled, D, lam, x0=u0, tol=tol, max_iter=iters, callback=cg_cb)
    else:
        reest = None
        if prior == "ptv" and reestimate_every > 0:
            reest = lambda f: sparsifying_operator("ptv", grid.shape, order=order, f0=f)  # noqa: E731
        solver = ADMM(scaled, T, lam, beta, x0=u0, isotropic=isotropic, tol=tol, max_iter=iters,
                      inner_iters=inner_iters, reestimate=reest, reestimate_every=reestimate_every)

        def cb(state):
            tick(1)
            if callback is not None:
                callback(state.iteration, state.history["objective"][-1])

        u = solver.run(cb)
        hist = solver.history_arrays()
    f = u * (s_b / s_a)
    params["lam"], params["beta"] = lam, beta
    params["iterations"] = int(len(hist.get("objective", [])))
    products["final"] = counter.count - products["scaling"] - products["path"] + products.pop("path_subapertures", 0)
    params["gram_products"] = {**products, "total": products["scaling"] + products["path"] + products["final"]}
    _outcome(params, hist, prior)
    return Image(f, grid.x, grid.y, method=f"regularize-{prior}", parameters=params,
                 runtime_s=time.perf_counter() - t0, history=hist)
