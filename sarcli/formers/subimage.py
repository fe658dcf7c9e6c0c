"""Sub-image NUFFT: the Fourier former that survives the spherical wavefront.

A far-field former (one NUFFT) on spherical data loses the curvature phase
``k (|δ|² − (û·δ)²) / (2 r)`` at a distance ``δ`` from the scene centre (docs/conventions.md "Data
models"), a radian already ~20 m from the centre of a 10 km X-band collection. Close to *any*
point the far-field model holds again, so:

1. split the image into square tiles of ``tile`` × ``tile`` pixels;
2. motion-compensate the data to each tile's centre ``x_c`` with the exact spherical range:
   ``c_pj = w_pj d_pj exp(+i k_pj (|a_p − x_c| − r0_p))``;
3. one type-1 NUFFT per tile with the local look directions ``û_p = (a_p − x_c)/|a_p − x_c|``:
   ``f(x_c + δ) ≈ (1/W) Σ c_pj exp(−i k_pj û_p·δ)``;
4. put back the curvature phase of the central pulse at the central frequency,
   ``exp(i k_c (|a_c − x| − |a_c − x_c| + û_c·δ))``, which leaves only its variation over pulses
   and frequencies.

The tile is chosen from the predicted error (:func:`predict_tile_error`): the RMS over the tile,
the pulses and the frequencies of ``|e^{i ρ} − 1|``, ``ρ`` the residual phase after steps 3–4,
evaluated exactly on sample points (by Parseval, the relative L2 image error of a defocus that
small). Cost: ``n_tiles × (P·M spreading + (2·tile)² FFT)``, so large tiles are cheap and the
curvature decides how large they may be (∝ ``sqrt(r0 / k)`` for a given tolerance).
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..core import geometry, sampling
from ..core.grid import Grid
from ..errors import SarcliInputError
from .options import SubimageOptions

__all__ = ["subimage_nufft", "predict_tile_error", "choose_tile", "TILE_SIZES"]

#: Tile sides (pixels) the chooser tries, largest first.
TILE_SIZES = (1024, 768, 512, 384, 256, 192, 128, 96, 64, 48, 32, 24, 16, 12, 8)


def _ranges(t, q, r0, pts):
    """Differential ranges (P, S) of points, monostatic or bistatic (the geometry module's)."""
    if q is None:
        return geometry.differential_range(t, r0, pts)
    return geometry.bistatic_differential_range(t, q, r0, pts)


def _look(t, q, xc):
    """Unit vectors û_p from ``xc`` to the antenna (mean of transmit and receive for bistatic)."""
    def unit(a):
        v = a - xc[None, :]
        return v / np.linalg.norm(v, axis=1)[:, None]
    return unit(t) if q is None else 0.5 * (unit(t) + unit(q))


def _tile_centres(grid: Grid, tile: int):
    """Row/column slices of the tiles and their centre pixels (index ``n//2`` within each)."""
    out = []
    for r0 in range(0, grid.ny, tile):
        rs = slice(r0, min(r0 + tile, grid.ny))
        for c0 in range(0, grid.nx, tile):
            cs = slice(c0, min(c0 + tile, grid.nx))
            out.append((rs, cs))
    return out


def _tile_errors(t, q, r0, freq, grid: Grid, tiles, eps, n_side=5, max_pulses=64) -> np.ndarray:
    """Predicted relative error of :func:`subimage_nufft` for each tile size in ``tiles`` (module
    docstring): the worst of the tiles at the grid's centre and corners (ranges differ across the
    scene), plus the NUFFT's own ``eps``.

    At ``n_side²`` points of each of those tiles, the residual phases ``ρ[p, j, s]`` of steps 3-4
    (the exact range minus its linearisation about the tile's centre pixel, at the band's ends and
    middle, less the central pulse's curvature at the central frequency), for every size in one
    pass over ``max_pulses`` pulses; the error is ``rms |e^{iρ} − 1|``."""
    t = np.asarray(t, float)
    q = None if q is None else np.asarray(q, float)
    r0 = np.asarray(r0, float)
    P = t.shape[0]
    pi = np.linspace(0, P - 1, min(P, max_pulses)).round().astype(int)      # increasing: drop repeats
    pi = pi[np.concatenate([[True], np.diff(pi) > 0])]
    fr = np.asarray(freq, float)
    fr = fr if fr.ndim == 1 else fr[0]
    gx, gy = grid.x, grid.y
    owner, centres, pts = [], [], []
    for i_size, tile in enumerate(int(x) for x in tiles):
        n_cols, n_rows = math.ceil(grid.nx / tile), math.ceil(grid.ny / tile)
        n = n_cols * n_rows
        for i in sorted(p for p in {0, n - 1, n // 2, n_cols - 1, n - n_cols} if 0 <= p < n):
            r_, c_ = divmod(i, n_cols)
            rs = slice(r_ * tile, min((r_ + 1) * tile, grid.ny))
            cs = slice(c_ * tile, min((c_ + 1) * tile, grid.nx))
            ny, nx = rs.stop - rs.start, cs.stop - cs.start
            centres.append((gx[cs.start + nx // 2], gy[rs.start + ny // 2]))
            xs = np.linspace(gx[cs.start], gx[cs.stop - 1], n_side)
            ys = np.linspace(gy[rs.start], gy[rs.stop - 1], n_side)
            pts.append(np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2))
            owner.append(i_size)
    xc = np.column_stack([np.asarray(centres), np.zeros(len(centres))])                  # [T, 3]
    pts = np.concatenate([np.stack(pts), np.zeros((len(pts), n_side * n_side, 1))], axis=2)   # [T, S, 3]
    tt, qq = t[pi], (None if q is None else q[pi])
    rr = r0[pi]
    exact = (_ranges(tt, qq, rr, pts.reshape(-1, 3)).reshape(pi.size, *pts.shape[:2])
             - _ranges(tt, qq, rr, xc)[:, :, None])                                        # [p, T, S]

    def unit(a):
        v = a[:, None, :] - xc[None, :, :]
        return v / np.linalg.norm(v, axis=2, keepdims=True)                               # [p, T, 3]

    look = unit(tt) if qq is None else 0.5 * (unit(tt) + unit(qq))
    d = pts[:, :, :2] - xc[:, None, :2]                          # the points lie in the plane z = 0
    rem = exact + look[:, :, None, 0] * d[None, :, :, 0] + look[:, :, None, 1] * d[None, :, :, 1]
    k = sampling.range_wavenumbers(fr[[0, fr.size // 2, -1]])
    kc = sampling.range_wavenumbers(fr[fr.size // 2])
    rho = k[None, :, None, None] * rem[:, None] - kc * rem[pi.size // 2][None, None]       # [p, j, T, S]
    per_tile = 2.0 * np.sqrt(np.mean(np.sin(0.5 * rho) ** 2, axis=(0, 1, 3)))              # rms |e^{iρ} − 1|
    owner = np.asarray(owner)
    return np.array([per_tile[owner == i].max() for i in range(len(tiles))]) + float(eps)


def predict_tile_error(t, q, r0, freq, grid: Grid, tile: int, *, eps=1e-9) -> float:
    """Predicted relative error of :func:`subimage_nufft` with ``tile``-pixel tiles (module docstring).

    The worst of the tiles at the grid's centre and corners (ranges differ across the scene),
    plus the NUFFT's own ``eps`` (:func:`_tile_errors`).
    """
    return float(_tile_errors(t, q, r0, freq, grid, [int(tile)], eps)[0])


def tile_sizes(grid: Grid) -> list:
    """The tile sizes :func:`choose_tile` considers, largest first: the grid's larger side, then
    every smaller one of :data:`TILE_SIZES`."""
    side = max(grid.nx, grid.ny)
    return [side] + [s for s in TILE_SIZES if s < side]


def choose_tile(t, q, r0, freq, grid: Grid, tolerance: float, *, eps=None, min_tile=None):
    """Largest tile of :data:`TILE_SIZES` (capped at the grid) predicted to meet ``tolerance``.

    Returns ``(tile, predicted_error)``, or ``(None, error of the smallest tile)`` when none does.
    The error grows with the tile (the residual of the linearised range grows with the distance
    from the tile's centre), so the sizes are bisected: four or five predictions, not one a size.
    ``min_tile``: a tile smaller than this is of no use to the caller; ``(None, nan)`` as soon as
    the answer is known to be one (or none), else the same answer.
    """
    eps = tolerance / 10 if eps is None else eps
    sizes = tile_sizes(grid)
    known = {}

    def err(i):
        if i not in known:
            known[i] = float(_tile_errors(t, q, r0, freq, grid, [sizes[i]], eps)[0])
        return known[i]

    lo, hi = 0, len(sizes) - 1
    if min_tile is None:
        e_hi = err(hi)
        if e_hi > tolerance:
            return None, e_hi
    # sizes[hi] meets (with min_tile: is taken to, and checked only if the answer is of use)
    while lo < hi:                    # find the largest that meets
        if min_tile is not None and sizes[lo] < min_tile:
            return None, math.nan     # the answer is at most sizes[lo]
        mid = (lo + hi) // 2
        e_mid = err(mid)
        if e_mid <= tolerance:
            hi = mid
        else:
            lo = mid + 1
    if min_tile is not None:
        if sizes[hi] < min_tile:
            return None, math.nan
        if err(len(sizes) - 1) > tolerance:
            return None, err(len(sizes) - 1)
    return sizes[hi], err(hi)


def subimage_nufft(data, collection, grid: Grid, options=None, *, nthreads=None, return_info=False):
    """Spherical matched filter by one NUFFT per motion-compensated tile (module docstring).

    Parameters
    ----------
    data : array_like, shape (P, M)
    collection : Collection
        Frequencies (M,) or (P, M), antenna positions (P, 3; transmit positions with receive
        positions), reference ranges (P,), window weights and receive positions
        (:class:`sarcli.core.collection.Collection`).
    grid : Grid
    options : SubimageOptions, optional
        The knobs (:class:`sarcli.formers.options.SubimageOptions`, default its defaults): ``tile``,
        the tile side in pixels (None: the largest predicted to meet ``tolerance``);
        ``tolerance``, the target relative error when no tile is given; ``eps``, the NUFFT
        accuracy (None: ``tolerance / 10``).
    nthreads : int, optional
    return_info : bool
        Also return ``{'tile', 'eps', 'predicted_error', 'n_tiles'}``.

    Returns
    -------
    image : ndarray (ny, nx), complex128
    """
    import finufft

    from .direct import weighted_samples

    opts = SubimageOptions() if options is None else options
    tile, tolerance, eps = opts.tile, opts.tolerance, opts.eps
    weights, rcv = collection.weights, collection.receive_position_m
    wd, total = weighted_samples(data, None if weights is None else np.broadcast_to(weights, np.shape(data)))
    P, M = wd.shape
    t = np.asarray(collection.antenna_position_m, float)
    q = None if rcv is None else np.asarray(rcv, float)
    r0 = np.asarray(collection.range_to_center_m, float)
    if t.shape != (P, 3) or r0.shape != (P,):
        raise SarcliInputError(f"antenna positions {t.shape} / ranges {r0.shape} do not match {P} pulses")
    f = np.broadcast_to(np.asarray(collection.frequency_hz, float), (P, M))
    k = sampling.range_wavenumbers(f)
    if tile is None:
        tile, pred = choose_tile(t, q, r0, f, grid, tolerance, eps=eps)
        if tile is None:
            raise SarcliInputError(f"no sub-image size meets tolerance {tolerance:g} here (smallest tile: "
                                   f"predicted {pred:.3g}); use ffbp or backprojection")
    tile = int(tile)
    if tile < 1:
        raise SarcliInputError(f"tile must be at least one pixel, got {tile}")
    eps = tolerance / 10 if eps is None else float(eps)
    pred = predict_tile_error(t, q, r0, f, grid, tile, eps=eps)
    out = np.empty(grid.shape, dtype=np.complex128)
    # one single-threaded NUFFT per tile, tiles on a thread pool: FINUFFT's own threads on a tiny
    # output grid spend their time synchronising (slower than one thread at 16² pixels)
    opts = {"nthreads": 1, "spread_sort": 0}
    pc = P // 2
    kc = float(k[pc, M // 2])

    def one(tile_slices):
        rs, cs = tile_slices
        ny, nx = rs.stop - rs.start, cs.stop - cs.start
        xc = np.array([grid.x[cs.start + nx // 2], grid.y[rs.start + ny // 2], 0.0])
        drc = _ranges(t, q, r0, xc[None, :])[:, 0]                       # (P,)
        u = _look(t, q, xc)
        c = (wd * np.exp(1j * k * drc[:, None])).ravel()
        k1 = geometry.wrap_phase(-(k * u[:, 0:1]) * grid.dx).ravel()
        k2 = geometry.wrap_phase(-(k * u[:, 1:2]) * grid.dy).ravel()
        img = finufft.nufft2d1(k2, k1, c, (ny, nx), eps=eps, isign=1, **opts)
        # curvature phase of the central pulse at the central frequency
        xx, yy = np.meshgrid(grid.x[cs], grid.y[rs])
        pts = np.stack([xx, yy, np.zeros_like(xx)], axis=-1).reshape(-1, 3)
        tc, qc = t[pc:pc + 1], (None if q is None else q[pc:pc + 1])
        rem = (_ranges(tc, qc, r0[pc:pc + 1], pts)[0] - drc[pc]) + u[pc] @ (pts - xc).T
        out[rs, cs] = img * np.exp(1j * kc * rem).reshape(ny, nx)

    tiles = _tile_centres(grid, tile)
    workers = max(1, int(nthreads) if nthreads is not None else (os.cpu_count() or 1))
    if workers == 1 or len(tiles) == 1:
        for ts in tiles:
            one(ts)
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            list(pool.map(one, tiles))
    out /= total
    info = {"tile": tile, "eps": eps, "predicted_error": pred, "n_tiles": len(tiles)}
    return (out, info) if return_info else out
