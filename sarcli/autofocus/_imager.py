"""The image of phase-corrected data and the adjoint that gives the entropy's per-pulse gradient.

For a per-pulse phase correction ``φ_p`` the image is linear in the corrected data,

.. math::

    f(φ) = B\\,(d \\odot e^{-iφ}) = \\sum_p e^{-iφ_p}\\, b_p, \\qquad b_p = B_p d_p ,

with ``B`` the backprojection (``B_p`` its part for pulse ``p``). The entropy
``H = -Σ_s q_s \\ln q_s`` (``q_s = |f_s|² / E``, ``E = Σ_s |f_s|²``) has the gradient

.. math::

    \\frac{∂H}{∂φ_p} = 2\\, \\operatorname{Im}\\Big(e^{-iφ_p} \\sum_s w_s \\overline{f_s}\\, b_{ps}\\Big)
    = 2\\, \\operatorname{Im}\\Big(e^{-iφ_p} \\sum_j \\overline{R_{pj}}\\, d_{pj}\\Big),
    \\qquad w_s = -\\frac{\\ln q_s + H}{E}, \\quad R = B^{H} (w \\odot f),

because ``Σ_s g_s (B_p d_p)_s = ⟨B_p^H \\bar g, d_p⟩``. So one backprojection gives ``H`` and one
pass of the same size gives all ``P`` partial derivatives: two images of memory, none per pulse.
That pass (:func:`sarcli.formers.backprojection.pulse_contractions`) gathers ``Σ_s g_s (B_p d_p)_s``
from each pulse's profile as the backprojection does, the same numbers as the reprojection
formula (:func:`~sarcli.formers.backprojection.reproject`, the exact adjoint) without its scatter.
Both run on a :class:`~sarcli.formers.backprojection.Backprojector`: the range profiles of the
uncorrected data made once, each image multiplying pulse ``p``'s by ``e^{-iφ_p}``. Collections the
backprojector does not take (far-field model, unequally spaced frequencies) use the stack of single-pulse
images instead (:func:`~sarcli.autofocus._common.pulse_images`; small cases only).
"""

from __future__ import annotations

import threading
import warnings

import numpy as np

from ..core.grid import Grid
from ..errors import SarcliInputError, SarcliWarning
from ..formers.options import BackprojectionOptions
from ._common import MAX_GUARDED_PIXELS, guarded_grid, pulse_images

__all__ = ["Imager", "BlockImager", "entropy_of", "split_grid", "check_splittable", "every_nth_line",
           "range_axis", "single_threaded_blas"]

#: Backprojection options of the estimator: the pair backproject/reproject is an exact adjoint
#: for any of them, and the estimate only needs the image to a few per cent.
ESTIMATION_BP = BackprojectionOptions(upsample=4, interp="linear", precision="float32")


def prepared_backprojector(ph, grid: Grid, data):
    """The estimator's backprojector of ``data`` (``ph``'s samples as complex128) on ``grid``: the
    backprojection plan of :data:`ESTIMATION_BP` made ready for many images
    (:attr:`sarcli.formers.former.Plan.prepare`)."""
    from ..formers import plan_image

    return plan_image(ph, grid, ESTIMATION_BP).prepare(data)


#: The band left between the two halves of a grid, as a fraction of its width (:func:`split_grid`).
SPLIT_GAP = 0.125


class single_threaded_blas:
    """Context: numpy's matrix products on one thread (threadpoolctl's limit on the BLAS pools).

    The BLAS calls of minimum entropy are short (L-BFGS-B's, the small products of the level
    bases): a second thread saves no wall time, and OpenBLAS's idle threads spin after each call,
    which on cores shared with other jobs cost more CPU time than the whole search
    (``docs/autofocus.md``). threadpoolctl limits only the libraries already loaded, so load them
    first. The limit is process-wide: nested and concurrent uses are counted, and the last one out
    restores it.
    """

    _lock = threading.Lock()
    _users = 0
    _limit = None

    def __enter__(self):
        cls = type(self)
        with cls._lock:
            if cls._users == 0:
                from threadpoolctl import threadpool_limits

                cls._limit = threadpool_limits(limits=1, user_api="blas")
            cls._users += 1
        return self

    def __exit__(self, *exc):
        cls = type(self)
        with cls._lock:
            cls._users -= 1
            if cls._users == 0:
                cls._limit.restore_original_limits()
                cls._limit = None
        return False


