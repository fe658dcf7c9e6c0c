"""Polar-grid geometry of ffbp (:mod:`sarcli.formers.ffbp`) in NumPy, and the deapodization of its
range kernels: where it holds and the weights that divide the kernels' mean responses out of the
data (:func:`sarcli.formers.ffbp_model.deapodized_kernel`)."""

from __future__ import annotations

import numpy as np

from ..core.geometry import C
from ..core.grid import Grid
from ..errors import SarcliInputError
from .ffbp_model import deapodized_error, deapodized_response, deapodized_slope, interp_error


def _centre_geometry(c):
    """Rows cx, cy, |c|, ρ0, e0x, e0y, cz of the polar frames of centres ``c`` [S, 3]."""
    cn = np.linalg.norm(c, axis=1)
    rho0 = np.hypot(c[:, 0], c[:, 1])
    if np.any(rho0 <= 0):
        raise SarcliInputError("ffbp needs every sub-aperture centre away from the scene origin's vertical; "
                               "use method 'backprojection'")
    e0 = -c[:, :2] / rho0[:, None]
    return np.ascontiguousarray(np.stack([c[:, 0], c[:, 1], cn, rho0, e0[:, 0], e0[:, 1], c[:, 2]]))


def _coords_np(g, x, y):
    """NumPy twin of the compiled ``_coords``: (q, τ, denominator) [S, n] for points (x, y)."""
    cx, cy, cn, rho0, e0x, e0y = (r[:, None] for r in g[:6])
    num = x * x + y * y - 2.0 * (cx * x + cy * y)
    q = num / (np.sqrt(cn * cn + num) + cn)
    den = rho0 + e0x * x + e0y * y
    return q, (e0x * y - e0y * x) / den, den


def _boundary(grid: Grid, margin: float):
    """Points on the boundary of the grid's rectangle grown by ``margin`` metres."""
    x0, x1 = grid.x[0] - grid.dx / 2 - margin, grid.x[-1] + grid.dx / 2 + margin
    y0, y1 = grid.y[0] - grid.dy / 2 - margin, grid.y[-1] + grid.dy / 2 + margin
    s = np.linspace(0, 1, 33)
    xs = np.concatenate([x0 + (x1 - x0) * s, np.full(33, x1), x1 - (x1 - x0) * s, np.full(33, x0)])
    ys = np.concatenate([np.full(33, y0), y0 + (y1 - y0) * s, np.full(33, y1), y1 - (y1 - y0) * s])
    return xs, ys, (x0, x1, y0, y1)


def range_slope(pos, fr, xs, ys):
    """Largest ``|dR_p/dq − 1|`` over the pulses of a frame and points of the (grown) grid: how
    much faster or slower than the sub-aperture centre's range q a pulse's range grows along the
    polar grid's rows (ground rays from the centre's nadir). A pulse's range frequency along q is
    ``k_j dR_p/dq``, not the ``k_j`` the range kernel's deapodization assumes: a climbing path, or a
    sub-aperture whose depression angle varies, moves it by ``k_j`` times this. ``fr``: a frame of
    :func:`sarcli.formers.ffbp._frame`; ``xs, ys``: ground points to check."""
    sub = np.repeat(np.arange(fr["first"].size), fr["count"])
    run = pos[fr["first"][0]:fr["first"][0] + sub.size]
    g = fr["geo"]
    worst = 0.0
    for a in range(0, sub.size, 4096):   # blocks of pulses: no [P, points] temporaries beyond 4096 rows
        sb = sub[a:a + 4096]
        cx, cy, cz = g[0][sb][:, None], g[1][sb][:, None], g[6][sb][:, None]
        hx, hy = xs[None, :] - cx, ys[None, :] - cy
        h = np.hypot(hx, hy)
        rc = np.sqrt(h * h + cz * cz)
        t = run[a:a + 4096]
        px, py, pz = xs[None, :] - t[:, 0:1], ys[None, :] - t[:, 1:2], t[:, 2:3]
        rp = np.sqrt(px * px + py * py + pz * pz)
        ratio = ((px * hx + py * hy) / (h * rp)) / (h / rc)
        worst = max(worst, float(np.max(np.abs(ratio - 1.0))))
    return worst


def deapodization(freq_hz, plan, n_len):
    """Weights [rows, M] that divide the deapodized kernels' mean responses out of the data
    (:func:`sarcli.formers.ffbp_model.deapodized_kernel`), as the plan says: the range profiles'
    kernel at bin frequency ``(j − j_c)/L``, exact, and the polar grids' range kernel,
    ``Ψ(ν_j)^{−S}`` for its ``S`` range interpolations (every merge and the final stage) at
    ``ν_j = (4π f_j / c − k_ref) Δq / 2π`` cycles per sample (the demodulated sub-images hold
    ``e^{i (k_j − k_ref) q}``; all levels share ``Δq``)."""
    f = np.asarray(freq_hz, dtype=np.float64)
    m = f.shape[-1]
    w = np.ones((1, m))
    if plan.profiles_deapodized:
        w = w / deapodized_response(float(plan.knobs["upsample"]), (np.arange(m) - m // 2) / float(n_len))
    if plan.range_deapodized:
        nu = (4.0 * np.pi * f / C - plan.kref) * plan.dq / (2.0 * np.pi)
        w = w * deapodized_response(float(plan.knobs["os_range"]), nu) ** (-float(len(plan.levels)))
    return w


def decide_range(pos, frames, grid, margin, kmax, dq, os_range):
    """Whether to deapodize the polar grids' range kernel, and the error its frequency mismatch
    costs: where that mismatch (``k_max Δq/2π · max |d ln Ψ/dν| · Σ_levels`` :func:`range_slope`,
    on the grid grown by ``margin``) plus the aliases of every range
    interpolation stays below the minimax stencil's error (:func:`sarcli.formers.ffbp_model.interp_error`)."""
    bx, by, _ = _boundary(grid, margin)
    bx = np.concatenate([bx[::4], [0.5 * (grid.x[0] + grid.x[-1])]])
    by = np.concatenate([by[::4], [0.5 * (grid.y[0] + grid.y[-1])]])
    mismatch = deapodized_slope(float(os_range)) * kmax * dq / (2 * np.pi) * \
        sum(range_slope(pos, fr, bx, by) for fr in frames)
    s_q = len(frames)
    ok = bool(s_q * deapodized_error(float(os_range)) + mismatch < s_q * interp_error("optimal", float(os_range)))
    return ok, (float(mismatch) if ok else 0.0)
