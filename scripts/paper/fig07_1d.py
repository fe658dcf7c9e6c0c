"""Figure ``fig: 1D``: TV vs partial Fourier sum vs filtered sum, 1-D, |k| ≤ 75.

The periodic ``f(x) = 2x + 2`` on [-1/2, 0), ``2x`` on [0, 1/2) has ``f̂_k = i/(πk)`` (``f̂_0 = 1``),
which we confirm by quadrature. From the 151 coefficients |k| ≤ 75 we form on N = 512 samples:
the partial sum, a Hann-filtered sum (:func:`sarcli.core.windows.window_1d`), and the TV-regularised
solution of ``min ‖Af - b‖² + λ‖Df‖₁`` (eq. ``eq: reg``) by sarcli's ADMM (:class:`sarcli.solvers.ADMM`,
Appendix A) with ``A`` the 151 rows of the DFT (scaled to ``‖A‖ = 1``) and ``D`` the
first difference of eq. ``eq: Dmatrix`` (periodic). The claim: TV removes the Gibbs ringing
without smoothing the jump, and its coefficients outside the band resemble the true ones.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import quad

from sarcli.linops import FiniteDifference, MatrixLinop, normal_equations
from sarcli.solvers import ADMM
from sarcli.core.windows import window_1d

from _common import Result, fmt

KEY, LABEL = "fig07_1d", "fig: 1D"


def truth(x):
    x = np.asarray(x, float)
    return np.where(x < 0, 2 * x + 2, 2 * x)


def coefficients(k):
    """``f̂_k = i / (πk)``, ``f̂_0 = 1`` (the paper's closed form)."""
    k = np.asarray(k, float)
    return np.where(k == 0, 1.0 + 0j, 1j / (np.pi * np.where(k == 0, 1, k)))


def quadrature_check(ks=(1, 2, 3, 10, 75)) -> float:
    """Max |closed form - numerical ∫ f e^{-i2πkx} dx| over ``ks`` (adaptive quadrature per piece)."""
    worst = 0.0
    for k in ks:
        val = 0j
        for a, b in ((-0.5, 0.0), (0.0, 0.5)):
            re = quad(lambda t: truth(t) * np.cos(2 * np.pi * k * t), a, b, limit=400, epsabs=1e-13)[0]
            im = quad(lambda t: -truth(t) * np.sin(2 * np.pi * k * t), a, b, limit=400, epsabs=1e-13)[0]
            val += re + 1j * im
        worst = max(worst, abs(val - coefficients(k)))
    return float(worst)


def compute(*, n: int = 512, k_max: int = 75, lam: float = 0.02, iters: int = 3000) -> dict:
    x = -0.5 + np.arange(n) / n
    k = np.arange(-k_max, k_max + 1)
    b = coefficients(k)
    e = np.exp(2j * np.pi * np.outer(x, k))  # synthesis, [n, K]
    partial = (e @ b).real
    hann = (e @ (b * window_1d(k.size, "hann"))).real
    # data model b_k = (1/n) Σ_j f_j e^{-i2πk x_j}; scaled by √n so that ‖A‖ = 1
    a = e.conj().T / np.sqrt(n)
    op = MatrixLinop(a)
    solver = ADMM(normal_equations(op, b * np.sqrt(n)), FiniteDifference((n,), 1), lam=lam, beta=32 * lam,
                  tol=1e-7, max_iter=iters, isotropic=False)
    tv = solver.run().real
    f = truth(x)
    jump = n // 2  # x = 0

    def overshoot(g):
        return float(max(g[jump - 40:jump].max() - 2.0, 0.0, -(g[jump:jump + 40].min() - 0.0)))

    def err(g):
        return float(np.linalg.norm(g - f) / np.linalg.norm(f))

    kk = np.fft.fftfreq(n, 1 / n).astype(int)
    c_tv = np.fft.fft(tv) / n * np.exp(-2j * np.pi * kk * x[0])  # coefficients of the samples at x_j
    band = (np.abs(kk) > k_max) & (np.abs(kk) <= 2 * k_max)
    coef_err = float(np.linalg.norm(c_tv[band] - coefficients(kk[band])) / np.linalg.norm(coefficients(kk[band])))
    return dict(x=x, f=f, partial=partial, hann=hann, tv=tv, k=kk, c_tv=c_tv, k_max=k_max,
                overshoot={"partial": overshoot(partial), "hann": overshoot(hann), "tv": overshoot(tv)},
                error={"partial": err(partial), "hann": err(hann), "tv": err(tv)},
                coef_err=coef_err, iterations=solver.iteration, history=solver.history_arrays(),
                data_fit=float(np.linalg.norm(a @ tv - b * np.sqrt(n)) / np.linalg.norm(b * np.sqrt(n))))


def plot(res):
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, 2, figsize=(12, 4.2))
    x = res["x"]
    axs[0].plot(x, res["f"], "k", lw=1, label="f")
    axs[0].plot(x, res["partial"], lw=1, label="partial sum")
    axs[0].plot(x, res["hann"], lw=1, label="Hann-filtered sum")
    axs[0].plot(x, res["tv"], lw=1, label="TV (ADMM)")
    axs[0].legend(fontsize=8)
    axs[0].set_xlabel("x")
    pos = (res["k"] > 0) & (res["k"] <= 3 * res["k_max"])
    k = res["k"][pos]
    axs[1].semilogy(k, np.abs(1 / (np.pi * k)), "k", lw=1, label="|f̂_k| true")
    axs[1].semilogy(k, np.abs(res["c_tv"][pos]), ".", ms=3, color="C2", label="TV solution")
    axs[1].axvline(res["k_max"], color="C0", ls="--", label="known band |k| ≤ 75")
    axs[1].set_xlabel("k")
    axs[1].legend(fontsize=8)
    axs[1].set_title("Fourier coefficients (partial / filtered sums: 0 beyond 75)")
    fig.tight_layout()
    return fig


