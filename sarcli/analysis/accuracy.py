"""How accurate an image is: the reference grid an exact matched filter can afford, the truth on
an image grid, the error against it, and the Pareto front of error against run time.

Used by ``sar bench`` (:mod:`sarcli.batch.benchmark`), the benchmarks in ``bench/`` and the
figures of :mod:`sarcli.viz`.
"""

from __future__ import annotations

import numpy as np

from ..core.grid import Grid
from ..core.types import PhaseHistory

__all__ = ["MAX_REFERENCE_COST", "reference_grid", "truth_on_grid", "truth_error", "pareto_front"]

#: Largest ``P·M·pixels`` of an exact matched-filter reference before it is formed on a strided sub-grid.
MAX_REFERENCE_COST = 1.0e9


def _strided_axis(n: int, stride: int) -> np.ndarray:
    """Indices ``n//2 + (j - m//2)·stride`` of an axis of ``n`` pixels, as many as fit (``m`` of them)."""
    left = (n // 2) // stride
    right = (n - 1 - n // 2) // stride
    m = 2 * right + 2 if left > right else 2 * left + 1
    return n // 2 + (np.arange(m) - m // 2) * stride


def reference_grid(ph: PhaseHistory, grid: Grid, max_cost: float = MAX_REFERENCE_COST):
    """The grid the exact reference is formed on: ``grid`` itself, or a strided sub-grid of it.

    The sub-grid takes every ``s``-th pixel of ``grid`` in x and y around its centre pixel, with the
    smallest stride ``s`` for which ``P·M·pixels <= max_cost``; its pixels are pixels of ``grid``
    and they cover the whole image, so errors that grow towards the edges (gridding roll-off,
    far-field defocus) are sampled fairly. Returns ``(sub_grid, rows, cols, cost)`` with
    ``rows``/``cols`` the indices into ``grid`` (use ``img[np.ix_(rows, cols)]``) and
    ``cost = P·M·pixels`` of the full grid.
    """
    P, M = ph.data.shape
    cost = float(P) * M * grid.nx * grid.ny
    if cost <= max_cost:
        return grid, np.arange(grid.ny), np.arange(grid.nx), cost
    stride = max(2, int(np.ceil(np.sqrt(cost / max_cost))))
    cols = _strided_axis(grid.nx, stride)
    rows = _strided_axis(grid.ny, stride)
    sub = Grid(cols.size, rows.size, grid.dx * stride, grid.dy * stride,
               float(grid.x[grid.nx // 2]), float(grid.y[grid.ny // 2]))
    return sub, rows, cols, cost


def truth_on_grid(ph: PhaseHistory, grid: Grid):
    """The truth on ``grid`` as ``(values, mask)``, or None when unknown.

    Extended scenes: ``|ph.truth.scene|`` when its grid is ``grid`` (mask None: every pixel counts).
    Point-only scenes: ``|a_s|`` at each target's nearest pixel with ``mask`` selecting those
    pixels, so the error is that of the peak amplitudes (a matched filter blurs a point into its
    PSF, which a pixel-wise comparison with a one-pixel truth would only measure the width of).
    """
    t = ph.truth
    if t is None:
        return None
    scene = ph.acquisition.scene or {}
    extended = any(k in scene for k in ("phantom", "image_file"))
    if extended or t.point_amplitude.size == 0:
        if t.scene is not None and t.x_m is not None and t.x_m.shape == grid.x.shape and \
                t.y_m.shape == grid.y.shape and np.allclose(t.x_m, grid.x) and np.allclose(t.y_m, grid.y):
            mag = np.abs(t.scene)
            return (mag, None) if np.any(mag) else None
        return None
    out = np.zeros(grid.shape)
    for (x, y, _), a in zip(t.point_position_m, t.point_amplitude):
        r, c = grid.index_of(x, y)
        if 0 <= r < grid.ny and 0 <= c < grid.nx:
            out[r, c] += abs(a)
    return (out, out > 0) if np.any(out) else None


def truth_error(img, truth):
    """``‖|f| − |t|‖₂ / ‖t‖₂`` over the truth's pixels (see :func:`truth_on_grid`)."""
    if truth is None:
        return float("nan")
    t, mask = truth
    f = np.abs(np.asarray(img))
    if mask is not None:
        f, t = f[mask], t[mask]
    return float(np.linalg.norm(f - t) / np.linalg.norm(t))


def pareto_front(errors, seconds) -> np.ndarray:
    """Indices of the settings no other setting beats in both error and time, by increasing time."""
    e = np.asarray(errors, float)
    s = np.asarray(seconds, float)
    ok = np.flatnonzero(np.isfinite(e) & np.isfinite(s))
    order = ok[np.lexsort((e[ok], s[ok]))]
    front, best = [], np.inf
    for i in order:
        if e[i] < best:
            front.append(i)
            best = e[i]
    return np.asarray(front, dtype=int)
