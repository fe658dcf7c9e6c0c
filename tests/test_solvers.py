"""ADMM (Appendix A), complex shrinkage (section ``sec: g``), Tikhonov (eq. ``eq: Tik``),
the paper's 1-D sawtooth example and the Appendix B optimality conditions."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.optimize
import scipy.signal

from sarcli.errors import ConvergenceWarning
from sarcli.linops import FiniteDifference, Identity, MatrixLinop, SubsampledDFT, normal_equations
from sarcli.regularize import DEFAULT_BETA_RATIO, scale_problem
from sarcli.solvers import ADMM, complex_shrinkage, shrink, tikhonov


def _crandn(rng, shape):
    return rng.standard_normal(shape) + 1j * rng.standard_normal(shape)


# ---------------------------------------------------------------------------------------------
# shrinkage
def _brute_minimise(F, dim, start, grad):
    """Minimise a convex function of ``dim`` complex numbers numerically, tightly.

    Nelder-Mead first (robust at the kink z = 0); away from 0 a polish by a root of the analytic
    gradient ``grad(z)`` (complex, ∂/∂x + i ∂/∂y) since F's values alone fix z to only ~1e-8.
    """
    res = scipy.optimize.minimize(lambda v: F(v[:dim] + 1j * v[dim:]), start, method="Nelder-Mead",
                                  options={"xatol": 1e-13, "fatol": 1e-16, "maxiter": 20000,
                                           "maxfev": 40000})
    v = res.x
    if np.linalg.norm(v) > 1e-6:  # smooth away from 0: polish with a gradient method
        def g(w):  # F is convex and smooth here: its minimiser is the root of the gradient
            gz = np.atleast_1d(grad(w[:dim] + 1j * w[dim:]))
            return np.concatenate([gz.real, gz.imag])

        v = scipy.optimize.root(g, v, method="hybr", options={"xtol": 1e-15}).x
    return v[:dim] + 1j * v[dim:]


@pytest.mark.parametrize("seed", range(8))
def test_complex_shrinkage_is_the_minimiser(seed):
    """Proposition (sec: g): argmin β/2|z-z0|² + |z| + Re(conj(σ) z) to 1e-8."""
    rng = np.random.default_rng(seed)
    z0, sigma = _crandn(rng, ()), _crandn(rng, ())
    beta = float(rng.uniform(0.3, 5.0))
    if seed % 2:  # half the cases have the minimiser at 0
        sigma = beta * z0 + 0.5 * (sigma / abs(sigma))
    F = lambda z: 0.5 * beta * abs(z - z0) ** 2 + abs(z) + (np.conj(sigma) * z).real  # noqa: E731
    z = complex_shrinkage(z0, sigma, beta)
    grad = lambda z: beta * (z - z0) + z / abs(z) + sigma  # noqa: E731
    zb = _brute_minimise(lambda v: F(v[0]), 1, np.array([z0.real, z0.imag]) * 0.9,
                         lambda v: grad(v[0]))[0]
    assert abs(z - zb) < 1e-8
    assert F(z) <= F(zb) + 1e-14


def test_isotropic_shrinkage_is_the_vector_minimiser():
    """Grouped shrinkage minimises β/2‖z-z0‖² + λ‖z‖₂ + Re(σᴴz) over C² (isotropic TV)."""
    rng = np.random.default_rng(5)
    z0, sigma = _crandn(rng, (2, 1)), _crandn(rng, (2, 1))
    beta, lam = 1.7, 0.6
    F = lambda z: (0.5 * beta * np.sum(np.abs(z - z0[:, 0]) ** 2) + lam * np.linalg.norm(z)  # noqa: E731
                   + np.sum((np.conj(sigma[:, 0]) * z).real))
    z = complex_shrinkage(z0, sigma, beta, lam, group_axis=0)[:, 0]
    grad = lambda z: beta * (z - z0[:, 0]) + lam * z / np.linalg.norm(z) + sigma[:, 0]  # noqa: E731
    zb = _brute_minimise(F, 2, np.concatenate([z0[:, 0].real, z0[:, 0].imag]), grad)
    assert np.max(np.abs(z - zb)) < 1e-8


@pytest.mark.parametrize("group, k", [(False, 1), (True, 2), (True, 3)])
def test_compiled_shrink_update_satisfies_the_proposition(group, k):
    """The fused compiled g-step ADMM calls (linops._reduce.shrink_update) is the Proposition's
    minimiser of β/2|g - Tf|² + λ|g| + Re(σ̄ g): equal to complex_shrinkage, optimal by the
    subgradient condition entry by entry, brute-force minimiser at a few entries; σ' = σ - β(Tf - g).
    ℓ1 (k = 1) and isotropic TV (k = 2) have their own vectorised loops, k = 3 the general one."""
    from sarcli.linops._reduce import shrink_update

    rng = np.random.default_rng(11)
    shape = (k, 300) if group else (300,)
    tf, sigma = _crandn(rng, shape), _crandn(rng, shape)
    beta, lam = 1.3, (2.0 * np.sqrt(k / 2) if group else 0.9)
    g, sig_new, reg = shrink_update(tf, sigma, beta, lam / beta, group)
    ax = 0 if group else None
    assert np.max(np.abs(g - complex_shrinkage(tf, sigma, beta, lam, group_axis=ax))) < 1e-14
    assert np.max(np.abs(sig_new - (sigma - beta * (tf - g)))) < 1e-13
    norms = (lambda z: np.sqrt(np.sum(np.abs(z) ** 2, axis=0))) if group else np.abs
    assert reg == pytest.approx(np.sum(norms(tf)), rel=1e-13)
    gn = norms(g)
    nz = gn > 0
    assert 0.2 < nz.mean() < 0.95  # both branches of the Proposition are exercised
    # 0 ∈ β(g - Tf) + λ ∂|g| + σ
    resid = beta * (g - tf) + sigma
    unit = g / np.where(nz, gn, 1.0)
    assert np.max(np.abs((resid + lam * unit)[..., nz])) < 1e-12
    assert np.all(norms(resid)[~nz] <= lam + 1e-12)
    if not group:
        for i in np.flatnonzero(nz)[:2].tolist() + np.flatnonzero(~nz)[:2].tolist():
            F = lambda z: 0.5 * beta * abs(z - tf[i]) ** 2 + lam * abs(z) + (np.conj(sigma[i]) * z).real  # noqa: E731
            grad = lambda z: beta * (z - tf[i]) + lam * z / abs(z) + sigma[i]  # noqa: E731
            zb = _brute_minimise(lambda v: F(v[0]), 1, np.array([tf[i].real, tf[i].imag]) * 0.9,
                                 lambda v: grad(v[0]))[0]
            assert abs(g[i] - zb) < 1e-7


@pytest.mark.parametrize("isotropic", [False, True])
def test_admm_step_g_and_multiplier_follow_the_proposition(isotropic):
    """One ADMM iteration: g is complex_shrinkage(Tf, σ, β, λ) of the f-step's Tf and the previous σ."""
    rng = np.random.default_rng(2)
    normal = normal_equations(MatrixLinop(_crandn(rng, (40, 64))), _crandn(rng, 40))
    T = FiniteDifference((64,), 1)
    solver = ADMM(normal, T, 0.7, 2.1, isotropic=isotropic, max_iter=10)
    for _ in range(3):
        s0 = solver.sigma.copy()
        solver.step()
        ax = solver.group_axis
        assert np.max(np.abs(solver.g - complex_shrinkage(solver.Tf, s0, 2.1, 0.7, group_axis=ax))) < 1e-13
        assert np.max(np.abs(solver.sigma - (s0 - 2.1 * (solver.Tf - solver.g)))) < 1e-12