def entropy_of(image, order: float = 1.0) -> tuple[float, np.ndarray, np.ndarray]:
    """The Rényi entropy ``H_α`` of order ``α = order`` of an image's normalised intensity ``q``, ``q``
    itself, and the gradient weights ``w_s = ∂H_α/∂|f_s|²``.

    ``H_1 = -Σ q ln q`` (Shannon), ``w = -(ln q + H_1)/E``; for ``α ≠ 1``
    ``H_α = ln(Σ q^α)/(1 - α)`` and ``w = α (q^{α-1} - S)/((1 - α) S E)`` with ``S = Σ q^α`` and
    ``E = Σ|f|²``; pixels with ``q = 0`` get ``w = 0``. Orders below 1 weigh the dim pixels more:
    on a scene of points in clutter the minimum of ``H_{1/2}`` lies closer to the true phase than
    that of ``H_1`` (``docs/autofocus.md``).
    """
    f = np.asarray(image)
    inten = f.real.astype(np.float64) ** 2 + f.imag.astype(np.float64) ** 2
    total = float(inten.sum())
    if total <= 0.0:
        return 0.0, inten, np.zeros_like(inten)
    q = inten / total
    pos = q > 0
    if order == 1.0:
        logq = np.log(np.where(pos, q, 1.0))
        h = float(-np.sum(q * logq))
        return h, q, -(logq + h) / total
    qm1 = np.where(pos, np.where(pos, q, 1.0) ** (order - 1.0), 0.0)  # q^(α-1), 0 where q = 0
    S = float(np.sum(q * qm1))
    h = float(np.log(S) / (1.0 - order))
    return h, q, np.where(pos, order * (qm1 - S) / ((1.0 - order) * S * total), 0.0)


class Imager:
    """Images of ``d · exp(-iφ)`` on one grid, and the entropy with its per-pulse gradient.

    Parameters
    ----------
    ph : PhaseHistory
    grid : Grid
    order : float
        Order of the Rényi entropy (:func:`entropy_of`).
    like : Imager or BlockImager, optional
        An imager of the same ``ph`` on another grid: its prepared backprojector's range profiles
        are shared (:meth:`sarcli.formers.backprojection.Backprojector.on`).
    stack : bool
        Where the backprojector does not take the data, hold the stack of single-pulse images
        (False: neither, and the imager forms no image;
        :func:`~sarcli.autofocus._sharpness.sharpness_imager` then uses :func:`~sarcli.autofocus._common.form`).
    """

    def __init__(self, ph, grid: Grid, order: float = 1.0, *, like=None, stack: bool = True):
        self.grid = grid
        self.order = float(order)
        self.stack = self._bp = None
        self.evaluations = 0
        acq = ph.acquisition
        if like is not None and like._bp is not None and like._ph is ph:
            with warnings.catch_warnings():  # as below
                warnings.simplefilter("ignore", SarcliWarning)
                self._ph, self._bp = ph, like._bp.on(grid)   # the same data: their range profiles shared
            return
        data = np.asarray(ph.data, dtype=np.complex128)
        self._ph = ph
        if acq.model == "spherical" and data.shape[1] >= 2:
            try:  # the backprojector's checks; its range profiles once for every image and contraction
                with warnings.catch_warnings():  # a guard band may reach the unambiguous window: harmless
                    warnings.simplefilter("ignore", SarcliWarning)
                    self._bp = prepared_backprojector(ph, grid, data)
                return
            except SarcliInputError:  # unequally spaced frequencies: the stack below
                pass
        if stack:
            self.stack = pulse_images(ph, grid)

    def image(self, phi) -> np.ndarray:
        """``f(φ)``, shape ``grid.shape``."""
        if self.stack is not None:
            e = np.exp(-1j * np.asarray(phi, np.float64))
            return (e.astype(self.stack.dtype) @ self.stack).reshape(self.grid.shape)
        return self._bp.image(phi)

    def _contract(self, g) -> np.ndarray:
        """``v_p = Σ_s g_s b_ps`` for an image-shaped ``g``."""
        if self.stack is not None:
            return self.stack @ g.ravel().astype(self.stack.dtype)
        return self._bp.contract(g)

    def blockwise(self, phi) -> np.ndarray:
        """``φ`` itself (this imager is exact for any per-pulse phase)."""
        return np.asarray(phi, np.float64)

    def coarsened(self, pulses: int) -> "Imager":
        """This imager (it has no sub-apertures to merge)."""
        return self

    def entropy(self, phi) -> float:
        """``H(f(φ))``."""
        return entropy_of(self.image(phi), self.order)[0]

    def entropy_and_gradient(self, phi) -> tuple[float, np.ndarray]:
        """``H(φ)`` and ``∂H/∂φ_p`` (module docstring): one image and one adjoint."""
        phi = np.asarray(phi, np.float64)
        self.evaluations += 1
        f = self.image(phi)
        h, _, w = entropy_of(f, self.order)
        v = self._contract(w * np.conj(f))
        return h, 2.0 * np.imag(np.exp(-1j * phi) * v)


