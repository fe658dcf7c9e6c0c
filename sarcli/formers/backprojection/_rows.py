"""The kernels' rows: which image axis they follow, and how many pulses' profiles a pass over the
image works through (:class:`._setup.Setup` uses both).

Orientation
-----------
The kernels run along rows: a tile is up to 128 consecutive pixels of a row sharing one range
model, and its 16-lane groups read each a 4-tap stencil of the pulse's profile. The range is
symmetric in swapping x and y of the pixels and of the antennas, so the kernels may equally run
on the transposed problem (grid axes and antenna x, y swapped: kernel rows are image columns)
and hand back the transpose. :func:`orient` picks, per call, the orientation of least predicted
cost per pixel-pulse:

- the tiling's (:func:`._kernels.tile_cost` of the tiling :func:`._kernels.tiling` picks for that
  row's pixel spacing, over a row's whole and last, partial tiles: :func:`row_cost`): the arithmetic;
- plus :data:`LINE_COST` for each cache line of profile a lane group's 16 stencils span,
  ``16 |∂Δr/∂u| Δu / bin`` bins (:func:`group_lines`; ``u`` the row's axis, ``mean_p |∂Δr_p/∂u|``
  at the grid's centre, the antennas' direction cosine along it: :func:`row_steps`).

With square pixels and rows of whole tiles either way (the usual case) the tilings cost the same
and the lines decide: rows across the look direction, whose groups read a line or two, rather than
along it (GOTCHA at 0.125 m pixels, 16x profiles: 12 lines). A tiling cheaper by more than the
lines keeps its rows (pixels much finer along one axis near the radar). The terms add because
all are time per pixel-pulse in the same unit, a quadratic lane group's work: the tiling's is
what the planner charges (``Tiling.cost``), a line's the fit of rows along against across the look
at the same tiling (:data:`LINE_COST`); the transposed problem also pays its transposing copy,
once a call (:data:`TRANSPOSE_COST` over the pulses), so a few pulses keep the grid as it is.

The transposed problem accumulates into arrays of the kernels' shape (the image's transposed) and
the complex image is made from them by a transposing copy (:func:`copy_oriented`, by strips), the
copy the untransposed problem makes too: no image-sized array is added. :func:`~sarcli.formers.backprojection.reproject` and the
contractions take their image-shaped input through the same copy, transposed the other way.

Pulse block
-----------
Inside a kernel call the pulses go over the image in passes, and each pass adds every tile's
accumulators into the (float64) image once: the fewer passes the better, as long as what a row
reads of the pass's profiles stays in cache from one row to the next. A row reads of each profile
the bins its range spans (:func:`row_reach_bins`: the row's length times the largest direction
cosine along it), all of the profile for rows along the look direction, a few lines for rows
across it; a pass takes as many pulses as those parts fill :data:`CACHE_FRACTION` of a core's L2
cache (:func:`l2_cache_bytes`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...core.grid import Grid
from ._kernels import MODEL_TOLERANCE, Tiling, row_cosine, tile_cost, tiling

__all__ = ["Orientation", "LINE_COST", "TRANSPOSE_COST", "group_lines", "transposed_grid", "row_steps", "row_cost", "orient",
           "copy_oriented", "row_cosines", "row_reach_bins", "FALLBACK_L2_BYTES", "CACHE_FRACTION", "l2_cache_bytes"]

#: L2 cache per core assumed where neither sysfs nor ``sysconf`` tells it: the smallest of x86 cores
#: with AVX2 (Intel's client cores from Haswell to Comet Lake). A pulse block smaller than the cache
#: costs a few percent; one larger, with rows along the look direction, a third.
FALLBACK_L2_BYTES = 256 * 1024
#: Share of a core's L2 cache that the profiles of one pass over the image fill (the rest holds the
#: tiles' accumulators and the image rows). Rows along the look direction read all of each profile
#: in a pass and slow down sharply once the profiles outgrow the L2; rows across it read a few lines
#: at a time and barely notice (measured: docs/performance.md, ``bench/bench_bp_orient.py``).
CACHE_FRACTION = 0.75


def l2_cache_bytes(sysfs="/sys/devices/system/cpu/cpu0/cache", sysconf=getattr(os, "sysconf", None)) -> int:
    """Bytes of one core's L2 cache: the level-2 data or unified cache under ``sysfs`` (Linux), else
    ``sysconf("SC_LEVEL2_CACHE_SIZE")`` (glibc), else :data:`FALLBACK_L2_BYTES`."""
    try:
        for index in sorted(Path(sysfs).glob("index*")):
            if (index / "level").read_text().strip() != "2" or \
                    (index / "type").read_text().strip() not in ("Unified", "Data"):
                continue
            text = (index / "size").read_text().strip().upper()
            unit = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30}.get(text[-1:], 1)
            size = int(text.rstrip("KMG")) * unit
            if size > 0:
                return size
    except (OSError, ValueError):
        pass
    try:
        size = int(sysconf("SC_LEVEL2_CACHE_SIZE")) if sysconf is not None else 0
    except (OSError, ValueError, TypeError):
        size = 0
    return size if size > 0 else FALLBACK_L2_BYTES


class Orientation(NamedTuple):
    """The orientation of the kernels' rows (module docstring): ``transposed`` when kernel rows are
    image columns, the tiling on those rows (:class:`._kernels.Tiling`), the cache lines of profile
    a lane group's stencils span (:func:`group_lines`) and the predicted cost per pixel-pulse, the
    tiling's over a row (:func:`row_cost`) plus :data:`LINE_COST` a line."""
    transposed: bool
    tiling: Tiling
    lines: float
    cost: float
    c_max: float = 1.0   # the largest direction cosine along the rows (:func:`row_cosines`)


