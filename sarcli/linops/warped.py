"""The spherical forward operator at FFT speed: sub-aperture NUFFTs on warped pixel positions.

The exact spherical model (docs/conventions.md "Data models") is
``A f (p, j) = Σ_x f(x) exp(−i k_pj d_p(x))``, ``k_pj = 4π α_pj / c`` and ``d_p(x)`` the
differential range (:func:`sarcli.core.geometry.bistatic_differential_range`). Split it as
``d_p(x) = d_p(0) + ρ_p(x)``: the first term is a phase per sample, exact. Over a short run of
pulses ``ρ_p(x)`` is, for every pixel, almost a linear function of the look direction
``v_p = −∇d_p(0)`` (horizontal part): ``ρ_p(x) ≈ −v_p · w(x)`` with ``w(x)`` the pixel's *warped
position*, fitted per pixel by least squares over the pulses (``w = x`` in the far field). Then

    A f (p, j) ≈ exp(−i k_pj d_p(0)) Σ_x f(x) exp(i κ_pj · w(x)),   κ_pj = k_pj v_p,

a non-uniform Fourier sum from non-uniform points ``w(x)`` to non-uniform frequencies
``κ_pj`` (a type-3 NUFFT). It is computed from pieces that are each exactly adjoint to their
reverse, so the pair (A, Aᴴ) is an exact adjoint pair as implemented:

1. ``E``: the phase ``exp(i κ̄·w(x))`` of the sub-aperture's mean frequency κ̄, per pixel;
2. ``S``: the pixels spread from ``u(x) = R w(x)`` (R rotates κ's principal axes onto the grid
   axes) onto a uniform grid of spacing ``h_i = π / (σ K_i)`` (K_i the half-extent of
   ``R(κ − κ̄)``, σ = 2) with FINUFFT's exponential-of-semicircle kernel φ (its spreader alone);
   the adjoint is its interpolation;
3. ``F``: the grid's Fourier series at ``ξ h`` (ξ = R(κ − κ̄)), a FINUFFT type-2 transform;
   the adjoint is the type-1 transform at the same points;
4. ``C``: per sample, ``exp(i ξ·o) / Φ̂(ξ)`` (o the grid's centre, Φ̂ the kernel's Fourier series)
   times ``exp(−i k d_p(0))``.

``AᴴA = Σ_s Eᴴ Sᵀ T_s S E`` with ``T_s = Fᴴ |C|² F`` applied by FFTs on the 2n × 2n embedding of
the grid (:class:`~sarcli.linops.toeplitz.ToeplitzGram`): per sub-aperture two passes of the
spreader over the pixels and two FFTs of a grid whose area shrinks as the sub-aperture does.

Error. The fit leaves a residual ``r_p(x) = ρ_p(x) + v_p·w(x)`` that grows as the square of the
sub-aperture's angular extent (it is the wavefront's curvature seen over the sub-aperture less
what a warp of the pixel absorbs). The predicted relative error of ``A f`` is the RMS of
``|exp(i k r_p(x)) − 1|`` over pixels (a 9 × 9 lattice over the grid, corners included), every
pulse, and the band's two ends and centre, plus the NUFFT's ``eps``. ``AᴴA`` sees that phase only
through its difference between two pixels, and its error is smaller (0.1-0.6 of it, measured); the
forward error is the bound :func:`predict_gram_error` holds it to. ``subapertures='auto'`` takes
the fewest equal runs of pulses that meet the tolerance by that bound, or, near it, by an
a-posteriori estimate against four times the runs (:func:`measured_gram_error`).

In the regulariser ``Aᴴb`` comes from the exact pair (one backprojection), so the normal equations'
only approximation is ``AᴴA``'s.
"""

from __future__ import annotations

import math

import finufft
import numpy as np
import scipy.fft

from .._native import load, threads
from ..core import geometry
from ..core.grid import Grid
from ..errors import SarcliInputError
from .base import Linop
from .spreading import SIGMA, kernel_series, kernel_table, kernel_weights
from .toeplitz import ToeplitzGram

