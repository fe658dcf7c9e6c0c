"""The rows of the per-pulse and per-grid tables that cross into the compiled kernels, by name.

The kernels read float64 tables ``[rows, n]``, one column per pulse or sub-aperture; the C++ side
names the same rows in enums (``src/native/backprojection.hpp``, ``src/native/ffbp.hpp``), and each
module exports them as a dict (``GEO_ROWS``, ``POINT_ROWS``, ``FRAME_ROWS``, ``PULSE_ROWS``) that
the tests compare with these.
"""

from __future__ import annotations

from enum import IntEnum

__all__ = ["BpGeo", "BpPointGeo", "FfbpFrame", "FfbpPulse"]


class BpGeo(IntEnum):
    """Rows of backprojection's tiled kernels' geometry ``[len(BpGeo), P]`` (transmit ``a``, receive
    ``b``): ``2a_x, 2a_y, |a|², |a|, 2b_x, 2b_y, |b|², |b|``, the range offset ``(|a| + |b|)/2 - r0``,
    the inverse profile bin and the carrier wavenumber."""
    TWO_AX = 0
    TWO_AY = 1
    A2 = 2
    NA = 3
    TWO_BX = 4
    TWO_BY = 5
    B2 = 6
    NB = 7
    OFFSET = 8
    INV_BIN = 9
    KC = 10


class BpPointGeo(IntEnum):
    """Rows of backprojection's terrain kernels' geometry ``[len(BpPointGeo), P]``: ``a`` and ``b``
    (x, y, z), ``|a|, |b|``, the range offset, the inverse profile bin and the carrier wavenumber."""
    AX = 0
    AY = 1
    AZ = 2
    BX = 3
    BY = 4
    BZ = 5
    NA = 6
    NB = 7
    OFFSET = 8
    INV_BIN = 9
    KC = 10


class FfbpFrame(IntEnum):
    """Rows of ffbp's frame table ``[len(FfbpFrame), n]``, one column per polar grid: its centre
    ``c`` (``cx, cy, |c|``), the ground distance ``ρ0`` of ``c``'s nadir from the scene origin, the
    unit vector ``e0`` from that nadir towards the origin, ``cz``, and the grid's range origin,
    angular origin and angular spacing."""
    CX = 0
    CY = 1
    CN = 2
    RHO0 = 3
    E0X = 4
    E0Y = 5
    CZ = 6
    Q0 = 7
    U0 = 8
    DU = 9


class FfbpPulse(IntEnum):
    """Rows of ffbp stage 0's pulse table ``[len(FfbpPulse), P]``: the exact range's inputs
    (transmit ``t``: ``tx, ty, |t|², |t|``; receive ``r``: ``rx, ry, |r|², |r|``; the offset
    ``(|t| + |r|)/2 - r0``), the range series' (``Δt = t - c``: x, y, z, ``|Δt|²``; ``Δr = r - c``:
    x, y, z, ``|Δr|²``; ``|c| - r0``), the inverse profile bin and the carrier wavenumber."""
    TX = 0
    TY = 1
    T2 = 2
    TN = 3
    RX = 4
    RY = 5
    R2 = 6
    RN = 7
    OFFSET = 8
    DTX = 9
    DTY = 10
    DTZ = 11
    DT2 = 12
    DRX = 13
    DRY = 14
    DRZ = 15
    DR2 = 16
    CENTRE_OFFSET = 17
    INV_BIN = 18
    KC = 19
