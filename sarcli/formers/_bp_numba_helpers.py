"""numba helpers that the ffbp kernels still compile (carrier polynomial, interpolation weights).

Backprojection itself runs in C++ (``src/native/backprojection.cpp``); these helpers stay only
for :mod:`._ffbp_kernels` and :mod:`._ffbp_stage0` until those are ported, and are reached
through :mod:`._bp_kernels` under their former names.
"""

from __future__ import annotations

import math
from decimal import Decimal, localcontext

import numpy as np
from numba import njit, prange, types
from numba.extending import overload

# ---------------------------------------------------------------------------------------------
# compiled helpers
# ---------------------------------------------------------------------------------------------
def _sincos(ph):  # pragma: no cover - replaced by the overload inside compiled code
    return math.cos(ph), math.sin(ph)


# Minimax (Remez, weights h³ for sine and h² for cosine, in 50-digit arithmetic) coefficients of
#     sin h = h (1 + u S(u)),   cos h = 1 + u C(u),   u = h² in [0, (π/2)²],
# lowest order first. Largest error of the polynomial itself on |h| <= π/2:
#     float64: sine 4.9e-19, cosine 4.2e-18 (Taylor needs two more terms each for ~1e-17);
#     float32: sine 1.0e-8, cosine 5.3e-8 (below float32 rounding; Taylor to the same order: 4e-6).
_SIN64 = (-0.16666666666666666, 0.008333333333333238, -0.0001984126984122125,
          2.7557319212672704e-06, -2.5052106975152003e-08, 1.6058943303445617e-10,
          -7.64305230855962e-13, 2.721531131585704e-15)
_COS64 = (-0.49999999999999983, 0.04166666666666437, -0.0013888888888785652,
          2.480158727914903e-05, -2.755731652522882e-07, 2.0876567741089065e-09,
          -1.1463039371264495e-11, 4.610294182579396e-14)
_SIN32 = (-0.16666661057244608, 0.008333083661225673, -0.00019809918539322803,
          2.6050985599817745e-06)
_COS32 = (-0.4999993229304565, 0.041663989454597754, -0.001385592718265202,
          2.3194386451824987e-05)


def _two_pi_split(dtype, hi_bits):
    """2π = hi + mid + lo with ``hi`` short enough that ``k·hi`` is exact (Cody-Waite reduction)."""
    with localcontext() as ctx:
        ctx.prec = 60
        two_pi = Decimal("6.28318530717958647692528676655900576839433879875021164194988918")
        scale = 2 ** (hi_bits - 3)
        hi = Decimal(round(two_pi * scale)) / scale
        mid = dtype(float(two_pi - hi))
        lo = dtype(float(two_pi - hi - Decimal(float(mid))))
    return dtype(float(hi)), mid, lo


def _carrier_constants(dtype):
    """Constants of :func:`_sincos_half` in ``dtype``: ``(1/π, hi, mid, lo, S..., C...)``.

    ``hi + mid + lo`` is π (the halves of :func:`_two_pi_split`'s 2π, exactly); ``S`` and ``C``
    are the minimax coefficients above (4 each in float32, 8 in float64).
    """
    dt = np.dtype(dtype).type
    hi, mid, lo = _two_pi_split(dt, 10 if dt is np.float32 else 26)
    half = dt(0.5)
    sin_c, cos_c = (_SIN32, _COS32) if dt is np.float32 else (_SIN64, _COS64)
    return ((dt(1.0 / np.pi), hi * half, mid * half, lo * half)
            + tuple(dt(v) for v in sin_c) + tuple(dt(v) for v in cos_c))


def _sincos_half(hp, cst):  # pragma: no cover - replaced by the overload inside compiled code
    return math.cos(2.0 * hp), math.sin(2.0 * hp)


@overload(_sincos_half, inline="always")
def _ov_sincos_half(hp, cst):
    """(cos, sin) of ``2 hp`` by a vectorisable polynomial; ``cst`` from :func:`_carrier_constants`.

    Cody-Waite reduction ``h = hp - k π`` (``k = rint(hp / π)``, π split in three so ``k·hi`` is
    exact), minimax polynomials of sin and cos of ``h`` in [-π/2, π/2] (:data:`_SIN64`,
    :data:`_COS64`), then the double-angle formulas. Taking the half phase saves the halving
    (callers fold it into a per-pulse constant) and gives the same bits as halving ``2 hp``.
    The constants come as a tuple so a kernel can pass them in at run time: the compiler then
    keeps them in vector registers or on the stack as memory operands, where literal constants
    are re-broadcast from the constant pool for every vector of the loop.
    """
    if not (isinstance(hp, types.Float) and isinstance(cst, types.UniTuple)):
        return None
    if cst.count == 12:
        def poly(h2, c):
            ps = c[4] + h2 * (c[5] + h2 * (c[6] + h2 * c[7]))
            pc = c[8] + h2 * (c[9] + h2 * (c[10] + h2 * c[11]))
            return ps, pc
    elif cst.count == 20:
        def poly(h2, c):
            ps = c[4] + h2 * (c[5] + h2 * (c[6] + h2 * (c[7] + h2 * (c[8] + h2 * (c[9] + h2 * (
                c[10] + h2 * c[11]))))))
            pc = c[12] + h2 * (c[13] + h2 * (c[14] + h2 * (c[15] + h2 * (c[16] + h2 * (c[17] + h2 * (
                c[18] + h2 * c[19]))))))
            return ps, pc
    else:
        return None
    poly = njit(inline="always")(poly)
    dt = np.float32 if hp.bitwidth == 32 else np.float64
    one, two = dt(1.0), dt(2.0)

    def impl(hp, cst):
        k = np.rint(hp * cst[0])
        h = ((hp - k * cst[1]) - k * cst[2]) - k * cst[3]   # in [-π/2, π/2]
        h2 = h * h
        ps, pc = poly(h2, cst)
        sh = h * (one + h2 * ps)
        ch = one + h2 * pc
        return ch * ch - sh * sh, two * sh * ch

    return impl


