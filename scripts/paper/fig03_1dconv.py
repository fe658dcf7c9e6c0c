"""Figure ``fig: 1Dconv`` and Proposition ``prop:1``: offset partial Fourier sums are convolutions.

``S_{K1,K2} f = f * G`` with ``G(x; K_c, B) = e^{i K_c x} D_{B/2}(x)`` (eq. ``dirichlet-off-2``),
``D_n(x) = sin((n + 1/2) x) / sin(x/2)`` (eq. ``dirichlet``), for the unit step on [-π, π)
(0 on [-π, 0), 1 on [0, π)), B = 50, K_c = 0 and 125.

Two independent routes are compared: the partial sum from the step's exact Fourier coefficients
``f̂_k = (1 - e^{-iπk}) / (2π i k)`` (``f̂_0 = 1/2``) and the convolution integral
``(1/2π) ∫_0^π G(x - y) dy`` by Gauss-Legendre quadrature of the closed-form kernel (evaluated
with :func:`sarcli.analysis.psf.dirichlet_ratio`). The discrete statement (eq. ``dirchlet-off-4``) is
checked too: the inverse DFT of a band of DFT coefficients equals the circular convolution with
``g_m = N⁻¹ e^{i 2π K_c m / N} D_{B/2}(2π m / N)``.
"""

from __future__ import annotations

import numpy as np
from scipy.special import roots_legendre

from sarcli.analysis.psf import dirichlet_ratio

from _common import Result, fmt

KEY, LABEL = "fig03_1dconv", "fig: 1Dconv"


def dirichlet(x, n: int):
    """``D_n(x) = sin((n + 1/2) x) / sin(x / 2)`` (eq. ``dirichlet``), stable at x = 2πm."""
    return dirichlet_ratio(0.5 * np.asarray(x, float), 2 * n + 1)