#: Cost of a cache line of profile that a lane group's stencils span, in the lane groups of
#: :func:`._kernels.tile_cost` (measured, ``bench/bench_bp_orient.py``, rows along against across
#: the look direction at the same tiling: 0.004 GOTCHA, 0.007 the 740 km orbit and 10 km, 0.002 and
#: 0 at 1 km and 50 m, measured with the exact departure's lanes there, heavier than the series', which
#: hide the loads).
LINE_COST = 0.005
#: Bytes of a cache line.
_LINE_BYTES = 64
#: What the transposed problem's copies add per pixel, in the same unit: a transposing copy of the
#: image's two parts against a plain one (measured: 2.7 ns a pixel beside 1.0 ns a unit of tile
#: cost, 10 km's quadratic rows, on one machine), paid once a call, not once a pulse.
TRANSPOSE_COST = 3.0


def group_lines(step: float, inv_bin: float, sample_bytes: int) -> float:
    """Cache lines of profile the 16 lanes of a group span beyond one stencil, for a range step
    ``step`` (m) a pixel along the row, ``inv_bin`` profile bins a metre and ``sample_bytes`` a
    profile sample (re and im interleaved: 8 in float32, 16 in float64)."""
    return 16.0 * abs(step * inv_bin) * sample_bytes / _LINE_BYTES


def transposed_grid(grid: Grid) -> Grid:
    """``grid`` with x and y swapped: its ``x`` is ``grid.y``, its ``y`` is ``grid.x``."""
    return Grid(grid.ny, grid.nx, grid.dy, grid.dx, grid.cy, grid.cx)


def row_steps(a, b, grid) -> tuple[float, float]:
    """Mean over pulses of ``|∂Δr/∂x| Δx`` and ``|∂Δr/∂y| Δy`` at the grid's centre, for transmit
    positions ``a`` and receive positions ``b`` [P, 3]: how far the range moves from one pixel to the
    next along a row and along a column (``Δr = (|a - x| + |b - x|)/2 - r0``)."""
    centre = np.array([0.5 * (grid.x[0] + grid.x[-1]), 0.5 * (grid.y[0] + grid.y[-1]), 0.0])
    grad = np.zeros((a.shape[0], 2))
    for pos in (a, b):
        d = centre - pos
        grad += 0.5 * d[:, :2] / np.maximum(np.linalg.norm(d, axis=1), 1e-30)[:, None]
    mean = np.mean(np.abs(grad), axis=0)
    return float(mean[0] * grid.dx), float(mean[1] * grid.dy)


