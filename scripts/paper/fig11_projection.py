"""Figure ``fig: proj-example`` and Lemma ``proj-lem``: projection p_θ and its adjoint, backprojection.

Discretisation. Pixels of side h at centres x; bins of width Δw at w_b. Each pixel's value is
split between the two bins around ``t = ξ_θ·x`` by linear-interpolation weights ``W[x, b]``, so

    (p_θ f)_b = (h² / Δw) Σ_x W[x, b] f(x)          (line integral ∫ f dz per unit w)
    (p_θ* g)(x) = Σ_b W[x, b] g_b = g(ξ_θ·x)        (linear interpolation: Lemma proj-lem)

With the inner products of the paper, ``⟨u, v⟩_w = Σ_b u_b v̄_b Δw`` and ``⟨f, h⟩_A = Σ_x f h̄ h²``,
``⟨p_θ f, g⟩_w = ⟨f, p_θ* g⟩_A`` holds exactly (the dot-product test below). Checks:

* the dot-product test (random complex f and g);
* Lemma proj-lem's formula: ``p_θ* g(x) = g(ξ_θ·x)`` exactly for any g linear in w, and to
  O(Δw²) for a smooth g;
* p_θ of a disk against its analytic projection ``2√(r² − w²)``;
* the SAR link (eq. ``tomo``): sarcli's matched filter of a single look (the adjoint of its
  pixel-model operator, :class:`sarcli.linops.NufftOperator`) equals p_θ* applied to that look's
  range profile ``G(w) = Σ_j d_j e^{i k_j w}``: the matched filter is a sum of backprojections.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from sarcli.core.grid import Grid
from sarcli.simulation.scenes import shepp_logan

from _common import Result, fmt

KEY, LABEL = "fig11_projection", "fig: proj-example"


class Projection:
    """p_θ on a pixel grid with ``n_bins`` bins of width ``dw`` centred on w = 0."""

    def __init__(self, grid: Grid, theta: float, n_bins: int, dw: float):
        self.grid, self.theta, self.dw = grid, float(theta), float(dw)
        X, Y = np.meshgrid(grid.x, grid.y)
        t = X.ravel() * np.cos(theta) + Y.ravel() * np.sin(theta)
        self.w = (np.arange(n_bins) - (n_bins - 1) / 2) * dw
        u = (t - self.w[0]) / dw
        i0 = np.floor(u).astype(int)
        frac = u - i0
        if i0.min() < 0 or i0.max() + 1 >= n_bins:
            raise ValueError("the bins do not cover the grid's projection")
        rows = np.r_[np.arange(t.size), np.arange(t.size)]
        cols = np.r_[i0, i0 + 1]
        vals = np.r_[1.0 - frac, frac]
        self.W = sp.csr_matrix((vals, (rows, cols)), shape=(t.size, n_bins))
        self.area = grid.dx * grid.dy

    def forward(self, f) -> np.ndarray:
        """(p_θ f)_b."""
        return (self.area / self.dw) * (self.W.T @ np.asarray(f).ravel())

    def backproject(self, g) -> np.ndarray:
        """p_θ* g = g(ξ_θ·x), as an image."""
        return (self.W @ np.asarray(g)).reshape(self.grid.shape)


def dot_test(proj: Projection, seed: int = 0) -> float:
    """|⟨p f, g⟩_w − ⟨f, p* g⟩_A| / (‖p f‖ ‖g‖) for random complex f, g."""
    rng = np.random.default_rng(seed)
    f = rng.standard_normal(proj.grid.shape) + 1j * rng.standard_normal(proj.grid.shape)
    g = rng.standard_normal(proj.w.size) + 1j * rng.standard_normal(proj.w.size)
    pf = proj.forward(f)
    lhs = np.vdot(g, pf) * proj.dw
    rhs = np.vdot(proj.backproject(g), f) * proj.area
    return float(abs(lhs - rhs) / (np.linalg.norm(pf) * np.linalg.norm(g) * proj.dw))


def lemma_formula(proj: Projection) -> dict:
    """p_θ* g against g(ξ_θ·x): a linear g (exact) and a smooth g (O(Δw²))."""
    X, Y = np.meshgrid(proj.grid.x, proj.grid.y)
    t = X * np.cos(proj.theta) + Y * np.sin(proj.theta)
    lin = 0.7 * proj.w - 1.3j
    smooth = np.cos(2.0 * proj.w) + 1j * np.sin(0.5 * proj.w)
    err_lin = np.max(np.abs(proj.backproject(lin) - (0.7 * t - 1.3j)))
    exact = np.cos(2.0 * t) + 1j * np.sin(0.5 * t)
    err_smooth = np.max(np.abs(proj.backproject(smooth) - exact))
    # linear interpolation errs by at most max|g''| Δw²/8, max|g''| ≤ 4 + 1/4
    return dict(linear=float(err_lin), smooth=float(err_smooth), smooth_bound=float(4.25 * proj.dw**2 / 8))


def disk_projection(n: int = 256, radius: float = 3.0, theta: float = 0.4) -> float:
    """Relative L2 error of p_θ of a disk (n × n pixels over [-4, 4]²) against 2√(r² − w²)."""
    grid = Grid.square(4.0, n)
    X, Y = np.meshgrid(grid.x, grid.y)
    f = ((X**2 + Y**2) <= radius**2).astype(float)
    proj = Projection(grid, theta, int(np.ceil(12.0 / (2 * grid.dx))) | 1, 2 * grid.dx)
    exact = 2 * np.sqrt(np.maximum(radius**2 - proj.w**2, 0.0))
    return float(np.linalg.norm(proj.forward(f) - exact) / np.linalg.norm(exact))


def sar_single_look(n: int = 48, seed: int = 1) -> float:
    """sarcli's single-look matched filter Aᴴd vs p_θ*(range profile): relative max error."""
    from sarcli.core import geometry
    from sarcli.linops import NufftOperator

    grid = Grid.square(3.0, n)
    freq = np.linspace(9.9e9, 10.1e9, 64)
    theta, el = 0.3, np.deg2rad(30.0)
    kx, ky = geometry.kspace_coordinates(freq, [theta], [el])
    rng = np.random.default_rng(seed)
    d = rng.standard_normal(kx.shape) + 1j * rng.standard_normal(kx.shape)
    mf = NufftOperator(kx, ky, grid, eps=1e-13).adjoint(d)
    k = geometry.wavenumbers(freq, [el])[0]
    dw = 2e-5  # k Δw ≈ 0.008: linear interpolation of G good to ~1e-5
    proj = Projection(grid, theta, int(2 * 4.3 / dw) | 1, dw)
    G = np.exp(1j * np.outer(proj.w, k)) @ d[0]  # range profile G(w) = Σ_j d_j e^{i k_j w}
    return float(np.max(np.abs(proj.backproject(G) - mf)) / np.max(np.abs(mf)))


