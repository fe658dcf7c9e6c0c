"""Stage 0 of fast factorised backprojection (:mod:`sarcli.formers.ffbp`): the pulses of each base
sub-aperture backprojected onto its polar grid (:func:`stage0`, compiled in ``src/native/ffbp.cpp``),
with ranges from a short series about the sub-aperture centre where its truncation allows (the
series' inputs and where it holds from :func:`series_inputs`); and the deapodized kernels' mean
responses at each pulse's tones, divided out of the data (:func:`tone_weights`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..._native.layout import FfbpPulse
from ._kernels import full_rows, native, table

#: Largest phase (radians) the truncated range series of stage 0 may cost (:func:`series_inputs`).
SERIES_PHASE = 1e-7
#: Whether stage 0 forms a row's 6-tap weights in a pass of their own before the sums (True), or
#: inside the sums' blocks (False); None: as suits the CPU's copy of the kernel (a pass on AVX2 and
#: baseline CPUs, in the blocks on AVX-512 ones: ``stage0_weights_first`` in src/native/ffbp.cpp).
#: The same image bit for bit either way; set for tests.
WEIGHTS_FIRST = None


def _binomial_half(n):
    """``C_k = binom(1/2, k)``, k = 1 .. n: the coefficients of ``√(1 + ε) − 1 = Σ_k C_k ε^k``
    (exact binary fractions; ``|C_k|`` falls with k)."""
    c, out = 1.0, []
    for k in range(1, n + 1):
        c *= (1.5 - k) / k
        out.append(c)
    return tuple(out)


#: The eight terms stage 0 sums (``sqrt_series`` in ``src/native/ffbp.cpp``), and ``|C_9|``, which
#: bounds the tail it leaves.
SQRT_SERIES = _binomial_half(8)
SQRT_TAIL = abs(_binomial_half(9)[8])


class Stage0Settings(NamedTuple):
    """Stage 0's scalars: the profiles' interpolator code, whether the pulses are bistatic, the
    profile's half length and length ``L // 2``, ``L``, its padding on each side, the polar grids'
    range spacing and the demodulation's reference wavenumber."""

    kind: int
    bistatic: bool
    half_len: float
    n_len: float
    pad: int
    dq: float
    kref: float


def stage0(profiles, groups, pulses, series, frame, tab, settings: Stage0Settings, out, rows=None):
    """Backproject the pulses ``first[s] .. first[s]+count[s]-1`` onto sub-aperture s's polar grid
    (the nodes of ``rows``; the others set to zero).

    Profile interpolation as in backprojection; the profiles, weights, gather and sums are float32
    (the sub-images are stored in float32), positions and carriers float64.

    Where ``series[s]`` is set, the range of a pulse at ``t = c + Δ`` to the node ``x`` comes from
    the node's own range ``R = |c − x| = |c| + q`` (exact on the polar grid) and a short series:
    ``|t − x| = R √(1 + ε)``, ``ε = (2 (c − x)·Δ + |Δ|²) / R²`` (:data:`SQRT_SERIES`; the caller
    sets ``series[s]`` only where the truncated tail is below :data:`SERIES_PHASE`). That trades
    a square root and a division per node and pulse for eight fused multiply-adds.

    Parameters
    ----------
    profiles : (ndarray, ndarray), each shape (B, L + 2·pad), float32
        Range profiles of the block's pulses, real and imaginary parts
        (:func:`sarcli.formers.backprojection.range_profiles`).
    groups : (array_like of int, array_like of int), each shape (S,)
        ``(first, count)``: each sub-aperture's pulses, indices into the block.
    pulses : ndarray, shape (20, B)
        :func:`pulse_table`.
    series : ndarray of bool, shape (S,)
    frame : ndarray, shape (10, S)
        :func:`sarcli.formers.ffbp._kernels.frame` of the sub-apertures.
    tab : ndarray, shape (6, 8)
        The profiles' weight polynomials (kind 3).
    settings : Stage0Settings
    out : (ndarray, ndarray), each shape (S, n_u, n_q), float32
        The sub-images, real and imaginary parts (written).
    rows : ndarray of int64, shape (S, n_u, 2), optional
        The nodes ``start .. stop-1`` of each row to form
        (:meth:`sarcli.formers.ffbp._grids._Level.row_table`); None: every node.
    """
    (pre, pim), (first, count), (out_re, out_im), st = profiles, groups, out, settings
    rows = full_rows(out_re.shape) if rows is None else np.ascontiguousarray(rows, np.int64)
    opts = native().Stage0Options(kind=int(st.kind), bistatic=bool(st.bistatic), half_len=float(st.half_len),
                                  n_len=float(st.n_len), pad=int(st.pad), dq=float(st.dq), kref=float(st.kref))
    if WEIGHTS_FIRST is not None:
        opts.weights_first = int(bool(WEIGHTS_FIRST))
    native().stage0(pre, pim, np.ascontiguousarray(first, np.int64), np.ascontiguousarray(count, np.int64), pulses,
                    np.ascontiguousarray(series, np.bool_), frame, rows, table(tab), opts, out_re, out_im)