def test_admm_reused_by_products_change_nothing():
    """The values one pass hands to the next (w = β(Tf - g) - σ from the g-step, the BB products
    from the end of an iteration, ‖Tf - Tf_p‖² from the backtracking test) give the iterates of
    the solver that recomputes them all, and the gradient the eq. ``eq: grad`` formula."""
    from sarcli.linops import sparsifying_operator

    rng = np.random.default_rng(5)
    shape = (12, 10)
    normal = normal_equations(MatrixLinop(_crandn(rng, (90, 120)), ishape=shape), _crandn(rng, 90))
    T = sparsifying_operator("ptv", shape, f0=_crandn(rng, shape))
    fast, slow = (ADMM(normal, T, 0.3, 2.0, max_iter=30) for _ in range(2))
    for _ in range(12):
        s = slow
        ref = 2.0 * (s.Gf - normal.atb) + T.adjoint(s.beta * (s.Tf - s.g) - s.sigma)
        assert np.max(np.abs(fast.gradient() - ref)) <= 1e-12 * np.max(np.abs(ref))
        fast.step()
        slow._w_of = slow._bb_of = slow._tt_of = None  # recompute everything
        slow.step()
        assert fast._bb_of is not None and fast._w_of is not None
    for k in ("objective", "data_residual", "reg_norm", "relative_change", "step_size"):
        assert np.allclose(fast.history[k], slow.history[k], rtol=1e-12, atol=0)
    assert np.max(np.abs(fast.f - slow.f)) <= 1e-12 * np.max(np.abs(slow.f))
    assert np.max(np.abs(fast.sigma - slow.sigma)) <= 1e-12 * np.max(np.abs(slow.sigma))


