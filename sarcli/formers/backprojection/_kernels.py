"""Backprojection's compiled kernels (``src/native/backprojection.cpp``) and their planning.

The kernels cut the image into tiles of up to 128 pixels along a row (groups of 16 lanes). Per tile and pulse they
evaluate, in float64, the differential range at the tile's centre ``Δr_c`` and its derivatives
along the row; inside the tile a pixel at offset ``u`` from the centre takes

.. math::

    \\Delta r(u) = \\Delta r_c + d_1 u + d_2 u^2, \\qquad
    d_2 = \\frac{1 - c^2}{2R}, \\quad d_1 = c + \\tfrac34 h^2 d_3, \\quad
    d_3 = -\\frac{c (1 - c^2)}{2R^2},

(``R`` the range to the centre, ``c`` the direction cosine along the row, ``h`` the tile's half
width; the ``3/4 h² d3`` term is the Chebyshev economisation of the cubic Taylor term), so the
model leaves at most ``|d3| h³ / 4`` plus the quartic term (:func:`quadratic_error`). ``|d3|``
is largest at ``c² = 1/3``; where every pulse sees the grid's rows at a smaller cosine (rows
across the look direction, :func:`row_cosine`), the bound takes that cosine and tiles widen.

That error grows as ``h³ / R²``: near the radar the quadratic's tiles narrow to a few pixels and
the per-tile work dominates. The *series* model keeps wide tiles there: the plain Taylor quadratic
(``d1 = c``) in float64 plus, per pixel, the rest of the range's Taylor series to ``u⁹``,

.. math::

    R(u) = R \\sqrt{1 + 2 c s + s^2} = R \\sum_k b_k(c)\\, s^k, \\qquad s = u / R, \\qquad
    \\rho(u) = \\sum_{k=3}^{9} \\frac{b_k(c)}{R^{k-1}}\\, u^k, \\qquad
    (k + 1)\\, b_{k+1} = c (1 - 2k)\\, b_k + (2 - k)\\, b_{k-1},

(``b_1 = c``, ``b_2 = (1 − c²)/2``; a bistatic pair's coefficients are the mean of its ends'),
evaluated by Horner's rule in float32: six fused multiply-adds and three products a pixel, where
the range's square root and a reciprocal cost the loop about twice that. For ``|c| <= 1`` the
coefficients are bounded by ``|b_k| <= 4 |binom(1/2, k)|``, so the truncation after ``u⁹`` leaves at
most ``4 |binom(1/2, 10)| R s¹⁰ / (1 − s)`` with ``s = h / R_min`` (:func:`series_error`, which adds the
float32 roundings of the sum). :func:`tiling` picks,
of the two models, the tiling of least predicted cost (:func:`tile_cost`) whose error stays below
:data:`MODEL_TOLERANCE` in both carrier phase and profile bins. The profile position is float32
relative to an integer bin of the centre, the carrier phase float64 in turns reduced to half a
turn either side and evaluated by a float32 minimax polynomial; the interpolation weights and the carrier are thus
float32 (errors ~1e-7), the profiles and accumulation follow ``precision``.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from ..._native import load
from ..._native.layout import BpGeo

__all__ = ["GEO_ROWS", "MODEL_TOLERANCE", "QUADRATIC", "SERIES", "Tiling", "next_fast_len", "quadratic_error",
           "series_error", "row_cosine", "MODEL_SHARE", "model_tolerance", "tile_cost", "tile_width", "tiling", "kernels"]

#: Rows of the per-pulse geometry table the kernels read (:class:`sarcli._native.layout.BpGeo`).
GEO_ROWS = len(BpGeo)
#: Largest model error of a tile, in radians of carrier phase and in profile bins.
MODEL_TOLERANCE = 1e-5
#: Share of the interpolation's own RMS error (:func:`sarcli.formers.ffbp.model.interp_error`) that
#: the range model may add where that is more than :data:`MODEL_TOLERANCE` (:func:`model_tolerance`).
MODEL_SHARE = 0.01
_WIDTHS = (128, 96, 64, 48, 32, 16, 12, 8, 4, 2, 1)



def kernels():
    """The compiled module ``sarcli._native._backprojection``."""
    return load("backprojection")


def next_fast_len(n: int) -> int:
    """Smallest ``2^a 3^b 5^c 7^d 11^e >= n`` (the complex FFT sizes scipy.fft.next_fast_len gives)."""
    n = max(int(n), 1)
    best = 1 << (n - 1).bit_length()
    p11 = 1
    while p11 < best:
        p7 = p11
        while p7 < best:
            p5 = p7
            while p5 < best:
                p3 = p5
                while p3 < best:
                    v = p3
                    while v < n:
                        v *= 2
                    best = min(best, v)
                    p3 *= 3
                p5 *= 5
            p7 *= 7
        p11 *= 11
    return best


def _nearest(pos, grid):
    """Distance from each antenna position in ``pos`` [P, 3] to the grid's rectangle (z = 0, pixel
    edges included), and the rectangle's x edges ``(x0, x1)``."""
    pos = np.asarray(pos, dtype=np.float64)
    x0, x1 = grid.x[0] - grid.dx / 2, grid.x[-1] + grid.dx / 2
    y0, y1 = grid.y[0] - grid.dy / 2, grid.y[-1] + grid.dy / 2
    dx = np.clip(pos[:, 0], min(x0, x1), max(x0, x1)) - pos[:, 0]
    dy = np.clip(pos[:, 1], min(y0, y1), max(y0, y1)) - pos[:, 1]
    return np.sqrt(dx * dx + dy * dy + pos[:, 2] ** 2), (x0, x1)