def compute(*, n: int = 128, theta: float = np.deg2rad(30.0)) -> dict:
    grid = Grid.square(1.0, n)
    X, Y = np.meshgrid(grid.x, grid.y)
    f = shepp_logan(X / 0.95, Y / 0.95)
    proj = Projection(grid, theta, int(np.ceil(2.9 / grid.dx)) | 1, grid.dx)
    pf = proj.forward(f)
    return dict(grid=grid, f=f, theta=theta, w=proj.w, pf=pf, bp=proj.backproject(pf),
                dot=dot_test(proj), lemma=lemma_formula(proj), disk=disk_projection(),
                sar=sar_single_look())


def plot(res):
    import matplotlib.pyplot as plt

    g = res["grid"]
    ext = [g.x[0], g.x[-1], g.y[0], g.y[-1]]
    fig, axs = plt.subplots(1, 3, figsize=(13, 4.2), layout="constrained")
    axs[0].imshow(res["f"], origin="lower", extent=ext, cmap="gray")
    t = np.linspace(-1, 1, 2)
    axs[0].plot(t * np.cos(res["theta"]), t * np.sin(res["theta"]), "C1--", lw=1, label="ξ_θ")
    axs[0].set_title("f (Shepp-Logan)")
    axs[0].legend(fontsize=8)
    axs[1].plot(res["w"], res["pf"])
    axs[1].set_xlabel("w")
    axs[1].set_title(f"projection p_θ f, θ = {np.rad2deg(res['theta']):.0f}°")
    axs[2].imshow(res["bp"], origin="lower", extent=ext, cmap="gray")
    axs[2].set_title("backprojection p_θ* p_θ f")
    return fig


def run(out_dir=None) -> Result:
    res = compute()
    lem = res["lemma"]
    ok = (res["dot"] < 1e-12 and lem["linear"] < 1e-12 and lem["smooth"] <= lem["smooth_bound"]
          and res["disk"] < 0.02 and res["sar"] < 1e-3)
    return Result(
        KEY, LABEL, "projection and backprojection (Lemma proj-lem)",
        claim=("Lemma `proj-lem`: the adjoint of the projection p_θ f(w) = ∫ f((w, z) Q_θᵀ) dz is "
               "p_θ* g(x, y) = g(ξ_θ·(x, y)), the backprojection of a single projection; `fig: proj-example` "
               "shows an image, its projection p_θ f and p_θ* p_θ f."),
        measured=[
            f"Dot-product test ⟨p_θ f, g⟩_w = ⟨f, p_θ* g⟩_A (random complex f on 128², g on {res['w'].size} bins): "
            f"relative error {fmt(res['dot'])} (bound 1e-12).",
            f"Lemma's formula p_θ* g = g(ξ_θ·x): max error {fmt(lem['linear'])} for a linear g (exact; bound 1e-12), "
            f"{fmt(lem['smooth'])} for cos 2w + i sin(w/2) (bound max|g''| Δw²/8 = {fmt(lem['smooth_bound'])}).",
            f"p_θ of a disk (r = 3, 256² pixels) against 2√(r² − w²): relative L2 error {fmt(res['disk'])} "
            f"(pixelisation; bound 0.02).",
            f"SAR link (eq. `tomo`): sarcli's single-look matched filter (NUFFT adjoint, 64 frequencies at 10 GHz) "
            f"against p_θ* of the look's range profile G(w) = Σ_j d_j e^(i k_j w): max relative error "
            f"{fmt(res['sar'])} (bound 1e-3; linear interpolation of G at k Δw ≈ 0.008).",
        ],
        passed=ok, headline=f"dot test {fmt(res['dot'])}; single-look matched filter = backprojection to {fmt(res['sar'])}", figure=plot(res))