def pulse_table(geo, dlt, inv_bin, kc):
    """Stage 0's per-pulse rows, float64 ``[20, B]`` (:class:`sarcli._native.layout.FfbpPulse`):
    :func:`pulse_geometry` (exact ranges), :func:`series_inputs`' rows (the series), the inverse
    profile bin and the carrier wavenumber."""
    t = np.empty((len(FfbpPulse), geo.shape[1]))
    t[FfbpPulse.TX:FfbpPulse.OFFSET + 1] = geo
    t[FfbpPulse.DTX:FfbpPulse.CENTRE_OFFSET + 1] = dlt
    t[FfbpPulse.INV_BIN], t[FfbpPulse.KC] = inv_bin, kc
    return t


def series_inputs(t, rcv, r0, lev, dq, kmax):
    """Per-pulse rows of stage 0's range series (:func:`stage0`: Δ = position − centre
    and |Δ|² for transmit and receive, ``|c| − r0``) and, per sub-aperture, whether the series'
    truncated tail stays below :data:`SERIES_PHASE` radians of phase at every node of its grid.

    With ``e = 2|Δ|/R + |Δ|²/R²`` (largest |Δ|, nearest node ``R = |c| + q``) the tail beyond the
    eighth term is at most ``R_far |C_9| e⁹ / (1 − e)`` metres; a sub-aperture whose bound exceeds
    ``SERIES_PHASE / k_max`` (or whose ``e`` reaches 1/2: near field, long sub-apertures, wide
    bistatic baselines), or whose sum ``~R e/2`` would round by more than that (the virtual
    antennas of far-field data, ~1e9 m away), keeps the exact square root.
    """
    sub = np.repeat(np.arange(lev.n), lev.count)
    cen = np.stack([lev.geo[0], lev.geo[1], lev.geo[6]], axis=1)[sub]
    dt, dr = t - cen, rcv - cen
    dlt = np.empty((9, t.shape[0]))
    dlt[0:3], dlt[3] = dt.T, np.sum(dt * dt, axis=1)
    dlt[4:7], dlt[7] = dr.T, np.sum(dr * dr, axis=1)
    dlt[8] = lev.geo[2][sub] - r0
    reach = np.sqrt(np.maximum(dlt[3], dlt[7]))
    dmax = np.zeros(lev.n)
    np.maximum.at(dmax, sub, reach)
    r_near = np.maximum(lev.geo[2] + lev.q0, 1e-300)
    r_far = lev.geo[2] + lev.q0 + (lev.n_q - 1) * dq
    e = 2.0 * dmax / r_near + (dmax / r_near) ** 2
    tail = r_far * SQRT_TAIL * np.minimum(e, 0.5) ** 9 / (1.0 - np.minimum(e, 0.5))
    # the series' sum, ~R e/2 metres, rounds at a few ulps of itself: far-field data's virtual
    # antennas (R ~ 1e9 m) would lose ~1e-5 rad there, where the exact form loses nothing
    rounding = 8.0 * np.finfo(np.float64).eps * r_far * e
    series = (e < 0.5) & (tail + rounding <= SERIES_PHASE / kmax)
    return np.ascontiguousarray(dlt), series


def pulse_geometry(t, rcv, r0):
    """Rows tx, ty, |t|², |t|, rx, ry, |r|², |r|, offset of the per-pulse range (stage 0's exact
    range; ``t`` transmit, ``rcv`` (r) receive positions)."""
    norm_t = np.sqrt(np.sum(t.astype(np.longdouble) ** 2, axis=1))
    norm_r = np.sqrt(np.sum(rcv.astype(np.longdouble) ** 2, axis=1))
    off = (0.5 * (norm_t + norm_r) - r0.astype(np.longdouble)).astype(np.float64)
    norm_t, norm_r = norm_t.astype(np.float64), norm_r.astype(np.float64)
    return np.ascontiguousarray(np.stack([t[:, 0], t[:, 1], norm_t * norm_t, norm_t, rcv[:, 0], rcv[:, 1],
                                          norm_r * norm_r, norm_r, off]))


def tone_weights(k, a, b, inv_h, inv_psi, out):
    """``out[p, j] *= Π_l 1/Ψ(k_j a[l, p] + b)``: a deapodized kernel's mean response at each
    pulse's tone on every level it passes (:func:`sarcli.formers.ffbp._grids.decide_deapodization`),
    divided out of the data in place.

    Parameters
    ----------
    k : ndarray, shape (1 or P, M)
        Wavenumbers.
    a : ndarray, shape (levels, P)
    b : float
    inv_h : float
        Samples of ``inv_psi`` per cycle.
    inv_psi : ndarray
        ``1/Ψ`` at ``ν = i/inv_h`` (:func:`sarcli.formers.ffbp.model.deapodized_inverse`; Ψ is
        even), linearly interpolated.
    out : ndarray, shape (P, M), float64, C-contiguous
    """
    native().tone_weights(np.ascontiguousarray(k, np.float64), np.ascontiguousarray(a, np.float64), float(b),
                          float(inv_h), np.ascontiguousarray(inv_psi, np.float64), out)