@overload(_sincos, inline="always")
def _ov_sincos(ph):
    """(cos, sin) by a vectorisable polynomial: :func:`_sincos_half` of ``ph / 2``.

    Cody-Waite reduction ``r = ph - k 2π`` (``k = rint(ph / 2π)``, 2π split in three so ``k·hi``
    is exact), minimax polynomials of sin and cos of the half angle ``h = r/2`` in [-π/2, π/2]
    (:data:`_SIN64`, :data:`_COS64`), then the double-angle formulas. float32: error ~1e-6 rad
    for |ph| < 1e5 (the float32 phase itself is rounded by up to 4e-3 rad there); float64: error
    ~7e-16 (mostly the final roundings) plus the reduction's ~1e-15·|k|.
    """
    if not isinstance(ph, types.Float):
        return None
    dt = np.float32 if ph.bitwidth == 32 else np.float64
    cst = _carrier_constants(dt)
    half = dt(0.5)

    def impl(ph):
        return _sincos_half(ph * half, cst)

    return impl


# Constants of the interpolation kernels, float32 so they keep float32 arithmetic float32 (they
# are exact binary fractions, so the float64 path loses nothing).
_F0 = np.float32(0.0)
_F1 = np.float32(1.0)
_F2 = np.float32(2.0)
_F4 = np.float32(4.0)
_FH = np.float32(0.5)
_F15 = np.float32(1.5)
_F25 = np.float32(2.5)
# Unsigned stencil offsets: an unsigned index skips numba's negative-index wrap-around test, which
# otherwise costs a compare and a conditional move per tap and keeps the gathers scalar.
_U1 = np.uint64(1)
_U2 = np.uint64(2)
_U3 = np.uint64(3)
_U4 = np.uint64(4)
_U5 = np.uint64(5)
#: Floating-point licence of the kernels: fused multiply-adds only (no reassociation), so results
#: differ from separate rounding by at most an ulp per operation and stay deterministic.
_FM = {"contract"}


@njit(inline="always")
def _first_tap(pad, kind):
    """Offset of the first stencil tap from the unpadded profile index, as ``uint64``."""
    return np.uint64(pad - (0 if kind == 0 else (1 if kind == 1 else 2)))


@njit(inline="always")
def _pixel(xv, xxv, cy, tax, ap2, nap, offp, ib, kch, half_len, n_len, top, carrier,
           bist, cyb, tbx, bp2, nbp):
    """Per pixel and pulse: profile index, fraction, masked carrier ``m·exp(+i kc Δr)``, mask.

    ``kch`` is ``kc / 2`` and ``carrier`` the constants of :func:`_sincos_half`.

    Δr is the cancellation-free ``(|x|² - 2 a·x) / (|a - x| + |a|) + (|a| - r0)``; with separate
    transmit (a) and receive (b) positions (``bist``) the two one-way terms are averaged,
    ``((|a - x| - |a|) + (|b - x| - |b|)) / 2 + ((|a| + |b|)/2 - r0)``. The profile position is
    ``Δr / bin + L/2``; ``m`` is 1 inside the unambiguous window, else 0 (the position is then
    clamped so every access stays in bounds).
    """
    num = xxv - tax * xv + cy
    dr = num / (math.sqrt(ap2 + num) + nap)
    if bist:
        numb = xxv - tbx * xv + cyb
        dr = _FH * (dr + numb / (math.sqrt(bp2 + numb) + nbp))
    dr = dr + offp
    s = dr * ib + half_len
    inside = (s >= _F0) & (s < n_len)
    s = min(max(s, _F0), top)
    fl = np.floor(s)
    c, sn = _sincos_half(kch * dr, carrier)
    m = _F1 if inside else _F0
    return np.int32(fl), s - fl, m * c, m * sn, inside


@njit(inline="always")
def _keys(t):
    """Keys cubic (a = -1/2) weights for offsets -1, 0, 1, 2 at fraction ``t``."""
    d0 = t + _F1
    d2 = _F1 - t
    d3 = _F2 - t
    w0 = ((_F25 - _FH * d0) * d0 - _F4) * d0 + _F2
    w1 = (_F15 * t - _F25) * t * t + _F1
    w2 = (_F15 * d2 - _F25) * d2 * d2 + _F1
    w3 = ((_F25 - _FH * d3) * d3 - _F4) * d3 + _F2
    return w0, w1, w2, w3


@njit(inline="always")
def _lanczos3(d):
    """``sinc(d) sinc(d/3)`` for ``|d| < 3`` (0 beyond), float64."""
    if abs(d) < 1e-12:
        return 1.0
    if abs(d) >= 3.0:
        return 0.0
    return 3.0 * math.sin(math.pi * d) * math.sin(math.pi * d / 3.0) / (math.pi * math.pi * d * d)


@njit(inline="always")
def _lanczos(t):
    """Normalised Lanczos-3 weights for offsets -2..3 at fraction ``t`` (float64)."""
    t = np.float64(t)
    w0 = _lanczos3(t + 2.0)
    w1 = _lanczos3(t + 1.0)
    w2 = _lanczos3(t)
    w3 = _lanczos3(t - 1.0)
    w4 = _lanczos3(t - 2.0)
    w5 = _lanczos3(t - 3.0)
    tot = w0 + w1 + w2 + w3 + w4 + w5
    return w0 / tot, w1 / tot, w2 / tot, w3 / tot, w4 / tot, w5 / tot