def min_range(pos, grid) -> float:
    """Smallest distance from any antenna position in ``pos`` [P, 3] to the grid's rectangle (z = 0)."""
    return float(np.min(_nearest(pos, grid)[0]))


#: The two range models of a tile (module docstring).
QUADRATIC, SERIES = "quadratic", "series"
#: Unit roundoff of float32.
_EPS32 = 2.0**-24
#: The series model's last power of ``u`` (the kernels' ``kSeriesTerms`` terms from ``u³``).
SERIES_DEGREE = 9
#: float32 roundings that the series model's ρ accumulates, at most, as a multiple of the unit
#: roundoff times the sum of its terms' magnitudes (the coefficients' and offsets' conversions,
#: ``u³`` and the last fused multiply-adds of Horner's rule on the leading term: about 8; twice
#: that for margin, checked against float64 in tests/test_bp_tiles.py).
SERIES_ROUNDINGS = 16
#: Relative cost of a tile's work per pulse, in 16-lane groups of the quadratic model: a group of
#: lanes in each model (the series adds its polynomial a lane) and the float64 anchor of a tile
#: (measured: ``bench/bench_bp_range.py --tile-costs``).
_GROUP_COST = {QUADRATIC: 1.0, SERIES: 1.16}
_ANCHOR_COST = {QUADRATIC: 0.23, SERIES: 0.4}
_LANES = 16


class Tiling(NamedTuple):
    """A backprojection tiling: the range model, the tile width (pixels along a row), the model's
    largest error (radians of carrier phase or profile bins, whichever is larger) and the relative
    cost per pixel-pulse (:func:`tile_cost`)."""
    model: str
    width: int
    error: float
    cost: float


def quadratic_error(h: float, r: float, c_max: float = 1.0) -> float:
    """Largest range error (m) of the economised quadratic over a tile of half width ``h`` (m) whose
    pixels are at least ``r`` (m) from the antenna and see it at direction cosines along the row
    of at most ``c_max``: ``|d3| h³/4 + |d4| h⁴`` with ``|d3| = |c| (1 − c²) / (2R²)``, at most
    ``0.19245 / R²`` (at ``c² = 1/3``), and ``|d4| <= 5 / (8 R³)``."""
    c = min(abs(float(c_max)), 1.0)
    g = c * (1.0 - c * c) if c * c < 1.0 / 3.0 else 2.0 / (3.0 * math.sqrt(3.0))
    return 0.5 * g * h**3 / (4.0 * r * r) + 0.625 * h**4 / r**3


def row_cosine(pos, grid) -> float:
    """Largest direction cosine along the grid's rows (x) from any antenna position in ``pos`` [P, 3]
    to any point of the grid's rectangle (z = 0): ``max |x − a_x| / min |x − a|`` per position."""
    pos = np.asarray(pos, dtype=np.float64)
    near, (x0, x1) = _nearest(pos, grid)
    along = np.maximum(np.abs(x0 - pos[:, 0]), np.abs(x1 - pos[:, 0]))
    return float(min(1.0, np.max(along / np.maximum(near, 1e-300))))


def _half_binomial(k: int) -> float:
    """``|binom(1/2, k)|``."""
    v = 1.0
    for j in range(k):
        v *= (0.5 - j) / (j + 1)
    return abs(v)