def kernel(x, k_center: int, bandwidth: int):
    """``G(x; K_c, B) = e^{i K_c x} D_{B/2}(x)`` (eq. ``dirichlet-off-2``)."""
    return np.exp(1j * k_center * np.asarray(x, float)) * dirichlet(x, bandwidth // 2)


def step_coefficients(k):
    """Exact Fourier coefficients ``(1/2π) ∫_0^π e^{-ikx} dx`` of the unit step."""
    k = np.asarray(k, float)
    safe = np.where(k == 0, 1.0, k)
    return np.where(k == 0, 0.5, (1 - np.exp(-1j * np.pi * safe)) / (2j * np.pi * safe))


def partial_sum(x, k_center: int, bandwidth: int):
    """``S_{K1,K2} f(x) = Σ_{K1}^{K2} f̂_k e^{ikx}`` (eq. ``dirichlet-off``) of the step."""
    k = np.arange(k_center - bandwidth // 2, k_center + bandwidth // 2 + 1)
    return np.exp(1j * np.outer(x, k)) @ step_coefficients(k)


def convolution(x, k_center: int, bandwidth: int, *, nodes: int = 600):
    """``f * G (x) = (1/2π) ∫_0^π G(x - y) dy`` by Gauss-Legendre quadrature (``nodes`` points)."""
    t, w = roots_legendre(nodes)
    y = 0.5 * np.pi * (t + 1)
    w = 0.5 * np.pi * w
    return kernel(np.subtract.outer(x, y), k_center, bandwidth) @ w / (2 * np.pi)


def discrete_check(n: int, k_center: int, bandwidth: int, seed: int = 0) -> float:
    """Max |IDFT band sum - circular convolution with g| / max|IDFT band sum| for a random f ∈ C^n."""
    rng = np.random.default_rng(seed)
    f = rng.standard_normal(n) + 1j * rng.standard_normal(n)
    k = np.arange(k_center - bandwidth // 2, k_center + bandwidth // 2 + 1)
    m = np.arange(n)
    fhat = np.fft.fft(f)
    s = np.exp(2j * np.pi * np.outer(m, k) / n) @ fhat[k % n] / n
    g = np.exp(2j * np.pi * k_center * m / n) * dirichlet(2 * np.pi * m / n, bandwidth // 2) / n
    conv = np.array([np.sum(f * g[(mm - m) % n]) for mm in m])
    return float(np.max(np.abs(s - conv)) / np.max(np.abs(s)))


def compute(*, bandwidth: int = 50, centers=(0, 125), n_points: int = 801, n_discrete: int = 512) -> dict:
    x = np.linspace(-np.pi, np.pi, n_points, endpoint=False)
    out = {"x": x, "bandwidth": bandwidth, "centers": tuple(centers)}
    for kc in centers:
        s = partial_sum(x, kc, bandwidth)
        c = convolution(x, kc, bandwidth)
        out[kc] = dict(sum=s, conv=c, kernel=kernel(x, kc, bandwidth),
                       error=float(np.max(np.abs(s - c))),
                       discrete_error=discrete_check(n_discrete, kc, bandwidth))
    return out


def plot(res):
    import matplotlib.pyplot as plt

    x = res["x"]
    fig, axs = plt.subplots(2, len(res["centers"]), figsize=(10, 6), sharex=True)
    for i, kc in enumerate(res["centers"]):
        r = res[kc]
        axs[0, i].plot(x, r["kernel"].real, lw=0.8, label="Re G")
        if kc:
            axs[0, i].plot(x, np.abs(r["kernel"]), lw=0.8, label="|G|")
        axs[0, i].set_title(f"G(x; K_c={kc}, B={res['bandwidth']})")
        axs[0, i].legend(fontsize=8)
        axs[1, i].plot(x, (x >= 0).astype(float), "k--", lw=0.8, label="f")
        axs[1, i].plot(x, r["sum"].real, lw=1, label="Re f*G")
        axs[1, i].plot(x, np.abs(r["sum"]), lw=1, label="|f*G|")
        axs[1, i].set_title(f"step * G, max|S f - f*G| = {r['error']:.1e}")
        axs[1, i].legend(fontsize=8)
        axs[1, i].set_xlabel("x")
    fig.tight_layout()
    return fig


def run(out_dir=None) -> Result:
    res = compute()
    errs = [res[kc]["error"] for kc in res["centers"]]
    derrs = [res[kc]["discrete_error"] for kc in res["centers"]]
    x, mag = res["x"], np.abs(res[125]["sum"])
    near = np.minimum(np.abs(x), np.pi - np.abs(x)) < 0.2
    edge = float(mag[near].max())
    flat = float(mag[np.abs(np.abs(x) - np.pi / 2) < 0.5].max())
    ok = max(errs) < 1e-12 and max(derrs) < 1e-12 and flat < 0.1 * edge
    return Result(
        KEY, LABEL, "offset partial Fourier sums (Proposition prop:1)",
        claim=("Proposition `prop:1`: S_{K1,K2} f = f * G(·; K_c, B) with G = e^{iK_c x} D_{B/2}(x) "
               "(eq. `dirichlet-off-2`). `fig: 1Dconv`: with K_c = 0 the partial sum of the unit step "
               "approximates the step (with Gibbs ringing); with K_c = 125 (B = 50) the complex kernel "
               "'only detects the edges'."),
        measured=[
            f"Partial sum from the exact coefficients vs the convolution integral of the closed-form G "
            f"(600-node Gauss-Legendre), at 801 points: max error {fmt(errs[0])} (K_c = 0), "
            f"{fmt(errs[1])} (K_c = 125); bound 1e-12.",
            f"Discrete form (eq. `dirchlet-off-4`), random f ∈ C^512: relative max error {fmt(derrs[0])} "
            f"(K_c = 0), {fmt(derrs[1])} (K_c = 125); bound 1e-12.",
            f"Edges only at K_c = 125: max |f*G| within 0.2 of the jumps (x = 0, ±π) is {edge:.3f}, within 0.5 of "
            f"x = ±π/2 (flat parts) {flat:.4f}; for K_c = 0 the sum is {res[0]['sum'][np.argmin(abs(x - np.pi / 2))].real:.3f} "
            f"at x = π/2 (the step's value 1).",
        ],
        passed=ok, headline=f"partial sum = convolution with G to {fmt(max(errs))}", figure=plot(res))