def range_axis(acq) -> int:
    """The image axis closer to the ground range direction: 1 (x, columns) or 0 (y, rows)."""
    th = float(np.angle(np.mean(np.exp(1j * np.asarray(acq.azimuth_rad, np.float64)))))
    return 1 if abs(np.cos(th)) >= abs(np.sin(th)) else 0


def split_grid(grid: Grid, axis: int = 1, gap: float = 0.0) -> tuple[Grid, ...]:
    """Two disjoint halves of ``grid`` along ``axis`` (1: near and far columns, 0: rows), and,
    when ``gap > 0``, the band between them (``gap`` of the grid's width, at least 2 pixels).

    Split across range, each half holds whole cross-range lines: a phase error moves energy only
    in cross-range, so neither half can lower its entropy by pushing energy into the other. The
    band keeps the halves out of each other's range sidelobes.

    Returns
    -------
    (low, high) or (low, high, band) : Grids
    """
    n, d, c = (grid.nx, grid.dx, grid.cx) if axis == 1 else (grid.ny, grid.dy, grid.cy)
    g = 0 if gap <= 0 else max(2, int(round(gap * n / 2)) * 2)
    half = (n - g) // 2
    if half < 2:
        raise SarcliInputError(f"a grid {n} pixels across cannot be split in two halves")
    first = c - (n // 2) * d  # coordinate of pixel 0

    def part(start, size):
        centre = first + (start + size // 2) * d
        if axis == 1:
            return Grid(size, grid.ny, grid.dx, grid.dy, centre, grid.cy)
        return Grid(grid.nx, size, grid.dx, grid.dy, grid.cx, centre)

    parts = (part(0, half), part(half + g, n - half - g))
    return parts + ((part(half, g),) if g else ())


def check_splittable(user: Grid, est: Grid, guarded: Grid, acq, axis: int) -> None:
    """Raise a :class:`~sarcli.errors.SarcliInputError` naming ``user`` and the pixels across range
    it needs when ``guarded`` cannot be split in two halves (:func:`split_grid`).

    Parameters
    ----------
    user, est, guarded : Grid
        The grid asked for, its estimation window and that window widened by the guard band.
    acq : Acquisition
    axis : int
        The axis across range (:func:`range_axis`).
    """
    def splits(g):
        try:
            return bool(split_grid(g, axis, SPLIT_GAP))
        except SarcliInputError:
            return False

    if splits(guarded):
        return
    n0 = est.nx if axis == 1 else est.ny
    wider = (Grid(n, est.ny, est.dx, est.dy, est.cx, est.cy) if axis == 1 else
             Grid(est.nx, n, est.dx, est.dy, est.cx, est.cy) for n in range(n0 + 1, n0 + 65))
    need = next((g.nx if axis == 1 else g.ny for g in wider
                 if splits(guarded_grid(g, acq, max_pixels=max(g.nx * g.ny, MAX_GUARDED_PIXELS)))), None)
    raise SarcliInputError(
        f"min-entropy autofocus needs an image grid of {f'at least {need}' if need else 'more'} pixels along "
        f"{'x' if axis == 1 else 'y'} (across range) to compare two halves of the scene; the grid is "
        f"{user.nx} x {user.ny} pixels ({user.dx:g} x {user.dy:g} m): widen it (--extent) or use pga")


def every_nth_line(grid: Grid, axis: int, n: int) -> Grid:
    """Every ``n``-th line of ``grid`` across ``axis`` (1: columns, 0: rows), each line whole and
    the lines kept centred in the grid: a grid whose pixels are pixels of ``grid`` (``grid`` itself
    when ``n <= 1``).

    Across range (``axis`` of :func:`range_axis`) it keeps whole cross-range lines, the lines along
    which a phase error moves energy.
    """
    if n <= 1:
        return grid
    size, d, c = (grid.nx, grid.dx, grid.cx) if axis == 1 else (grid.ny, grid.dy, grid.cy)
    m = (size - 1) // n + 1
    offset = (size - 1 - (m - 1) * n) // 2
    centre = c + (offset + (m // 2) * n - size // 2) * d
    if axis == 1:
        return Grid(m, grid.ny, d * n, grid.dy, centre, grid.cy)
    return Grid(grid.nx, m, grid.dx, d * n, grid.cx, centre)


def _merge_rows(part, starts) -> np.ndarray:
    """``np.add.reduceat(part, starts, axis=0)``, row by row (several times faster on a wide stack)."""
    out = np.empty((len(starts), part.shape[1]), part.dtype)
    ends = np.append(starts[1:], part.shape[0])
    for i, (a, b) in enumerate(zip(starts, ends)):
        np.copyto(out[i], part[a])
        for r in range(a + 1, b):
            out[i] += part[r]
    return out


class BlockImager:
    r"""Images of ``d · exp(-iφ)`` from sub-aperture images of ``K`` consecutive pulses.

    With the block images ``F_b = Σ_{p ∈ b} b_p`` and the block phase ``θ = Mφ`` (``M`` averages
    the pulses of each block) the image is ``f = Σ_b e^{-iθ_b} F_b``, exact when ``φ`` is constant
    within each block, and

    .. math::

        \frac{∂H}{∂φ_p} = \frac{1}{K_b}\, 2 \operatorname{Im}\Big(e^{-iθ_b}
            \sum_s w_s \overline{f_s}\, F_{bs}\Big), \qquad p ∈ b .

    Memory: ``⌈P/K⌉`` images. The stack is held as the two halves of :func:`split_grid` (each
    ``blocks × pixels``, contiguous), so that :meth:`halves` costs nothing.

    Parameters
    ----------
    ph : PhaseHistory
    grid : Grid
    block : int
        Pulses per sub-aperture.
    axis : int
        The axis the halves split (:func:`split_grid`).
    order : float
        Order of the Rényi entropy (:func:`entropy_of`).
    """

    def __init__(self, ph, grid: Grid, block: int, axis: int = 1, *, order: float = 1.0, _parts=None,
                 _bounds=None, _counter=None):
        self.grid = grid
        self.order = float(order)
        self.axis = axis
        self._evaluations, self._counter = 0, _counter
        self._ph = self._bp = None   # the data and their prepared backprojector, when built here
        if _parts is None:
            P = ph.data.shape[0]
            self.bounds = np.append(np.arange(0, P, block), P)
            self.parts = self._build(ph, grid, split_grid(grid, axis, SPLIT_GAP))
        else:
            self.bounds, self.parts = _bounds, _parts
        self._sizes = np.diff(self.bounds).astype(np.float64)

    def _build(self, ph, grid, pieces):
        """The block images on ``grid``, each cut into the ``pieces`` of :func:`split_grid`
        (low, high[, band]; in the image: low, band, high along ``axis``)."""
        acq = ph.acquisition
        nb = len(self.bounds) - 1
        size = [g.nx if self.axis == 1 else g.ny for g in pieces]
        edges = [(0, size[0]), (size[0] + (size[2] if len(size) > 2 else 0), None)]
        if len(size) > 2:
            edges.append((size[0], size[0] + size[2]))
        parts = [np.empty((nb, g.nx * g.ny), dtype=np.complex64) for g in pieces]

        def store(b, re, im):
            # straight into the parts' real and imaginary parts: no complex image in between
            for part, g, (lo, hi) in zip(parts, pieces, edges):
                dst = part[b].reshape(g.ny, g.nx)
                cut = (slice(None), slice(lo, hi)) if self.axis == 1 else (slice(lo, hi),)
                np.copyto(dst.real, re[cut])
                np.copyto(dst.imag, im[cut])

        data = np.asarray(ph.data, dtype=np.complex128)
        if acq.model == "spherical" and data.shape[1] >= 2:
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", SarcliWarning)
                    # the range profiles made once, kept for the exact imagers of the same data
                    self._ph, self._bp = ph, prepared_backprojector(ph, grid, data)
                    for b, re, im in self._bp.group_images(self.bounds):
                        store(b, re, im)
                return parts
            except SarcliInputError:  # unequally spaced frequencies: single-pulse images below
                self._bp = None
        pulses = pulse_images(ph, grid)
        for b in range(nb):
            img = pulses[self.bounds[b]:self.bounds[b + 1]].sum(axis=0).reshape(grid.shape)
            store(b, img.real, img.imag)
        return parts

    #: Guards the evaluation counts and the merged stacks' cache: imagers of one stack may search
    #: on several threads.
    _count_lock = threading.Lock()

    def coarsened(self, pulses: int) -> "BlockImager":
        """An imager of sub-apertures of about ``pulses`` pulses: ``m ≥ 1`` consecutive blocks of
        this stack summed (``m`` the most whose blocks stay within ``pulses``; this imager when
        ``m = 1``). Exact for a phase constant over each merged block, and ``m`` times cheaper per
        evaluation: the levels searching a phase smooth over ``pulses`` pulses need no finer
        blocks. Evaluations are counted on this imager.
        """
        K = int(self._sizes.max())
        m = max(1, int(pulses) // max(K, 1))
        if m == 1 or len(self.bounds) - 1 <= 2 * m:
            return self
        # the merged stacks are shared with the imagers of the same stack in another order (built
        # once, also when those search on other threads)
        with self._count_lock:
            cache = self.__dict__.setdefault("_coarse", {})
            if m not in cache:
                starts = np.arange(0, len(self.bounds) - 1, m)
                cache[m] = ([_merge_rows(part, starts) for part in self.parts],
                            np.append(self.bounds[starts], self.bounds[-1]))
            parts, bounds = cache[m]
        return BlockImager(None, self.grid, 0, self.axis, order=self.order, _parts=parts, _bounds=bounds,
                           _counter=self)

    def with_order(self, order: float) -> "BlockImager":
        """The same images measured by the Rényi entropy of another ``order`` (no copy; its
        evaluations are counted on this imager)."""
        if float(order) == self.order:
            return self
        other = BlockImager(None, self.grid, 0, self.axis, order=order, _parts=self.parts, _bounds=self.bounds,
                            _counter=self)
        other._coarse = self.__dict__.setdefault("_coarse", {})
        other._ph, other._bp = self._ph, self._bp
        return other

    def halves(self) -> tuple["BlockImager", "BlockImager"]:
        """The imagers of the two halves of :func:`split_grid` (this stack's own parts, no copy)."""
        return tuple(BlockImager(None, g, 0, self.axis, order=self.order, _parts=[part], _bounds=self.bounds)
                     for g, part in zip(split_grid(self.grid, self.axis, SPLIT_GAP)[:2], self.parts))

    @property
    def evaluations(self) -> int:
        """Entropy-and-gradient evaluations (those of its :meth:`coarsened` imagers included)."""
        return self._counter.evaluations if self._counter is not None else self._evaluations

    def _count(self):
        if self._counter is not None:
            self._counter._count()
        else:
            with self._count_lock:  # imagers of one stack may search on several threads
                self._evaluations += 1

    def _theta(self, phi):
        return np.add.reduceat(np.asarray(phi, np.float64), self.bounds[:-1]) / self._sizes

    def _image(self, e):
        return np.concatenate([e.astype(np.complex64) @ part for part in self.parts])

    def blockwise(self, phi) -> np.ndarray:
        """``Mᵀθ``: ``φ`` replaced by its block means, the phase this imager's images are exact for."""
        return np.repeat(self._theta(phi), np.diff(self.bounds))

    def image(self, phi) -> np.ndarray:
        """``f(φ)`` with ``φ`` averaged over each block (the halves' pixels one after the other)."""
        return self._image(np.exp(-1j * self._theta(phi)))

    def _sums(self, e, grad: bool):
        """One fused pass over the stack (``sarcli._native._autofocus.entropy_sums``, per part):
        ``E = Σ|f|²``, ``T`` (``Σ I ln I``, or ``Σ I^α``) and, with ``grad``, the per-block
        ``X_b = Σ_s F_bs conj(f_s) a_s`` and ``Y_b = Σ_s F_bs conj(f_s)`` (``a = ln I`` or ``I^(α-1)``)."""
        from .._native import load

        kern, nb = load("autofocus"), len(self.bounds) - 1
        e = np.ascontiguousarray(e, np.complex64)
        E = T = 0.0
        X = np.zeros(nb, np.complex128) if grad else None
        Y = np.zeros(nb, np.complex128) if grad else None
        x = np.empty(nb, np.complex128) if grad else None
        y = np.empty(nb, np.complex128) if grad else None
        # the calling thread's count: the halves' searches, side by side, run theirs on one each
        # (_search.each); a search alone uses the idle cores too
        for part in self.parts:
            dE, dT = kern.entropy_sums(part, e, self.order, x, y)
            E, T = E + dE, T + dT
            if grad:
                X += x
                Y += y
        return E, T, X, Y

    def _entropy_from(self, E, T) -> float:
        if E <= 0.0:
            return 0.0
        if self.order == 1.0:
            return float(np.log(E) - T / E)
        return float(np.log(T / E ** self.order) / (1.0 - self.order))

    def entropy(self, phi) -> float:
        """``H(f(φ))`` (:func:`entropy_of`), from one pass over the stack without the image."""
        E, T, _, _ = self._sums(np.exp(-1j * self._theta(phi)), False)
        return self._entropy_from(E, T)

    def entropy_and_gradient(self, phi) -> tuple[float, np.ndarray]:
        """``H`` and its per-pulse gradient (class docstring), from one pass over the stack.

        With ``v_b = Σ_s w_s conj(f_s) F_bs`` (``w`` of :func:`entropy_of`): Shannon's
        ``w = -(ln I - ln E + H)/E`` gives ``v = -(X - (T/E) Y)/E``; order ``α`` gives
        ``v = α (E^{1-α} X - S Y)/((1-α) S E)``, ``S = T/E^α``.
        """
        self._count()
        e = np.exp(-1j * self._theta(phi))
        E, T, X, Y = self._sums(e, True)
        h = self._entropy_from(E, T)
        if E <= 0.0:
            v = np.zeros_like(X)
        elif self.order == 1.0:
            v = -(X - (T / E) * Y) / E
        else:
            a = self.order
            S = T / E ** a
            v = a * (E ** (1.0 - a) * X - S * Y) / ((1.0 - a) * S * E)
        return h, np.repeat(2.0 * np.imag(e * v) / self._sizes, np.diff(self.bounds))
