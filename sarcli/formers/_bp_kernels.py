"""Backprojection's compiled kernels (``src/native/backprojection.cpp``) and their planning.

The kernels cut the image into tiles of up to 64 pixels along a row (groups of 16 lanes). Per tile and pulse they
evaluate, in float64, the differential range at the tile's centre ``Δr_c`` and its derivatives
along the row; inside the tile a pixel at offset ``u`` from the centre takes

.. math::

    \\Delta r(u) = \\Delta r_c + d_1 u + d_2 u^2, \\qquad
    d_2 = \\frac{1 - c^2}{2R}, \\quad d_1 = c + \\tfrac34 h^2 d_3, \\quad
    d_3 = -\\frac{c (1 - c^2)}{2R^2},

(``R`` the range to the centre, ``c`` the direction cosine along the row, ``h`` the tile's half
width; the ``3/4 h² d3`` term is the Chebyshev economisation of the cubic Taylor term), so the
model leaves at most ``|d3| h³ / 4`` plus the quartic term. :func:`tile_width` picks the widest
tile that keeps this below :data:`MODEL_TOLERANCE` in both carrier phase and profile bins. The
profile position is float32 relative to an integer bin of the centre, the carrier phase float64
reduced to [-π, π] and evaluated by a float32 minimax polynomial; the interpolation weights and
the carrier are thus float32 (errors ~1e-7), the profiles and accumulation follow ``precision``.
"""

from __future__ import annotations

import numpy as np

from .._native import load

__all__ = ["GEO_ROWS", "MODEL_TOLERANCE", "next_fast_len", "tile_width", "kernels"]

#: Rows of the per-pulse geometry table the kernels read: 2a_x, 2a_y, |a|², |a|, 2b_x, 2b_y, |b|²,
#: |b| (transmit a, receive b), (|a| + |b|)/2 - r0, 1/bin and the carrier wavenumber kc.
GEO_ROWS = 11
#: Largest model error of a tile, in radians of carrier phase and in profile bins.
MODEL_TOLERANCE = 1e-5
_WIDTHS = (64, 48, 32, 16, 12, 8, 4, 2, 1)



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


def min_range(pos, grid) -> float:
    """Smallest distance from any antenna position in ``pos`` [P, 3] to the grid's rectangle (z = 0)."""
    x0, x1 = grid.x[0] - grid.dx / 2, grid.x[-1] + grid.dx / 2
    y0, y1 = grid.y[0] - grid.dy / 2, grid.y[-1] + grid.dy / 2
    dx = np.clip(pos[:, 0], min(x0, x1), max(x0, x1)) - pos[:, 0]
    dy = np.clip(pos[:, 1], min(y0, y1), max(y0, y1)) - pos[:, 1]
    return float(np.sqrt(np.min(dx * dx + dy * dy + pos[:, 2] ** 2)))


def tile_width(grid, r_min: float, kc_max: float, inv_bin_max: float) -> int:
    """Widest tile (pixels along a row, at most 64) whose range model stays within tolerance.

    Bounds the model error by ``|d3| h³/4 + |d4| h⁴`` with ``|d3| <= 0.19245 / R²`` and
    ``|d4| <= 5 / (8 R³)`` at the smallest range ``R`` (``h`` the tile's half width) and asks
    ``kc · error`` and ``error / bin`` below :data:`MODEL_TOLERANCE`.
    """
    scale = max(abs(kc_max), abs(inv_bin_max), 1e-30)
    r = max(r_min, 1e-9)
    for w in _WIDTHS:
        h = 0.5 * (w - 1) * abs(grid.dx)
        err = 0.19245 * h**3 / (4.0 * r * r) + 0.625 * h**4 / r**3
        if err * scale <= MODEL_TOLERANCE:
            return w
    return 1