#: ``4 |binom(1/2, k)|``, k = 0 .. 10: bounds on the series' coefficients ``|b_k(c)|`` for ``|c| <= 1``.
_SERIES_BOUND = tuple(4.0 * _half_binomial(k) for k in range(SERIES_DEGREE + 2))


def series_error(h: float, r: float) -> float:
    """Largest range error (m) of the series model over a tile of half width ``h`` (m) whose pixels
    are at least ``r`` (m) from the antenna: the truncation after ``u⁹``,
    ``4 |binom(1/2, 10)| r s¹⁰ / (1 − s)`` with ``s = h / r``, plus :data:`SERIES_ROUNDINGS` float32
    roundings of the sum of the terms' bounds ``r Σ 4 |binom(1/2, k)| s^k``; infinite from ``s = 1/2``
    (where the series converges too slowly to be of use)."""
    s = h / r
    if s >= 0.5:
        return math.inf
    terms = r * sum(_SERIES_BOUND[k] * s**k for k in range(3, SERIES_DEGREE + 1))
    tail = r * _SERIES_BOUND[SERIES_DEGREE + 1] * s ** (SERIES_DEGREE + 1) / (1.0 - s)
    return tail + SERIES_ROUNDINGS * _EPS32 * terms


def model_tolerance(interp: str, upsample: float) -> float:
    """The range model's tolerance for profiles interpolated by ``interp`` at ``upsample``:
    :data:`MODEL_SHARE` of the interpolation's own RMS error (far below it: it adds 5e-5 of it in
    quadrature), and never tighter than :data:`MODEL_TOLERANCE`. A coarse interpolator is not
    held to an accuracy its images cannot show (linear at 4x errs 2.5e-2: its tiles are priced
    for 2.5e-4); the default's (Lagrange at 12x, 2.6e-5) is 1e-5."""
    from ..ffbp.model import interp_error

    return max(MODEL_TOLERANCE, MODEL_SHARE * interp_error(interp, float(upsample)))


def tile_cost(model: str, width: int) -> float:
    """Predicted work per pixel-pulse of tiles of ``width`` pixels in ``model``, relative to full
    tiles of the quadratic model's lane groups (each tile runs whole groups of 16 lanes
    and computes one float64 anchor per pulse). A bistatic series costs its lanes what a
    monostatic one does: its coefficients are the mean of the two ends'."""
    groups = math.ceil(width / _LANES)
    return (groups * _GROUP_COST[model] + _ANCHOR_COST[model]) / (width / _LANES)


def tiling(grid, r_min: float, kc_max: float, inv_bin_max: float, *,
           c_max: float = 1.0, tolerance: float = MODEL_TOLERANCE) -> Tiling:
    """The cheapest tiling (:func:`tile_cost`) whose range model stays within ``tolerance``
    (:data:`MODEL_TOLERANCE`; :func:`model_tolerance` for an interpolator)
    in carrier phase (``kc_max`` rad/m) and profile bins (``inv_bin_max`` bins/m), for pixels at least
    ``r_min`` from every antenna that see it at direction cosines along the rows of at most
    ``c_max`` (:func:`row_cosine`)."""
    scale = max(abs(kc_max), abs(inv_bin_max), 1e-30)
    r = max(r_min, 1e-9)
    best = None
    # a tile wider than the row is the row: price the tiles the kernel would run
    widths = sorted({min(w, max(int(grid.nx), 1)) for w in _WIDTHS}, reverse=True)
    for model, error in ((QUADRATIC, functools.partial(quadratic_error, c_max=c_max)), (SERIES, series_error)):
        for w in widths:
            e = error(0.5 * (w - 1) * abs(grid.dx), r) * scale
            if e <= tolerance or w == 1:
                cand = Tiling(model, w, e, tile_cost(model, w))
                if best is None or cand.cost < best.cost:
                    best = cand
                break
    return best


def tile_width(grid, r_min: float, kc_max: float, inv_bin_max: float, c_max: float = 1.0) -> int:
    """Widest tile of the quadratic model (pixels along a row, at most 128) within tolerance:
    ``kc · error`` and ``error / bin`` below :data:`MODEL_TOLERANCE` (:func:`quadratic_error`)."""
    scale = max(abs(kc_max), abs(inv_bin_max), 1e-30)
    r = max(r_min, 1e-9)
    for w in _WIDTHS:
        if quadratic_error(0.5 * (w - 1) * abs(grid.dx), r, c_max) * scale <= MODEL_TOLERANCE:
            return w
    return 1
