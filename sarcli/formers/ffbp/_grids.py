"""Polar-grid geometry of ffbp (:mod:`sarcli.formers.ffbp`) in NumPy, and the deapodization of its
kernels: where it holds, each pulse's tones, and the profiles' weights that divide the kernels'
mean responses out of the data (:func:`sarcli.formers.ffbp.model.deapodized_kernel`).

The sub-apertures of every level (:func:`_split`, :class:`Apertures`) have polar frames: their
centres and the grown grid's bounds in each frame's q and u (:class:`_FrameGeometry`, independent
of the sampling), then the spacing in u for an angular oversampling (:class:`_Frame`), then the
grids extended to hold later stencils (:class:`_Level`). :class:`Apertures` keeps what does not
depend on the oversampling (frame geometry, pulse tones) for recent pulses, grids and knobs."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

from ...core.grid import Grid
from ...errors import SarcliInputError
from .model import angle_interp_error, deapodized_error, deapodized_response, deapodized_slope, interp_error

#: Points per side of the grown grid's boundary where the frames' bounds are taken (:func:`_boundary`).
BOUNDARY_POINTS = 33
#: Every this many boundary points (and the grid's centre), each pulse's tones are taken
#: (:func:`_check_points`).
CHECK_STRIDE = 4
#: A centre's nadir must lie at least this fraction of its ground distance from the scene origin
#: away from every boundary point along ``e0`` (else the polar coordinates degenerate).
NADIR_CLEARANCE = 0.05
#: Pulses whose tones are taken at once (:func:`_rates`): no [P, points] temporaries beyond this.
PULSE_BLOCK = 4096
#: :func:`_split` rounds the number of base sub-apertures up by at most this factor.
SPLIT_ROUND_UP = 1.25
#: Recent :class:`Apertures` kept (:func:`apertures`).
APERTURES_KEPT = 16
#: Digests of unchangeable arrays kept (:func:`_digest`).
DIGESTS_KEPT = 8
_TINY = 1e-300


def _centre_geometry(c):
    """Rows cx, cy, |c|, ρ0, e0x, e0y, cz of the polar frames of centres ``c`` [S, 3]."""
    cn = np.linalg.norm(c, axis=1)
    rho0 = np.hypot(c[:, 0], c[:, 1])
    if np.any(rho0 <= 0):
        raise SarcliInputError("ffbp needs every sub-aperture centre away from the scene origin's vertical; "
                               "use method 'backprojection'")
    e0 = -c[:, :2] / rho0[:, None]
    return np.ascontiguousarray(np.stack([c[:, 0], c[:, 1], cn, rho0, e0[:, 0], e0[:, 1], c[:, 2]]))


def polar_coords(g, x, y):
    """NumPy twin of the compiled ``_coords``: (q, u, a) [S, n] for points (x, y); ``a`` is the
    point's distance from the centre's nadir along ``e0``."""
    cx, cy, cn, rho0, e0x, e0y = (r[:, None] for r in g[:6])
    num = x * x + y * y - 2.0 * (cx * x + cy * y)
    q = num / (np.sqrt(cn * cn + num) + cn)
    return q, (e0x * y - e0y * x) / (cn + q), rho0 + e0x * x + e0y * y


def _ray_derivatives(g, sub, xs, ys):
    """Ground displacements ``dx/dq`` (along a row: u fixed) and ``dx/du`` (q fixed) at points
    (xs, ys) of the polar grids of centres ``g[:, sub]``: ``x = n0 + a e0 + uR e⊥`` with
    ``a = √(R²(1 − u²) − c_z²)``, so ``dx/dR = (R(1 − u²)/a) e0 + u e⊥`` and
    ``dx/du = −(R² u/a) e0 + R e⊥``. Rows are the centres ``sub``, columns the points."""
    cx, cy, _, rho0, e0x, e0y, cz = (v[sub][:, None] for v in g)
    rng = np.sqrt((xs - cx) ** 2 + (ys - cy) ** 2 + cz * cz)
    u = (e0x * ys - e0y * xs) / rng
    a = rho0 + e0x * xs + e0y * ys
    ca, cu = rng * (1.0 - u * u) / a, -rng * rng * u / a
    return (ca * e0x - u * e0y, ca * e0y + u * e0x), (cu * e0x - rng * e0y, cu * e0y + rng * e0x)


def _range_rate(pos, xs, ys, dx, dy):
    """Directional derivative ``∇R_p · (dx, dy)`` of the ranges of pulses ``pos`` [n, 3] (rows)
    at the ground points (xs, ys) (columns)."""
    px, py, pz = xs - pos[:, 0:1], ys - pos[:, 1:2], pos[:, 2:3]
    return (px * dx + py * dy) / np.sqrt(px * px + py * py + pz * pz)


def _boundary(grid: Grid, margin: float):
    """Points on the boundary of the grid's rectangle grown by ``margin`` metres."""
    x0, x1 = grid.x[0] - grid.dx / 2 - margin, grid.x[-1] + grid.dx / 2 + margin
    y0, y1 = grid.y[0] - grid.dy / 2 - margin, grid.y[-1] + grid.dy / 2 + margin
    n = BOUNDARY_POINTS
    s = np.linspace(0, 1, n)
    xs = np.concatenate([x0 + (x1 - x0) * s, np.full(n, x1), x1 - (x1 - x0) * s, np.full(n, x0)])
    ys = np.concatenate([np.full(n, y0), y0 + (y1 - y0) * s, np.full(n, y1), y1 - (y1 - y0) * s])
    return xs, ys, (x0, x1, y0, y1)