__all__ = ["WarpedNufftOperator", "predict_error", "predict_gram_error", "measured_gram_error",
           "choose_subapertures", "SUBAPERTURE_COUNTS"]

#: Sub-aperture counts ``subapertures='auto'`` tries, fewest first.
SUBAPERTURE_COUNTS = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64)
#: The reference of :func:`measured_gram_error` has this many times the runs (16 times less error).
REFERENCE_FACTOR = 4
#: :func:`choose_subapertures` measures a count whose bound is within this factor of the tolerance.
MEASURE_ABOVE = 4.0
#: The smallest NUFFT tolerance: the Gram spreads in single precision with the same kernel.
EPS_MIN = 1e-6
#: Pixels along each side of the lattice on which the fit's residual is evaluated.
LATTICE = 9
#: Pulses of a run the per-pixel fit uses (evenly spread, ends included).
FIT_PULSES = 33
#: Nodes a side of the lattice the warp is fitted on and interpolated from (bicubic).
SPLINE_NODES = 48
#: Pixels per chunk of the per-pixel fit (bounds its work arrays to a few tens of MB).
_CHUNK = 16384
_C = 299_792_458.0


def _blocks(n_pulses: int, count: int) -> list[slice]:
    """``count`` runs of consecutive pulses, as equal as integers allow."""
    edges = np.linspace(0, n_pulses, count + 1).round().astype(int)
    return [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:]) if b > a]


def _look(t, q):
    """Horizontal look directions ``v_p = −∇d_p(0)`` (P, 2): the mean of the unit vectors to the
    transmitter and the receiver (the same vector, monostatic)."""
    def unit(a):
        return a / np.linalg.norm(a, axis=1)[:, None]
    return (0.5 * (unit(t) + unit(q)))[:, :2]


class _Fit:
    """The per-pixel warp of one run of pulses: ``w(x) = −(VᵀV)⁻¹ Vᵀ ρ(x)``, the least-squares
    fit over :data:`FIT_PULSES` pulses spread evenly over the run (ends included; ``ρ`` is smooth
    in the pulse, so more add nothing but time)."""

    def __init__(self, t, q, r0):
        self.t, self.q, self.r0 = t, q, r0
        self.offset = geometry.bistatic_differential_range(t, q, r0, np.zeros((1, 3)))[:, 0]
        self.v = _look(t, q)
        self.fit = np.unique(np.linspace(0, t.shape[0] - 1, FIT_PULSES).round().astype(int))
        vf = self.v[self.fit]
        self.pinv = np.linalg.solve(vf.T @ vf, vf.T)  # (2, FIT_PULSES)

    def rho(self, pts, pulses=slice(None)):
        """``ρ_p(x) = d_p(x) − d_p(0)`` of the given pulses, shape (P, S)."""
        return (geometry.bistatic_differential_range(self.t[pulses], self.q[pulses], self.r0[pulses], pts)
                - self.offset[pulses, None])

    def warp(self, pts):
        """Warped positions ``w(x)`` (S, 2) of points (S, 3), fitted at each point."""
        out = np.empty((pts.shape[0], 2))
        for a in range(0, pts.shape[0], _CHUNK):
            out[a:a + _CHUNK] = -(self.pinv @ self.rho(pts[a:a + _CHUNK], self.fit)).T
        return out

    def on_grid(self, grid: Grid):
        """``(wx, wy)(x, y)``: the warp over ``grid`` as bicubic splines of ``w(x) − x`` through
        its fit on a lattice of at most :data:`SPLINE_NODES` nodes a side (the warp is as smooth
        as the wavefront; the spline's own error is part of :meth:`residual`'s)."""
        from scipy.interpolate import RectBivariateSpline

        def nodes(c, n):
            return c[np.unique(np.linspace(0, n - 1, min(n, SPLINE_NODES)).round().astype(int))]
        xs, ys = nodes(grid.x, grid.nx), nodes(grid.y, grid.ny)
        xx, yy = np.meshgrid(xs, ys)
        w = self.warp(np.stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)], axis=1))
        dw = w - np.stack([xx.ravel(), yy.ravel()], axis=1)
        k = dict(kx=min(3, xs.size - 1), ky=min(3, ys.size - 1))
        return [RectBivariateSpline(ys, xs, dw[:, i].reshape(xx.shape), **k) for i in (0, 1)]

    def warp_on(self, splines, pts):
        """The spline warp (:meth:`on_grid`) at points (S, 3) inside the grid."""
        return pts[:, :2] + np.stack([sp.ev(pts[:, 1], pts[:, 0]) for sp in splines], axis=1)

    def residual(self, pts, splines):
        """The operator's residual ``r_p(x) = ρ_p(x) + v_p·w(x)`` (m) at every pulse, shape (P, S),
        with the spline warp."""
        return self.rho(pts) + self.v @ self.warp_on(splines, pts).T