def test_admm_never_overwrites_arrays_held_outside():
    """g and σ are written in place only when nothing else refers to them (nor to their memory)."""
    rng = np.random.default_rng(6)
    normal = normal_equations(MatrixLinop(_crandn(rng, (50, 64)), ishape=(8, 8)), _crandn(rng, 50))
    solver = ADMM(normal, FiniteDifference((8, 8)), 0.4, 3.0, max_iter=20)
    for _ in range(3):
        solver.step()
    g_id = id(solver.g)
    solver.step()
    assert id(solver.g) == g_id  # reused: nothing else held it
    held, view = solver.sigma, solver.g[0]
    held_copy, view_copy = held.copy(), view.copy()
    for _ in range(3):
        solver.step()
    assert solver.sigma is not held and np.array_equal(held, held_copy)
    assert np.array_equal(view, view_copy)


@pytest.mark.parametrize("group, k", [(False, 2), (True, 2), (True, 3)])
def test_shrink_update_w_output(group, k):
    """``shrink_update(..., w=)`` also writes β(Tf - g) - σ', what the next gradient needs."""
    from sarcli.linops._reduce import empty, shrink_update

    rng = np.random.default_rng(3)
    tf, sigma = _crandn(rng, (k, 7, 9)), _crandn(rng, (k, 7, 9))
    w = empty(tf.shape)
    g, sig_new, _ = shrink_update(tf, sigma, 1.7, 0.4, group, w=w)
    assert np.max(np.abs(w - (1.7 * (tf - g) - sig_new))) < 1e-13
    with pytest.raises(ValueError):
        shrink_update(tf, sigma, 1.7, 0.4, group, w=np.empty((k, 7, 8), complex))


def test_shrink_zero_and_threshold():
    z = np.array([0.0, 3 + 4j, 0.1j])
    out = shrink(z, 1.0)
    assert out[0] == 0 and out[2] == 0 and np.allclose(out[1], (3 + 4j) * 4 / 5)


# ---------------------------------------------------------------------------------------------
# Tikhonov
def test_tikhonov_cg_matches_closed_form():
    """eq. Tik: (AᴴA + λDᴴD)⁻¹ Aᴴb on a small dense problem, to 1e-8."""
    rng = np.random.default_rng(1)
    n, m, lam = 40, 30, 0.37
    A = MatrixLinop(_crandn(rng, (m, n)))
    b = _crandn(rng, m)
    D = FiniteDifference((n,), 1)
    Dm = np.stack([D.forward(e)[0] for e in np.eye(n)], axis=1)
    ref = np.linalg.solve(A.matrix.conj().T @ A.matrix + lam * Dm.conj().T @ Dm, A.matrix.conj().T @ b)
    f, hist = tikhonov(normal_equations(A, b), D, lam, tol=1e-13, max_iter=2000)
    assert np.linalg.norm(f - ref) / np.linalg.norm(ref) < 1e-8
    assert hist["objective"].size > 1 and np.all(np.isfinite(hist["objective"]))