@dataclass(frozen=True, eq=False)
class _FrameGeometry:
    """What a level's polar frames are that does not depend on the sampling (:func:`_frame_geometry`)."""

    geo: np.ndarray          # [7, S] centre geometry (_centre_geometry)
    q_min: np.ndarray        # bounds of the grown grid in each frame's q and u
    q_max: np.ndarray
    u_min: np.ndarray
    u_max: np.ndarray
    d: np.ndarray            # largest horizontal distance of a pulse from its centre
    tilt: np.ndarray         # largest |u| R/a over the grown grid (the band's growth across u)


@dataclass(frozen=True, eq=False)
class _Frame:
    """The polar frames of one level's sub-apertures at one angular sampling (:func:`_frame`)."""

    first: np.ndarray        # first pulse of each sub-aperture
    count: np.ndarray        # pulses in each
    geo: np.ndarray          # [7, S] centre geometry (_centre_geometry)
    q_min: np.ndarray        # bounds of the grid grown by the margin, in each frame's q and u
    q_max: np.ndarray
    u_min: np.ndarray
    u_max: np.ndarray
    du: np.ndarray           # spacing in u of each sub-aperture's grid
    beta: float              # the least angular oversampling over the sub-apertures
    metres_per_u: float      # ground metres per unit u (the largest R)


def ground_reach(levels) -> float:
    """The largest ``|u|`` any level's polar grid reaches (its rows' first and last). Past
    ``|u| = 1`` a node is no ground point (near the radar, a coarse grid's extension): the kernels
    keep such nodes out, and ffbp's error model does not cover the image they leave."""
    reach = 0.0
    for lv in levels:
        last = lv.u0 + (lv.n_u - 1) * lv.du
        reach = max(reach, float(np.max(np.abs(lv.u0))), float(np.max(np.abs(last))))
    return reach


@dataclass(frozen=True, eq=False)
class _Level:
    """Sub-apertures of one stage and their polar grids (all of one shape ``n_u × n_q``)."""

    first: np.ndarray        # first pulse of each sub-aperture
    count: np.ndarray        # pulses in each
    geo: np.ndarray          # [7, S] centre geometry (_centre_geometry)
    q0: np.ndarray           # each grid's first node in q and u
    u0: np.ndarray
    du: np.ndarray           # each grid's spacing in u (in q: the plan's dq, common)
    n_u: int
    n_q: int
    children: tuple | None = None   # (first, count) of each sub-aperture's children in the level below
    #: [n, n_u, 2] int64: the nodes ``start .. stop-1`` of each row that later stencils can read
    #: (:func:`sarcli.formers.ffbp._rows.with_rows`); None: every node
    rows: np.ndarray | None = None

    @property
    def n(self):
        return self.first.size

    @property
    def grid_nodes(self) -> np.ndarray:
        """Nodes formed in each sub-aperture's grid, ``[n]`` (those of :attr:`rows`, else the whole grid)."""
        if self.rows is None:
            return np.full(self.n, float(self.n_u) * self.n_q)
        return np.sum(self.rows[..., 1] - self.rows[..., 0], axis=1).astype(np.float64)

    @property
    def nodes(self) -> float:
        """Nodes formed in all the grids (:attr:`grid_nodes`)."""
        return float(np.sum(self.grid_nodes))

    def row_table(self, a=0, b=None):
        """:attr:`rows` of sub-apertures ``a .. b-1`` as the kernels take them (None: every node)."""
        return None if self.rows is None else self.rows[a:b]

    @property
    def nbytes(self) -> float:
        """Bytes of this level's sub-images (float32 real and imaginary parts)."""
        return 8.0 * self.n * self.n_u * self.n_q