def _lattice(grid: Grid) -> np.ndarray:
    """A ``LATTICE`` × ``LATTICE`` lattice of pixel centres spanning the grid, corners included."""
    xs = grid.x[np.unique(np.linspace(0, grid.nx - 1, LATTICE).round().astype(int))]
    ys = grid.y[np.unique(np.linspace(0, grid.ny - 1, LATTICE).round().astype(int))]
    xx, yy = np.meshgrid(xs, ys)
    return np.stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)], axis=1)


def _geometry(acq):
    if not acq.has_positions:
        raise SarcliInputError("the warped operator needs antenna positions; this collection has none")
    t, q, r0 = acq.range_geometry()
    k = 4 * np.pi * np.asarray(acq.frequencies_2d, np.float64) / _C
    return np.asarray(t, float), np.asarray(q, float), np.asarray(r0, float), k


def predict_error(acq, grid: Grid, subapertures: int, *, eps: float = 1e-6) -> float:
    """Predicted relative error of ``A f`` of :class:`WarpedNufftOperator` with ``subapertures``
    runs of pulses (module docstring): RMS of ``|exp(i k r_p(x)) − 1|`` over a lattice of pixels,
    every pulse and the band's ends and centre, plus ``eps``."""
    t, q, r0, k = _geometry(acq)
    pts = _lattice(grid)
    cols = np.unique([0, k.shape[1] // 2, k.shape[1] - 1])
    total, count = 0.0, 0
    for b in _blocks(t.shape[0], subapertures):
        fit = _Fit(t[b], q[b], r0[b])
        r = fit.residual(pts, fit.on_grid(grid))  # (P_s, S)
        e = np.abs(np.expm1(1j * k[b][:, cols][:, :, None] * r[:, None, :]))
        total += float(np.sum(e * e))
        count += e.size
    return math.sqrt(total / count) + eps


def predict_gram_error(acq, grid: Grid, subapertures: int, *, eps: float = 1e-6) -> float:
    """Predicted relative error of ``AᴴA f``: that of ``A f`` (:func:`predict_error`).

    ``AᴴA`` sees the residual phase only through its difference between two pixels,
    ``k (r_p(x) − r_p(x'))``, weighted by the point response between them, so its error is the
    smaller: measured against the exact model (random images and point scenes, grids of 48-192
    pixels a side), 0.10-0.14 of the forward error on circular arcs and 0.28-0.57 on straight
    lines, without a law in the grid's size that would hold for both. The forward error is the
    bound the tolerance is held to."""
    return predict_error(acq, grid, subapertures, eps=eps)


def measured_gram_error(acq, grid: Grid, subapertures: int, *, eps: float = 1e-6, built: dict | None = None) -> float:
    """An a-posteriori bound on the ``AᴴA`` error with ``subapertures`` runs: its relative
    difference from the operator with :data:`REFERENCE_FACTOR` times as many runs, on two probes
    (a seeded random image, and a point at the grid's corner pixel, where the residual is largest),
    plus the reference's own predicted forward error (16 times smaller, the residual falling as the
    square of the run). Costs building both operators and four ``AᴴA`` products; inf where the
    reference would have runs of fewer than 8 pulses. ``built``: a dict that receives the operator
    with ``subapertures`` runs under that key, for a caller that goes on to use it."""
    ref_runs = REFERENCE_FACTOR * subapertures
    if acq.n_pulses // ref_runs < 8:
        return math.inf
    rng = np.random.default_rng(0)
    x = rng.standard_normal(grid.shape) + 1j * rng.standard_normal(grid.shape)
    point = np.zeros(grid.shape, np.complex128)
    point[0, 0] = 1.0
    op = WarpedNufftOperator(acq, grid, subapertures=subapertures, eps=eps)
    gram = op.gram()
    if built is not None:
        built[subapertures] = op
    ref = WarpedNufftOperator(acq, grid, subapertures=ref_runs, eps=eps).gram()
    worst = 0.0
    for f in (x, point):
        want = ref.forward(f)
        worst = max(worst, float(np.linalg.norm(gram.forward(f) - want) / np.linalg.norm(want)))
    return worst + predict_error(acq, grid, ref_runs, eps=eps)


def choose_subapertures(acq, grid: Grid, tolerance: float, *, eps: float | None = None, built: dict | None = None):
    """The fewest sub-apertures (of :data:`SUBAPERTURE_COUNTS`, at least 8 pulses each) whose
    ``AᴴA`` error is within ``tolerance``: predicted by the forward error
    (:func:`predict_gram_error`), or, where that bound is at most :data:`MEASURE_ABOVE` times the
    tolerance, measured (:func:`measured_gram_error`; ``AᴴA`` sees the residual only through its
    differences between pixels, and is often 3-10 times better than the bound). ``built``: a dict
    that receives the operators the measurement built, by their count (the chosen one among them).

    Returns
    -------
    count : int or None
        None when no count meets the tolerance.
    error : float
        The ``AᴴA`` error at ``count``, predicted or measured (at the largest count tried when None).
    """
    eps = max(tolerance / 10 if eps is None else eps, EPS_MIN)
    err = math.inf
    for n in SUBAPERTURE_COUNTS:
        if n > 1 and acq.n_pulses // n < 8:
            break
        err = predict_gram_error(acq, grid, n, eps=eps)
        if err <= tolerance:
            return n, err
        if err <= MEASURE_ABOVE * tolerance:
            measured = measured_gram_error(acq, grid, n, eps=eps, built=built)
            if measured <= tolerance:
                return n, measured
    return None, err


def _fast_size(n: int) -> int:
    """The smallest even size ≥ ``n`` whose Toeplitz embedding ``2n`` FFTs fast (2, 3, 5, 7, 11
    only: a large prime factor makes the Gram's FFTs several times slower)."""
    m = scipy.fft.next_fast_len(2 * n)
    while m % 4:
        m = scipy.fft.next_fast_len(m + 1)
    return m // 2


class _Run:
    """One run of pulses: its warp, grid, plans and per-sample factors (module docstring, 1-4)."""

    def __init__(self, t, q, r0, k, grid, eps, nthreads):
        fit = _Fit(t, q, r0)
        xx, yy = np.meshgrid(grid.x, grid.y)
        sx, sy = fit.on_grid(grid)
        # pixel-length arrays as separate contiguous columns: (N, 2) @ (2, 2) products and axis-0
        # reductions of (N, 2) arrays are several times slower than these element-wise passes
        wx, wy = (xx + sx(grid.y, grid.x)).ravel(), (yy + sy(grid.y, grid.x)).ravel()   # w(x), (N,) each
        kap = k[:, :, None] * fit.v[:, None, :]             # (P_s, M, 2)
        kbar = kap.reshape(-1, 2).mean(axis=0)
        _, _, rot = np.linalg.svd(kap.reshape(-1, 2) - kbar, full_matrices=False)
        xi = (kap - kbar) @ rot.T                           # (P_s, M, 2) in the rotated frame
        u = (rot[0, 0] * wx + rot[0, 1] * wy, rot[1, 0] * wx + rot[1, 1] * wy)   # R w
        half = np.maximum(np.abs(xi).reshape(-1, 2).max(axis=0), 1e-12)
        h = np.pi / (SIGMA * half)
        lo, hi = np.array([c.min() for c in u]), np.array([c.max() for c in u])
        width = int(math.ceil(-math.log10(eps))) + 2
        n = np.array([_fast_size(int(m)) for m in np.ceil((hi - lo) / h) + 2 * width + 2])
        o = 0.5 * (lo + hi)
        tau = tuple(2 * np.pi * (u[i] - o[i]) / (n[i] * h[i]) for i in (0, 1))   # spreader coordinates in [-π, π)
        s = xi * h                                          # dimensionless frequencies, |s| ≤ π/σ
        phi = kernel_series(eps, s[..., 0].ravel()) * kernel_series(eps, s[..., 1].ravel())
        off = fit.offset
        self.image_phase = np.exp(1j * (kbar[0] * wx + kbar[1] * wy))          # E
        self.sample = (np.exp(1j * (xi[..., 0] * o[0] + xi[..., 1] * o[1])).ravel() / phi
                       * np.exp(-1j * k * off[:, None]).ravel())   # C
        self.weight2 = np.abs(self.sample) ** 2
        self.shape = (int(n[0]), int(n[1]))
        self._tau, self._nthreads = tau, nthreads
        self._s = tuple(np.ascontiguousarray(s[..., i].ravel()) for i in (0, 1))
        self._eps = eps
        self._plans = None
        self._toeplitz = None

    def plans(self):
        """FINUFFT's spreader, interpolator and the grid's type-2 / type-1 transforms of ``A`` and
        ``Aᴴ`` (made on first use: the Gram needs none of them)."""
        if self._plans is None:
            kw = dict(eps=self._eps, nthreads=self._nthreads) if self._nthreads else dict(eps=self._eps)
            spread = finufft.Plan(1, self.shape, spreadinterponly=1, upsampfac=SIGMA, modeord=0, **kw)
            interp = finufft.Plan(2, self.shape, spreadinterponly=1, upsampfac=SIGMA, modeord=0, **kw)
            for p in (spread, interp):
                p.setpts(*self._tau)
            fourier = finufft.Plan(2, self.shape, isign=+1, modeord=0, **kw)
            fourier_h = finufft.Plan(1, self.shape, isign=-1, modeord=0, **kw)
            for p in (fourier, fourier_h):
                p.setpts(*self._s)
            self._plans = (spread, interp, fourier, fourier_h)
        return self._plans

    def spread(self, f):
        return self.plans()[0].execute(np.ascontiguousarray(self.image_phase * f))

    def interp(self, g):
        return np.conj(self.image_phase) * self.plans()[1].execute(np.ascontiguousarray(g, np.complex128))

    def forward(self, f):
        return self.sample * self.plans()[2].execute(self.spread(f))

    def adjoint(self, y):
        return self.interp(self.plans()[3].execute(np.ascontiguousarray(np.conj(self.sample) * y)))

    def toeplitz(self) -> ToeplitzGram:
        """``T = Fᴴ|C|²F`` on the grid and the single-precision spreader around it (made on first
        use): the spreader's kernel weights precomputed per pixel (:func:`kernel_weights`), the
        spreading itself compiled (``sarcli._native._spread``)."""
        if self._toeplitz is None:
            table = kernel_table(self._eps)
            pts = [kernel_weights((self._tau[i] + np.pi) * self.shape[i] / (2 * np.pi), table) for i in (0, 1)]
            (self._i0, self._wy), (self._j0, self._wx) = pts
            s0, s1 = self._s
            # (FᴴWF)[m, m'] = Σ_l w_l e^{-i s_l·(m - m')}: ToeplitzGram's kernel at -s (k1 on columns)
            self._toeplitz = ToeplitzGram(-s1, -s0, self.shape, weights=self.weight2, eps=self._eps)
            self._phase32 = self.image_phase.astype(np.complex64)
        return self._toeplitz

    def gram(self, f32, out, work):
        """``Eᴴ Sᵀ T S E f`` in single precision (the Toeplitz form's own precision at this eps),
        into ``out`` (complex64, pixels), with the work arrays ``work`` (grid, applied, scratch,
        toeplitz) of one :class:`~sarcli.linops.warped_gram.WarpedGram`."""
        extra = max(0, threads() - 1)
        if work.scratch.shape[0] < extra:
            work.scratch = np.empty((extra,) + self.shape, np.complex64)
        pts = (self._i0, self._j0, self._wy, self._wx, self._phase32)
        kernels = load("spread")
        kernels.spread(*pts, f32, work.grid, work.scratch)
        work.toeplitz.apply(work.grid, out=work.applied)
        kernels.interp(*pts, work.applied, out)
        return out


class WarpedNufftOperator(Linop):
    """``A``: image ``[ny, nx]`` → spherical (or bistatic) phase history ``[P, M]`` at FFT speed.

    Sub-aperture NUFFTs on warped pixel positions (module docstring); an exact adjoint pair as
    implemented, whose difference from the exact spherical model is predicted by
    :func:`predict_error`.

    Parameters
    ----------
    acq : Acquisition
        With antenna positions (monostatic or bistatic).
    grid : Grid
    subapertures : int or 'auto'
        Runs of consecutive pulses, each with its own warp; 'auto': :func:`choose_subapertures`.
    tolerance : float
        Relative error of ``AᴴA`` that 'auto' meets (default 1e-3).
    eps : float, optional
        NUFFT tolerance (default ``tolerance / 10``; at least :data:`EPS_MIN`).
    nthreads : int, optional
        FINUFFT threads (default: FINUFFT's choice).
    predicted_error : float, optional
        With an integer ``subapertures`` that :func:`choose_subapertures` returned: the ``AᴴA``
        error it returned with it (measured, or the forward bound), recorded instead of the bound.

    Attributes
    ----------
    subapertures : int
    runs : list
        One run of pulses each (its warp, grid, tables and plans), in pulse order.
    predicted_error : float
        Predicted relative error of ``AᴴA`` against the exact spherical model.
    """

    def __init__(self, acq, grid: Grid, *, subapertures="auto", tolerance: float = 1e-3,
                 eps: float | None = None, nthreads: int | None = None, predicted_error: float | None = None):
        t, q, r0, k = _geometry(acq)
        super().__init__(grid.shape, (t.shape[0], k.shape[1]), np.complex128)
        self.grid, self.acquisition = grid, acq
        # the Gram's single-precision spreader needs eps >= 1e-6, and every piece one kernel
        self.eps = max(tolerance / 10 if eps is None else float(eps), EPS_MIN)
        built = {}
        if subapertures == "auto":
            n, err = choose_subapertures(acq, grid, tolerance, eps=self.eps, built=built)
            if n is None:
                raise SarcliInputError(
                    f"the warped operator cannot meet tolerance {tolerance:g} on this grid (predicted "
                    f"{err:.3g} with sub-apertures of 8 pulses); use the exact spherical pair")
        else:
            n = int(subapertures)
            if not 1 <= n <= t.shape[0]:
                raise SarcliInputError(f"subapertures must be 1..{t.shape[0]}, got {subapertures}")
            err = predict_gram_error(acq, grid, n, eps=self.eps) if predicted_error is None else predicted_error
        self.subapertures, self.predicted_error = n, float(err)
        self._blocks = _blocks(t.shape[0], n)
        same = built.get(n)   # the chooser built this operator to measure it
        self.runs = same.runs if same is not None and same.eps == self.eps else \
            [_Run(t[b], q[b], r0[b], k[b], grid, self.eps, nthreads) for b in self._blocks]

    @property
    def n_samples(self) -> int:
        return int(np.prod(self.oshape))

    def _forward(self, x):
        f = np.ascontiguousarray(x, np.complex128).ravel()
        out = np.empty(self.oshape, np.complex128)
        for b, run in zip(self._blocks, self.runs):
            out[b] = run.forward(f).reshape(-1, self.oshape[1])
        return out

    def _adjoint(self, y):
        y = np.asarray(y, np.complex128)
        out = np.zeros(int(np.prod(self.ishape)), np.complex128)
        for b, run in zip(self._blocks, self.runs):
            out += run.adjoint(y[b].ravel())
        return out.reshape(self.ishape)

    def gram(self):
        """``AᴴA`` by FFTs on each sub-aperture's grid (:class:`~sarcli.linops.warped_gram.WarpedGram`)."""
        from .warped_gram import WarpedGram

        return WarpedGram(self)
