"""Which nodes of each polar row ffbp forms (:mod:`sarcli.formers.ffbp`): those later stencils can
read. A level's grids are rectangles in (q, u) that hold the grown image grid; seen from near the
radar the image is far from a rectangle there (its near edge spans a wider u than its far edge),
so the rows at large |u| cross it only near its near edge, and the rest of them is never read."""

from __future__ import annotations

import dataclasses

import numpy as np

from ._grids import polar_coords


#: Rows are bounded only on levels whose grids' far and near ranges differ by more than this factor:
#: the rows at large |u| lose about half of ``1 − R_near/R_far`` of their nodes, so from farther
#: away (a 10 km circle: 1.01) bounding them saves a per cent or two of the nodes and costs the
#: planner more (a 42,000-pulse circle: 0.2 s a plan) than it saves.
RANGE_RATIO = 1.05


def with_rows(lv, bounds, dq, ext_q, ext_u):
    """The level ``lv`` (:func:`sarcli.formers.ffbp._grids.level_grid`, extended by ``ext_q`` and
    ``ext_u`` samples) with its :func:`row_bounds` for the grown grid's rectangle ``bounds``, where
    its grids span a range ratio above :data:`RANGE_RATIO` (else every node of every row)."""
    cn = lv.geo[2]
    near, far = cn + lv.q0 + ext_q * dq, cn + lv.q0 + (lv.n_q - 1 - ext_q) * dq
    if not np.max(far / np.maximum(near, 1e-300)) > RANGE_RATIO:
        return lv
    return dataclasses.replace(lv, rows=row_bounds(lv, bounds, dq, ext_q, ext_u))


def row_bounds(lv, bounds, dq, ext_q, ext_u) -> np.ndarray:
    """The nodes of each row of ``lv``'s grids that later stencils can read, ``[n, n_u, 2]``
    (start, stop), for the grown grid's rectangle ``bounds`` (x0, x1, y0, y1) and the grids'
    extensions ``ext_q`` and ``ext_u`` (samples). Along a row (u fixed) q grows with the distance
    from the centre's nadir, so over the rectangle and a band of rows q takes its extremes on the
    rectangle's boundary: each row keeps the q range of the boundary points within ``ext_u`` rows
    of it, extended by ``ext_q`` samples as the grids are.

    The boundary is sampled so that neighbouring points lie within half a row of each other; each
    point counts for the two rows about it."""
    x0, x1, y0, y1 = bounds
    ext_u = np.broadcast_to(np.asarray(ext_u, dtype=np.int64), (lv.n,))
    n_side = max(65, 2 * lv.n_u + 1)
    while True:
        s = np.linspace(0.0, 1.0, n_side)
        xs = np.concatenate([x0 + (x1 - x0) * s, np.full(n_side, x1), x1 - (x1 - x0) * s, np.full(n_side, x0)])
        ys = np.concatenate([np.full(n_side, y0), y0 + (y1 - y0) * s, np.full(n_side, y1), y1 - (y1 - y0) * s])
        q, u, _ = polar_coords(lv.geo, xs[None, :], ys[None, :])
        r = (u - lv.u0[:, None]) / lv.du[:, None]   # row coordinate of each boundary point
        if np.max(np.abs(np.diff(r, axis=1))) <= 0.5 or n_side > 64 * (lv.n_u + 1):
            break
        n_side = 2 * n_side - 1
    n, n_u = lv.n, lv.n_u
    q_lo, q_hi = np.full(n * n_u, np.inf), np.full(n * n_u, -np.inf)
    base = (np.arange(n) * n_u)[:, None]
    for row in (np.floor(r), np.ceil(r)):
        ok = (row >= 0) & (row < n_u)
        at = (base + np.clip(row, 0, n_u - 1).astype(np.int64))[ok]
        np.minimum.at(q_lo, at, q[ok])
        np.maximum.at(q_hi, at, q[ok])
    q_lo, q_hi = q_lo.reshape(n, n_u), q_hi.reshape(n, n_u)
    lo, hi = q_lo.copy(), q_hi.copy()
    reach = ext_u   # each point counts for the two rows about it: every point within ext_u rows
    for k in range(1, int(reach.max()) + 1):
        on = (k <= reach)[:, None]
        lo[:, k:] = np.where(on, np.minimum(lo[:, k:], q_lo[:, :-k]), lo[:, k:])
        lo[:, :-k] = np.where(on, np.minimum(lo[:, :-k], q_lo[:, k:]), lo[:, :-k])
        hi[:, k:] = np.where(on, np.maximum(hi[:, k:], q_hi[:, :-k]), hi[:, k:])
        hi[:, :-k] = np.where(on, np.maximum(hi[:, :-k], q_hi[:, k:]), hi[:, :-k])
    out = np.zeros((n, n_u, 2), np.int64)
    seen = np.isfinite(lo)
    q0 = lv.q0[:, None]
    # as the grids' own extension (the whole grid's q_min .. q_max give 0 .. n_q)
    start = np.floor((np.where(seen, lo, 0.0) - q0) / dq) - ext_q
    stop = np.ceil((np.where(seen, hi, 0.0) - q0) / dq) + ext_q + 1
    out[..., 0] = np.where(seen, np.clip(start, 0, lv.n_q), 0)
    out[..., 1] = np.where(seen, np.clip(stop, 0, lv.n_q), 0)
    out[..., 1] = np.maximum(out[..., 1], out[..., 0])
    out.setflags(write=False)
    return out