def _frame_geometry(pos, first, count, boundary) -> _FrameGeometry:
    """What :func:`_frame` finds that does not depend on the sampling (centres, bounds in the polar
    coordinates, the band's geometric factors; :meth:`Apertures.geometry` keeps it), for the grid
    grown by a margin whose :func:`_boundary` is ``boundary``."""
    run = pos[first[0]:first[-1] + count[-1]]   # the sub-apertures are consecutive runs of pulses
    starts = first - first[0]
    centres = np.add.reduceat(run, starts, axis=0) / count[:, None]
    g = _centre_geometry(centres)
    xs, ys, (x0, x1, y0, y1) = boundary
    q, u, den = polar_coords(g, xs[None, :], ys[None, :])
    if np.any(den <= NADIR_CLEARANCE * g[3][:, None]):
        raise SarcliInputError("ffbp needs the antennas' nadir well outside the image; use method 'backprojection'")
    # nearest point of the rectangle to each centre's nadir: the smallest q (q is convex in x)
    qn, _, _ = polar_coords(g, np.clip(centres[:, 0], x0, x1)[:, None], np.clip(centres[:, 1], y0, y1)[:, None])
    q_min = np.minimum(q.min(axis=1), qn[:, 0])
    q_max = q.max(axis=1)
    # band along u: |∂R_p/∂u| = |Δ⊥ − Δ_e0 u R/a| ≤ d √(1 + (uR/a)²) for a pulse Δ from the centre
    # (d its horizontal distance, a the point's distance from the nadir along e0)
    sub = np.repeat(np.arange(first.size), count)
    d = np.maximum.reduceat(np.hypot(*(run[:, :2] - centres[sub, :2]).T), starts)
    tilt = np.max(np.abs(u) * (g[2][:, None] + q) / den, axis=1)
    out = _FrameGeometry(g, q_min, q_max, u.min(axis=1), u.max(axis=1), d, tilt)
    for v in vars(out).values():
        v.setflags(write=False)   # shared by the plans of one Apertures
    return out


def _frame(geo: _FrameGeometry, first, count, kmax, os_angle, band_scale=1.0) -> _Frame:
    """Polar frames of the sub-apertures ``first/count`` of frame geometry ``geo``
    (:func:`_frame_geometry`): centres, bounds of the grid grown by the margin in their
    coordinates, spacing in u and ground metres per unit u (the largest R). ``band_scale`` widens
    the band in u the spacing is made for (:func:`band_excess`)."""
    span = np.maximum(geo.u_max - geo.u_min, _TINY)
    band = kmax * geo.d * np.sqrt(1.0 + geo.tilt * geo.tilt) * float(band_scale)
    du = np.where(band > 0, np.pi / np.maximum(band, _TINY) / os_angle, span)
    du = np.minimum(du, span / 2.0)
    beta = float(np.min(np.where(band > 0, np.pi / np.maximum(band * du, _TINY), np.inf)))
    return _Frame(first, count, geo.geo, geo.q_min, geo.q_max, geo.u_min, geo.u_max, du, beta,
                  float(np.max(geo.geo[2] + geo.q_max)))


def level_grid(fr: _Frame, dq, ext_q, ext_u, children=None) -> _Level:
    """The polar grids of a frame, extended by ``ext_q``/``ext_u`` samples on each side (``ext_u``
    may differ between sub-apertures; the grids share the largest shape), every node of every row
    formed (:func:`sarcli.formers.ffbp._rows.with_rows` bounds the rows)."""
    n_u = int(np.max(np.ceil((fr.u_max - fr.u_min) / fr.du) + 2 * np.asarray(ext_u))) + 1
    n_q = int(np.max(np.ceil((fr.q_max - fr.q_min) / dq))) + 1 + 2 * ext_q
    return _Level(fr.first, fr.count, fr.geo, fr.q_min - ext_q * dq, fr.u_min - ext_u * fr.du, fr.du, n_u, n_q,
                  children)