def row_cosines(a, b, grid) -> tuple[float, float]:
    """Largest direction cosine along the rows and along the columns from any transmit position in
    ``a`` or receive position in ``b`` [P, 3] to the grid's rectangle (:func:`._kernels.row_cosine`
    of the grid as it is and transposed): the quadratic's cubic term, and so its tile width, is
    bounded by the one along the kernels' rows."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    tg = transposed_grid(grid)
    along = max(row_cosine(a, grid), row_cosine(b, grid))
    across = max(row_cosine(a[:, [1, 0, 2]], tg), row_cosine(b[:, [1, 0, 2]], tg))
    return along, across


def row_reach_bins(grid, c_max: float, inv_bin_max: float, taps: int) -> float:
    """Profile bins that one row of ``grid`` reads of each pulse's profile, at most: the row's length
    times the largest direction cosine along it, in bins, plus a stencil either side."""
    length = abs(grid.x[-1] - grid.x[0]) + abs(grid.dx)
    return length * c_max * inv_bin_max + 2 * taps


def row_cost(t: Tiling, n: int) -> float:
    """Predicted work per pixel-pulse (:func:`._kernels.tile_cost`) of a row of ``n`` pixels cut into
    tiles of ``t.width`` from its start, the last one what is left."""
    full, rest = divmod(int(n), t.width)
    work = full * t.width * tile_cost(t.model, t.width)
    if rest:
        work += rest * tile_cost(t.model, rest)
    return work / n


def orient(grid, r_min: float, kc_max: float, inv_bin_max: float, steps, n_pulses: int, *,
           sample_bytes: int = 8, cosines=(1.0, 1.0),
           tolerance: float = MODEL_TOLERANCE) -> Orientation:
    """The orientation of the kernels' rows (module docstring): of the grid as it is and transposed,
    the one of least predicted cost per pixel-pulse, the tiling's over a row (:func:`._kernels.tiling`
    on that row's spacing, :func:`row_cost`) plus :data:`LINE_COST` for each cache line a lane group
    spans (:func:`group_lines` of ``steps``, :func:`row_steps`), plus, transposed,
    :data:`TRANSPOSE_COST` shared by the ``n_pulses``; the grid as it is on a tie. ``cosines``: the
    largest direction cosines along the rows and the columns (:func:`row_cosines`; the tiling's
    bound takes the one along its rows); ``tolerance``: the range model's
    (:func:`._kernels.model_tolerance`)."""
    best = None
    for transposed, g, step, c in ((False, grid, steps[0], cosines[0]), (True, transposed_grid(grid), steps[1], cosines[1])):
        t = tiling(g, r_min, kc_max, inv_bin_max, c_max=c, tolerance=tolerance)
        lines = group_lines(step, inv_bin_max, sample_bytes)
        cost = row_cost(t, g.nx) + LINE_COST * lines + (TRANSPOSE_COST / max(int(n_pulses), 1) if transposed else 0.0)
        cand = Orientation(transposed, t, lines, cost, c)
        if best is None or cand.cost < best.cost:
            best = cand
    return best


#: Rows of the source a transposing copy takes at a time: the strip of columns it writes stays in
#: cache (one strided copy of the whole array misses it on every write).
_STRIP = 64


def copy_oriented(dst, src, transposed):
    """``dst[...] = src.T`` if ``transposed`` (by strips of rows), else ``dst[...] = src``."""
    if not transposed:
        np.copyto(dst, src)
        return
    for i in range(0, src.shape[0], _STRIP):
        np.copyto(dst[:, i:i + _STRIP], src[i:i + _STRIP].T)