def bounds_hold(res) -> bool:
    """The pass bounds at |k| ≤ 75, N = 512: the sampled Gibbs overshoot of the partial sum
    (0.153 of the jump of 2; 0.179 in the continuum limit), TV and Hann without overshoot (< 0.01),
    TV's error at most 0.85 × the partial sum's and below Hann's, its coefficients beyond the
    band within 30 %, and its data misfit below 1e-3."""
    o, e = res["overshoot"], res["error"]
    return bool(0.14 < o["partial"] < 0.18 and o["tv"] < 0.01 and o["hann"] < 0.01
                and e["tv"] < 0.85 * e["partial"] and e["tv"] < e["hann"] and res["coef_err"] < 0.3
                and res["data_fit"] < 1e-3)


def run(out_dir=None) -> Result:
    res = compute()
    q = quadrature_check()
    o, e = res["overshoot"], res["error"]
    ok = bounds_hold(res) and q < 1e-10
    return Result(
        KEY, LABEL, "1-D TV vs partial and filtered Fourier sums",
        claim=("`fig: 1D` (section `sec: reg`): from the coefficients f̂_k = i/(πk), |k| ≤ 75, of the periodic "
               "f = 2x+2 / 2x, 'the partial sum results in the Gibbs effect at the discontinuity, and the filtered "
               "sum smooths this region over. However, the TV regularized solution removes the Gibbs ringing "
               "without over-smoothing'; its coefficients outside the known band 'are similar to the original'."),
        measured=[
            f"Closed form f̂_k = i/(πk) vs adaptive quadrature (k = 1, 2, 3, 10, 75): max error {fmt(q)} (bound 1e-10).",
            f"Overshoot at the jump (N = 512 samples): partial sum {o['partial']:.3f}, Hann {o['hann']:.3f}, "
            f"TV {o['tv']:.3f} (jump height 2; pass: partial 0.14-0.18, TV and Hann < 0.01).",
            f"Relative L2 error against f: partial {e['partial']:.4f}, Hann {e['hann']:.4f}, TV {e['tv']:.4f} "
            f"(pass: TV < 0.85 × partial and < Hann).",
            f"TV coefficients for 75 < |k| ≤ 150 (unknown to the solver) vs i/(πk): relative error "
            f"{res['coef_err']:.3f} (partial and filtered sums: 1, they are zero there; pass < 0.3).",
            f"ADMM: λ = 0.02, β = 32λ, {res['iterations']} iterations, relative data misfit {fmt(res['data_fit'])} "
            f"(pass < 1e-3).",
        ],
        passed=ok, headline=f"TV error {res['error']['tv']:.4f} vs partial sum {res['error']['partial']:.4f}; overshoot {res['overshoot']['tv']:.3f} vs {res['overshoot']['partial']:.3f}", figure=plot(res))