def pulse_rates(t, rcv, fr, xs, ys, parent=None, rays=None):
    """Each pulse's ``∂R_p/∂q`` and ``∂R_p/∂u`` on its sub-aperture's polar grid (derivatives along
    a row and across rows, :func:`_ray_derivatives`): the middle of each one's range over the points
    (xs, ys) and half that range, as ``(q_mid, q_half, u_mid, u_half)`` over the frame's pulses.

    A pulse's component of wavenumber ``k_j`` is locally the tone ``k_j ∂R_p/∂q`` along q (the
    sub-image is demodulated by ``k_ref``) and ``k_j ∂R_p/∂u`` along u: ``≈ k_j`` and ``≈ k_j Δ⊥``
    (Δ⊥ its offset across from the centre) wherever it is on the grid, which is why u, not an
    angle, is the polar grids' coordinate. A climbing path or a long sub-aperture spreads them.
    ``fr``: a :class:`_Frame` or :class:`_Level`. ``t``, ``rcv``: transmit and receive positions
    (the same array for a monostatic collection; the range is their mean). ``parent``: the centre
    geometry of each sub-aperture's parent [7, S] when a merge reads this level; its second pass
    interpolates along the parent's rows (direction ``v``), so the range tone it reads is
    ``∇R_p·v / ∇q·v`` per unit of this grid's q. ``rays``: :func:`_unit_rays` of ``t`` and ``rcv``
    at the points, when already at hand."""
    return _rates(rays or _unit_rays(t, rcv, xs, ys), fr.first, fr.count, fr.geo, xs, ys, parent, True)


def _rates(rays, first, count, g, xs, ys, parent, want_u):
    """:func:`pulse_rates` of the sub-apertures ``first/count`` (centre geometry ``g``) from the
    unit rays; ``want_u=False`` leaves the u rows out (``None``)."""
    n_sub = first.size
    sub = np.repeat(np.arange(n_sub), count)
    a0, a1 = first[0], first[-1] + count[-1]
    every = np.arange(n_sub)   # the grids' directions, once per sub-aperture
    (gqx, gqy), (gux, guy) = _ray_derivatives(g, every, xs[None, :], ys[None, :])
    gden = None
    if parent is not None:
        (gqx, gqy), _ = _ray_derivatives(parent, every, xs[None, :], ys[None, :])
        gden = _range_rate(np.stack([g[0], g[1], g[6]], axis=1), xs[None, :], ys[None, :], gqx, gqy)
    out = np.empty((4, sub.size))
    for a in range(0, sub.size, PULSE_BLOCK):   # blocks of pulses: bounded [pulses, points] temporaries
        sb = sub[a:a + PULSE_BLOCK]
        lo, hi = a0 + a, min(a0 + a + PULSE_BLOCK, a1)
        for i, (gx, gy) in enumerate(((gqx, gqy), (gux, guy)) if want_u else ((gqx, gqy),)):
            rate = _dot(rays, lo, hi, gx[sb], gy[sb])
            if i == 0 and gden is not None:
                rate = rate / gden[sb]
            top, bottom = rate.max(axis=1), rate.min(axis=1)
            out[2 * i, a:a + top.size], out[2 * i + 1, a:a + top.size] = 0.5 * (top + bottom), 0.5 * (top - bottom)
    return (out[0], out[1]) + ((out[2], out[3]) if want_u else (None, None))


def _unit_rays(t, rcv, xs, ys):
    """Unit vectors (x and y components, ``[P, points]``) from the pulses ``t`` (and the receive
    positions ``rcv`` where they differ) to the ground points (xs, ys): what :func:`pulse_rates`
    needs of the pulses, shared by every level."""
    def one(pos):
        px, py, pz = xs[None, :] - pos[:, 0:1], ys[None, :] - pos[:, 1:2], pos[:, 2:3]
        inv = 1.0 / np.sqrt(px * px + py * py + pz * pz)
        return px * inv, py * inv
    return (one(t),) if rcv is t else (one(t), one(rcv))