# ---------------------------------------------------------------------------------------------
# the paper's 1-D example (section sec: reg)
def test_sawtooth_tv_removes_gibbs():
    """Sawtooth from its coefficients i/(πk), |k| ≤ 75: TV vs partial sum and Hann-filtered sum.

    Pixel model: cell averages on N = 512 cells of [-1/2, 1/2) (the jump at 0 between two cells),
    so ``f̂_k = Σ_j f_j h sinc(k h) e^{-2πi k x_j}`` holds exactly for the sampled truth.
    """
    n, K = 512, 75
    x = (np.arange(n) + 0.5) / n - 0.5
    f = np.where(x < 0, 2 * x + 2, 2 * x)
    k = np.arange(-K, K + 1)
    coef = np.where(k == 0, 1.0 + 0j, 1j / (np.pi * np.where(k == 0, 1, k)))
    A = MatrixLinop(np.exp(-2j * np.pi * np.outer(k, x)) / n * np.sinc(k / n)[:, None])
    scaled, s_a, s_b = scale_problem(normal_equations(A, coef))
    lam = 1e-3
    solver = ADMM(scaled, FiniteDifference((n,)), lam, DEFAULT_BETA_RATIO * lam, tol=1e-6, max_iter=3000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        tv = (solver.run() * s_b / s_a).real
    synth = np.exp(2j * np.pi * np.outer(x, k))
    partial = (synth @ coef).real
    hann = (synth @ (scipy.signal.windows.hann(2 * K + 3)[1:-1] * coef)).real

    def overshoot(r):
        return max(r.max() - 2.0, -r.min(), 0.0)

    assert overshoot(partial) > 0.15  # Gibbs: ~9% of the jump of 2
    assert overshoot(tv) < overshoot(partial) / 3
    # away from the jump (all but the two cells touching it): RMS error no worse than Hann's
    away = np.abs(x) > 1.0 / n

    def rms(r):
        return np.sqrt(np.mean((r - f)[away] ** 2))

    assert rms(tv) <= rms(hann)
    # out-of-band coefficients 75 < |k| ≤ 150 track the true i/(πk)
    kk = np.concatenate([-np.arange(K + 1, 2 * K + 1), np.arange(K + 1, 2 * K + 1)])
    est = np.exp(-2j * np.pi * np.outer(kk, x)) @ tv / n * np.sinc(kk / n)
    true = 1j / (np.pi * kk)
    corr = np.vdot(true, est).real / (np.linalg.norm(true) * np.linalg.norm(est))
    assert corr > 0.8


# ---------------------------------------------------------------------------------------------
# Appendix A 2-D example
def _appendix_a_problem():
    rng = np.random.default_rng(0)
    n = 64
    f = np.zeros((n, n))
    f[10:30, 12:40] = 1.0
    f[35:55, 20:50] = 0.5
    f[40:50, 5:15] = -0.7
    A = SubsampledDFT(rng.random((n, n)) < 0.5)  # half the rows of the unitary DFT
    b0 = A.forward(f.astype(complex))
    noise = _crandn(rng, b0.shape)
    noise *= np.linalg.norm(b0) / np.linalg.norm(noise) / 2.0  # SNR 2
    return f, A, b0 + noise


def test_appendix_a_objective_decreases_and_beats_zero_filling():
    f, A, b = _appendix_a_problem()
    scaled, s_a, s_b = scale_problem(normal_equations(A, b))
    lam = 0.3
    solver = ADMM(scaled, FiniteDifference(f.shape), lam, DEFAULT_BETA_RATIO * lam, tol=1e-5, max_iter=300)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        u = solver.run()
    obj = np.asarray(solver.history["objective"])
    running_min = np.minimum.accumulate(obj)
    assert np.all(obj[1:] <= 1.01 * running_min[:-1])  # non-increasing up to 1% wobble
    assert obj[-1] < 0.7 * obj[0]
    err_tv = np.linalg.norm(u * s_b / s_a - f) / np.linalg.norm(f)
    err_zf = np.linalg.norm(A.adjoint(b) - f) / np.linalg.norm(f)
    assert err_tv < 0.75 * err_zf
    assert set(solver.history) == {"objective", "data_residual", "reg_norm", "relative_change",
                                   "step_size", "elapsed_s"}
    assert np.all(np.diff(solver.history["elapsed_s"]) >= 0)


# ---------------------------------------------------------------------------------------------
# Appendix B optimality conditions
def test_appendix_b_optimality_conditions():
    """After a long run, ∇_f L = 0, σ + β(g - Tf) ∈ -λ sign*(g) and Tf = g hold (λ-form of L)."""
    rng = np.random.default_rng(2)
    m, n = 40, 50
    t = np.linspace(0, 1, n, endpoint=False)
    signal = np.sin(2 * np.pi * t)
    A = MatrixLinop(rng.standard_normal((m, n)) / np.sqrt(m) + 0j)
    b0 = A.forward(signal + 0j)
    noise = rng.standard_normal(m)
    b = b0 + noise * np.linalg.norm(b0) / np.linalg.norm(noise) / 5.0  # SNR 5
    scaled, _, _ = scale_problem(normal_equations(A, b))
    lam = 0.05
    T = FiniteDifference((n,), 2)
    solver = ADMM(scaled, T, lam, DEFAULT_BETA_RATIO * lam, tol=1e-14, max_iter=5000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        solver.run()
    tol = 1e-6
    grad = solver.gradient()
    assert np.linalg.norm(grad) / np.linalg.norm(2 * scaled.atb) < tol
    Tf, g, sigma, beta = solver.Tf, solver.g, solver.sigma, solver.beta
    assert np.linalg.norm(Tf - g) / np.linalg.norm(Tf) < tol
    r = sigma + beta * (g - Tf)
    on = np.abs(g) > 0
    assert on.any() and (~on).any()
    assert np.max(np.abs(r[on] + lam * g[on] / np.abs(g[on]))) < tol * lam
    assert np.max(np.abs(r[~on])) <= lam * (1 + tol)
    # the original problem (eq. optim-1) with certificate s = -σ/λ ∈ sign*(Tf)
    s = -sigma / lam
    assert np.max(np.abs(s)) <= 1 + tol
    Gf = scaled.gram.forward(solver.f)
    kkt = 2 * (Gf - scaled.atb) + lam * T.adjoint(s)
    assert np.linalg.norm(kkt) / np.linalg.norm(2 * scaled.atb) < tol


# ---------------------------------------------------------------------------------------------
# limits of λ
@pytest.mark.parametrize("m,n", [(60, 30), (20, 40)])
def test_lambda_to_zero_gives_minimum_norm_least_squares(m, n):
    rng = np.random.default_rng(m)
    A = MatrixLinop(_crandn(rng, (m, n)))
    b = _crandn(rng, m)
    scaled, s_a, s_b = scale_problem(normal_equations(A, b))
    lam = 1e-12
    solver = ADMM(scaled, FiniteDifference((n,)), lam, DEFAULT_BETA_RATIO * lam, tol=1e-12, max_iter=5000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        f = solver.run() * s_b / s_a
    ref = np.linalg.pinv(A.matrix) @ b
    assert np.linalg.norm(f - ref) / np.linalg.norm(ref) < 1e-6


def test_lambda_to_infinity_kills_tf():
    f, A, b = _appendix_a_problem()
    scaled, _, _ = scale_problem(normal_equations(A, b))
    for T in (FiniteDifference(f.shape), Identity(f.shape)):
        lam = 1e12
        solver = ADMM(scaled, T, lam, DEFAULT_BETA_RATIO * lam, tol=1e-8, max_iter=300)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            u = solver.run()
        assert np.all(np.isfinite(u))
        # relative to the size of the data-only image (max |Âᴴb̂| = 1)
        assert np.linalg.norm(T.forward(u)) < 1e-6


def test_cap_warns_with_relative_change():
    f, A, b = _appendix_a_problem()
    scaled, _, _ = scale_problem(normal_equations(A, b))
    solver = ADMM(scaled, FiniteDifference(f.shape), 0.3, 9.6, tol=1e-12, max_iter=3)
    with pytest.warns(ConvergenceWarning, match=r"relative change \d"):
        solver.run()
    assert solver.iteration == 3 and len(solver.history["objective"]) == 3