def _dot(rays, lo, hi, gx, gy):
    """:func:`_range_rate` of pulses ``lo .. hi-1`` along the directions (gx, gy) [pulses, points]:
    the mean over the transmit and receive rays."""
    (px, py), rest = rays[0], rays[1:]
    rate = px[lo:hi] * gx + py[lo:hi] * gy
    if rest:
        (rx, ry), = rest
        rate = 0.5 * (rate + (rx[lo:hi] * gx + ry[lo:hi] * gy))
    return rate


def deapodization(freq_hz, plan, n_len):
    """Weights [1, M] that divide the range profiles' deapodized kernel's mean response out of the
    data (:func:`sarcli.formers.ffbp.model.deapodized_kernel`) where the plan says: bin ``j − j_c``
    of the FFT of length L is the frequency ``(j − j_c)/L``, exactly. (The polar grids' kernels read
    a frequency per pulse and level: :func:`decide_deapodization`, ``_stage0.tone_weights``.)"""
    m = np.shape(freq_hz)[-1]
    if not plan.profiles_deapodized:
        return np.ones((1, m))
    return 1.0 / deapodized_response(float(plan.knobs["upsample"]), (np.arange(m) - m // 2) / float(n_len))[None, :]


def _check_points(grid, boundary):
    """Points where each pulse's tones are taken (the deapodization's frequency mismatch is bounded
    there): every :data:`CHECK_STRIDE`-th point of the grown grid's boundary (:func:`_boundary`),
    and its centre."""
    bx, by, _ = boundary
    return (np.concatenate([bx[::CHECK_STRIDE], [0.5 * (grid.x[0] + grid.x[-1])]]),
            np.concatenate([by[::CHECK_STRIDE], [0.5 * (grid.y[0] + grid.y[-1])]]))


def _split(n, size, merge=None):
    """``ceil(n / size)`` consecutive groups of ``n`` items, as equal as possible: (first, count).

    Equal groups give sub-apertures of equal length, hence equal angular spacings; a short last
    group would have a coarse spacing that sets every grid's extension (the grids share a shape).
    With ``merge`` (the base sub-apertures), the number of groups is rounded up, by at most a
    factor :data:`SPLIT_ROUND_UP`, to ``r·merge^a`` (``r < 2·merge``), so that every merge stage
    groups them evenly too.
    """
    n_groups = -(-int(n) // int(size))
    if merge is not None:
        m, cands = int(merge), []
        while m <= 2 * n_groups:
            cand = m * -(-n_groups // m)
            if cand // m < 2 * int(merge) and cand <= min(SPLIT_ROUND_UP * n_groups, n):
                cands.append(cand)
            m *= int(merge)
        n_groups = min(cands, default=n_groups)
    edges = (np.arange(n_groups + 1) * int(n)) // n_groups
    return edges[:-1], np.diff(edges)


class Apertures:
    """Every level of sub-apertures ffbp can form from the pulses ``t`` (``rcv``: receive positions,
    the same array when monostatic) with ``base`` and ``merge``, on one grid: their pulses, the
    geometry of their polar frames (:func:`_frame_geometry`) and their pulses' tones
    (:func:`pulse_rates`), each computed when first asked for and kept. None of it depends on the
    oversampling, so a sweep of oversamplings (the planner's) computes it once per base.

    Level 0 holds the base sub-apertures (:func:`_split`); level l+1 groups level l's in runs of
    ``merge``; the last level has one sub-aperture. ``children[l]``: ``(first, count)`` of each
    level-l sub-aperture's children in level l-1 (``None`` for level 0)."""

    def __init__(self, t, rcv, grid: Grid, margin: float, base: int, merge: int):
        self.t, self.rcv, self.grid, self.margin = t, rcv, grid, float(margin)
        first, count = _split(t.shape[0], base, merge)
        self.first, self.count, self.children = [first], [count], [None]
        while self.first[-1].size > 1:
            cur_first, cur_count = self.first[-1], self.count[-1]
            pf, pc = _split(cur_first.size, merge)
            self.first.append(cur_first[pf])
            self.count.append(np.array([cur_count[i:i + m].sum() for i, m in zip(pf, pc)]))
            self.children.append((pf, pc))
        self._pos = t if rcv is t else 0.5 * (t + rcv)
        self._geometry, self._frames, self._rates, self._reach = {}, {}, {}, {}
        self._boundary = _boundary(grid, margin)
        self._points = self._rays = None

    @property
    def n_levels(self) -> int:
        return len(self.first)

    @property
    def bounds(self) -> tuple:
        """The grid's rectangle grown by the margin, ``(x0, x1, y0, y1)``
        (:func:`sarcli.formers.ffbp._rows.with_rows`)."""
        return self._boundary[2]

    def geometry(self, l: int) -> _FrameGeometry:
        """:func:`_frame_geometry` of level ``l``."""
        if l not in self._geometry:
            self._geometry[l] = _frame_geometry(self._pos, self.first[l], self.count[l], self._boundary)
        return self._geometry[l]

    def frame(self, l: int, kmax: float, os_angle: float, band_scale: float) -> _Frame:
        """:func:`_frame` of level ``l``."""
        key = (l, float(kmax), float(os_angle), float(band_scale))
        if key not in self._frames:
            self._frames[key] = _frame(self.geometry(l), self.first[l], self.count[l], kmax, os_angle, band_scale)
        return self._frames[key]

    def tone_reach(self, l: int, last: bool) -> tuple:
        """What :func:`band_excess` needs of :meth:`rates`: the least and largest ``∂R_p/∂q`` over
        the pulses and points, and each sub-aperture's largest ``|∂R_p/∂u|``."""
        key = (l, bool(last))
        if key not in self._reach:
            q_mid, q_half, u_mid, u_half = self.rates(l, last)
            starts = self.first[l] - self.first[l][0]
            self._reach[key] = (float(np.min(q_mid - q_half)), float(np.max(q_mid + q_half)),
                                np.maximum.reduceat(np.abs(u_mid) + u_half, starts))
        return self._reach[key]

    def parents(self, l: int) -> np.ndarray:
        """Index in level l+1 of each level-l sub-aperture's parent."""
        return np.searchsorted(self.children[l + 1][0], np.arange(self.first[l].size), side="right") - 1

    def rates(self, l: int, last: bool) -> tuple:
        """:func:`pulse_rates` of level ``l`` on the grid grown by the margin (its edge and centre,
        :func:`_check_points`): read by the final stage where ``last``, else by a merge into
        level l+1 (along its parents' rows)."""
        key = (l, bool(last))
        if key not in self._rates:
            if self._rays is None:
                self._points = _check_points(self.grid, self._boundary)
                self._rays = _unit_rays(self.t, self.rcv, *self._points)
            parent = None if last else self.geometry(l + 1).geo[:, self.parents(l)]
            u = self._rates.get((l, not last))   # the u rows do not depend on the reader
            q_mid, q_half, u_mid, u_half = _rates(self._rays, self.first[l], self.count[l], self.geometry(l).geo,
                                                  *self._points, parent, u is None)
            if u is not None:
                u_mid, u_half = u[2], u[3]
            self._rates[key] = (q_mid, q_half, u_mid, u_half)
        return self._rates[key]


def apertures(t, rcv, grid: Grid, margin: float, base: int, merge: int) -> Apertures:
    """The :class:`Apertures` of these pulses, grid and knobs, kept for recent plans."""
    key = (_digest(t), _digest(rcv) if rcv is not t else None, grid, float(margin), int(base), int(merge))
    hit = _APERTURES.get(key)
    if hit is None:
        hit = _keep(_APERTURES, key, Apertures(t, rcv, grid, margin, base, merge), APERTURES_KEPT)
    return hit


#: :func:`apertures` of recent plans.
_APERTURES: dict = {}


def _keep(cache: dict, key, value, limit: int):
    """Put ``value`` in ``cache`` under ``key``, dropping the oldest entry beyond ``limit``."""
    if len(cache) >= limit:
        cache.pop(next(iter(cache)))
    cache[key] = value
    return value


def _digest(a) -> bytes:
    """A key for the contents of ``a``; kept for arrays that cannot change (read-only and owning
    their data, as an :class:`~sarcli.core.acquisition.Acquisition`'s), which a sweep digests once."""
    a = np.ascontiguousarray(a)
    fixed = not a.flags.writeable and a.flags.owndata
    hit = _DIGESTS.get(id(a)) if fixed else None
    if hit is not None and hit[0] is a:
        return hit[1]
    out = hashlib.blake2b(a.view(np.uint8), digest_size=16).digest() + str(a.shape).encode()
    if fixed:
        _keep(_DIGESTS, id(a), (a, out), DIGESTS_KEPT)
    return out


#: :func:`_digest` of recent arrays that cannot change, by identity (each held, so its id stays its own).
_DIGESTS: dict = {}


def band_excess(reach, frames, kmin, kmax, kref, os_angle):
    """How far the pulses' tones reach past the bands the polar grids are sampled for, as
    ``(range, angle)`` ratios (1: exactly to the band's edge). Range: ``max |k ∂R_p/∂q − k_ref|``
    over the band and the grids against ``K_B/2``; angle: ``max k_max |∂R_p/∂u| Δu`` against
    ``π/os_angle``. Level paths stay within 2 %, climbing or squinted ones within ~15 %; a receiver far from the
    transmitter (the grids are centred on their mean) or a wide baseline does not, and then the
    grids must be sampled that much finer (:func:`sarcli.formers.ffbp.plan_stages`). ``reach``:
    :meth:`Apertures.tone_reach` of every level."""
    rq = ru = 0.0
    for (q_lo, q_hi, u_max), fr in zip(reach, frames):
        for wavenumber in (kmin, kmax):
            rq = max(rq, abs(wavenumber * q_lo - kref), abs(wavenumber * q_hi - kref))
        ru = max(ru, float(np.max(kmax * u_max * fr.du)) / (np.pi / float(os_angle)))
    return rq / (0.5 * (kmax - kmin)), ru


def decide_deapodization(rates, frames, kmax, kref, dq, os_range, os_angle):
    """Whether to deapodize the polar grids' range and angular kernels, from each pulse's tones on
    every level's grid (:meth:`Apertures.rates`).

    Pulse p's component at ``k_j`` is read by level l's interpolations at
    ``ν_q = k_j a_q[l, p] + b_q`` and ``ν_u = k_j a_u[l, p]`` cycles per sample, with
    ``a_q = ∂R_p/∂q · Δq/2π``, ``b_q = −k_ref Δq/2π`` and ``a_u = ∂R_p/∂u · Δu_l/2π``, so
    ``Π_l Ψ(ν)`` can be divided out of the data (``_stage0.tone_weights``). What the spread of
    the derivatives over a grid leaves costs ``rms_ν (d ln Ψ/dν) · k_max · rms_p (half-spread · Δ/2π)``
    per level (the mismatch: rms over the band and the pulses, as the aliases,
    :func:`sarcli.formers.ffbp.model.deapodized_error`). An axis is deapodized where its mismatch
    plus every level's aliases stays below the minimax stencils' error at the same oversampling.
    Returns ``{"range": (ok, mismatch, a_q, b_q), "angle": (ok, mismatch, a_u)}`` (the arrays
    ``None`` where not deapodized). ``rates``: :meth:`Apertures.rates` of every level."""
    n_lev, n_p = len(frames), rates[0][0].size
    a_q, a_u = np.empty((n_lev, n_p)), np.empty((n_lev, n_p))
    mis_q = mis_u = minimax_u = 0.0
    for l, fr in enumerate(frames):
        q_mid, q_half, u_mid, u_half = rates[l]
        du = np.repeat(fr.du, fr.count) / (2 * np.pi)
        a_q[l], a_u[l] = q_mid * dq / (2 * np.pi), u_mid * du
        mis_q += deapodized_slope(float(os_range)) * kmax * float(np.sqrt(np.mean(q_half ** 2))) * dq / (2 * np.pi)
        mis_u += deapodized_slope(float(os_angle)) * kmax * float(np.sqrt(np.mean((u_half * du) ** 2)))
        minimax_u += angle_interp_error("optimal", fr.beta, int(fr.count.max()), os_angle)
    ok_q = bool(n_lev * deapodized_error(float(os_range)) + mis_q < n_lev * interp_error("optimal", float(os_range)))
    ok_u = bool(n_lev * deapodized_error(float(os_angle)) + mis_u < minimax_u)
    return {"range": (ok_q, float(mis_q) if ok_q else 0.0, a_q if ok_q else None, -kref * dq / (2 * np.pi)),
            "angle": (ok_u, float(mis_u) if ok_u else 0.0, a_u if ok_u else None)}
