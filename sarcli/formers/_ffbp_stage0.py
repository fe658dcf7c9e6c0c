"""Stage 0 of fast factorised backprojection (:mod:`sarcli.formers.ffbp`): the pulses of each base
sub-aperture backprojected onto its polar grid, with ranges from a short series about the
sub-aperture centre where its truncation allows (:func:`_stage0`; the series' inputs and where it
holds from :func:`_series_inputs`). The polar-grid helpers it shares with the merges live in
:mod:`sarcli.formers._ffbp_kernels`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ._bp_kernels import _FM, _U1, _U2, _U3, _U4, _U5, _sincos
from ._ffbp_kernels import NTAPS, _node, _pulse_range, _row_weights, _taps_acc

#: Largest phase (radians) the truncated range series of stage 0 may cost (:func:`_series_inputs`).
SERIES_PHASE = 1e-7


def _binomial_half(n):
    """``C_k = binom(1/2, k)``, k = 1 .. n: the coefficients of ``√(1 + ε) − 1 = Σ_k C_k ε^k``
    (exact binary fractions; ``|C_k|`` falls with k)."""
    c, out = 1.0, []
    for k in range(1, n + 1):
        c *= (1.5 - k) / k
        out.append(c)
    return tuple(out)


#: The eight terms :func:`_series` sums, and ``|C_9|``, which bounds the tail it leaves.
SQRT_SERIES = _binomial_half(8)
SQRT_TAIL = abs(_binomial_half(9)[8])


@njit(inline="always")
def _series(e, c):
    """``√(1 + e) − 1`` by the series :data:`SQRT_SERIES` (``c``), eight terms by Horner."""
    return e * (c[0] + e * (c[1] + e * (c[2] + e * (c[3] + e * (c[4] + e * (c[5] + e * (c[6] + e * c[7])))))))


@njit(inline="always")
def _gather_run(rp, ip, w, cr, ci, acc_re, acc_im, i0, e, off):
    """The 6-tap profile gather of stage 0 for nodes ``i0 .. e-1`` whose stencils start at bin
    ``node + off``: contiguous loads (the sum ``node + off`` modulo 2**64 is the non-negative bin)."""
    uoff = np.uint64(off)
    for k in range(np.uint64(i0), np.uint64(e)):
        _tap6_acc(rp, ip, w, cr, ci, acc_re, acc_im, k, k + uoff)


@njit(inline="always")
def _tap6_acc(rp, ip, w, cr, ci, acc_re, acc_im, k, i):
    """``acc[k] += (cr + i·ci)[k] · Σ_b w[b, k] · profile[i + b]``: one node's 6-tap profile read
    (``i`` unsigned: no negative-index wrap-around tests)."""
    vr = (w[0, k] * rp[i] + w[1, k] * rp[i + _U1] + w[2, k] * rp[i + _U2]
          + w[3, k] * rp[i + _U3] + w[4, k] * rp[i + _U4] + w[5, k] * rp[i + _U5])
    vi = (w[0, k] * ip[i] + w[1, k] * ip[i + _U1] + w[2, k] * ip[i + _U2]
          + w[3, k] * ip[i + _U3] + w[4, k] * ip[i + _U4] + w[5, k] * ip[i + _U5])
    acc_re[k] += vr * cr[k] - vi * ci[k]
    acc_im[k] += vr * ci[k] + vi * cr[k]


@njit(parallel=True, cache=True, fastmath=_FM)
def _stage0(pre, pim, first, count, geo, dlt, series, bistatic, inv_bin, kc, half_len, n_len, pad, kind, tab,
            cgeo, q0, dq, t0, dtau, kref, out_re, out_im):
    """Backproject the pulses ``first[s] .. first[s]+count[s]-1`` onto sub-aperture s's polar grid.

    ``cgeo`` rows: cx, cy, |c|, ρ0, e0x, e0y, cz. Profile interpolation as in backprojection, in
    the same three passes (positions and carriers, weights, gather); the profiles, weights, gather
    and sums are float32 (the sub-images are stored in float32), positions and carriers float64.

    Where ``series[s]`` is set, the range of a pulse at ``t = c + Δ`` to the node ``x`` comes from
    the node's own range ``R = |c − x| = |c| + q`` (exact on the polar grid) and a short series:
    ``|t − x| = R √(1 + ε)``, ``ε = (2 (c − x)·Δ + |Δ|²) / R²`` (:func:`_series`; the caller sets
    ``series[s]`` only where the truncated tail is below a micro-radian of phase). That trades the
    square root and division of :func:`_pulse_range` for eight fused multiply-adds. ``dlt`` rows
    per pulse: Δ and |Δ|² of the transmit position (0-3) and of the receive position (4-7), and
    ``|c| − r0`` (8).
    """
    n_sub, nt, nq = out_re.shape
    top = n_len - 1.0
    ntap = NTAPS[kind]
    lo = -(ntap // 2 - 1)
    off = float(pad + lo)
    for job in prange(n_sub * nt):
        s = job // nt
        it = job - s * nt
        tau = t0[s] + it * dtau[s]
        xs = np.empty(nq)
        ys = np.empty(nq)
        ax = np.empty(nq)
        ay = np.empty(nq)
        az = np.empty(nq)
        ir2 = np.empty(nq)
        rr = np.empty(nq)
        qq = np.empty(nq)
        dr = np.empty(nq)
        idx = np.empty(nq, np.int32)
        frac = np.empty(nq, np.float32)
        cr = np.empty(nq, np.float32)
        ci = np.empty(nq, np.float32)
        w = np.empty((ntap, nq), np.float32)
        acc_re = np.zeros(nq, np.float32)
        acc_im = np.zeros(nq, np.float32)
        qa = q0[s]
        c0, c1, c2, c3, c4, c5, c6 = cgeo[0, s], cgeo[1, s], cgeo[2, s], cgeo[3, s], cgeo[4, s], cgeo[5, s], cgeo[6, s]
        for iq in range(nq):   # the node, its range from the centre and the series' factors
            q = qa + iq * dq
            x, y = _node(q, tau, c2, c3, c4, c5)
            r = c2 + q
            i2 = 1.0 / (r * r)
            xs[iq] = x
            ys[iq] = y
            ax[iq] = 2.0 * (c0 - x) * i2
            ay[iq] = 2.0 * (c1 - y) * i2
            az[iq] = 2.0 * c6 * i2
            ir2[iq] = i2
            rr[iq] = r
            qq[iq] = q
        use_series = series[s]
        for p in range(first[s], first[s] + count[s]):
            rp = pre[p]
            ip = pim[p]
            ib = inv_bin[p]
            kcp = kc[p]
            if use_series:
                tx, ty, tz, t2, offp = dlt[0, p], dlt[1, p], dlt[2, p], dlt[3, p], dlt[8, p]
                if bistatic:
                    bx, by, bz, b2 = dlt[4, p], dlt[5, p], dlt[6, p], dlt[7, p]
                    for iq in range(nq):
                        et = ax[iq] * tx + ay[iq] * ty + az[iq] * tz + t2 * ir2[iq]
                        eb = ax[iq] * bx + ay[iq] * by + az[iq] * bz + b2 * ir2[iq]
                        dr[iq] = qq[iq] + 0.5 * rr[iq] * (_series(et, SQRT_SERIES) + _series(eb, SQRT_SERIES)) + offp
                else:
                    for iq in range(nq):
                        e = ax[iq] * tx + ay[iq] * ty + az[iq] * tz + t2 * ir2[iq]
                        dr[iq] = qq[iq] + rr[iq] * _series(e, SQRT_SERIES) + offp
            else:
                g = (geo[0, p], geo[1, p], geo[2, p], geo[3, p], geo[4, p], geo[5, p], geo[6, p], geo[7, p],
                     geo[8, p])
                for iq in range(nq):
                    dr[iq] = _pulse_range(xs[iq], ys[iq], g, bistatic)
            for iq in range(nq):
                d = dr[iq]
                pos = d * ib + half_len
                inside = (pos >= 0.0) & (pos < n_len)
                pos = min(max(pos, 0.0), top)
                fl = math.floor(pos)
                idx[iq] = np.int32(fl + off)   # a vector conversion to int32 (see _locate)
                frac[iq] = np.float32(pos - fl)
                c, sn = _sincos(kcp * d)
                m = 1.0 if inside else 0.0
                cr[iq] = np.float32(m * c)
                ci[iq] = np.float32(m * sn)
            _row_weights(kind, frac, w, tab)
            if ntap == 6:
                # where a node's profile stencil starts as many bins after the previous node's as
                # it is nodes after it (node spacing ≈ one bin: the default upsample = os_range),
                # runs of nodes read contiguous bins: vector loads instead of gathers
                n_runs = 1
                for iq in range(1, nq):
                    n_runs += idx[iq] - idx[iq - 1] != 1
                if n_runs * 8 <= nq:
                    i0 = 0
                    while i0 < nq:
                        shift = idx[i0] - i0
                        e = i0 + 1
                        while e < nq and idx[e] - e == shift:
                            e += 1
                        _gather_run(rp, ip, w, cr, ci, acc_re, acc_im, i0, e, shift)
                        i0 = e
                    continue
                for iq in range(nq):   # gathers
                    _tap6_acc(rp, ip, w, cr, ci, acc_re, acc_im, iq, np.uint64(idx[iq]))
                continue
            _taps_acc(rp, ip, idx, 0, w, ntap, cr, ci, acc_re, acc_im)
        for iq in range(nq):
            c, sn = _sincos(-kref * (q0[s] + iq * dq))
            ar = np.float64(acc_re[iq])
            ai = np.float64(acc_im[iq])
            out_re[s, it, iq] = ar * c - ai * sn
            out_im[s, it, iq] = ar * sn + ai * c


def _series_inputs(t, q, r0, lev, dq, kmax):
    """Per-pulse rows of stage 0's range series (:func:`_stage0`: Δ = position − centre
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
    dt, dr = t - cen, q - cen
    dlt = np.empty((9, t.shape[0]))
    dlt[0:3], dlt[3] = dt.T, np.sum(dt * dt, axis=1)
    dlt[4:7], dlt[7] = dr.T, np.sum(dr * dr, axis=1)
    dlt[8] = lev.geo[2][sub] - r0
    reach = np.sqrt(np.maximum(dlt[3], dlt[7]))
    dmax = np.zeros(lev.n)
    np.maximum.at(dmax, sub, reach)
    r_near = np.maximum(lev.geo[2] + lev.q0, 1e-300)
    r_far = lev.geo[2] + lev.q0 + (lev.nq - 1) * dq
    e = 2.0 * dmax / r_near + (dmax / r_near) ** 2
    tail = r_far * SQRT_TAIL * np.minimum(e, 0.5) ** 9 / (1.0 - np.minimum(e, 0.5))
    # the series' sum, ~R e/2 metres, rounds at a few ulps of itself: far-field data's virtual
    # antennas (R ~ 1e9 m) would lose ~1e-5 rad there, where the exact form loses nothing
    rounding = 8.0 * np.finfo(np.float64).eps * r_far * e
    series = (e < 0.5) & (tail + rounding <= SERIES_PHASE / kmax)
    return np.ascontiguousarray(dlt), series


def _pulse_geometry(t, q, r0):
    """Rows tx, ty, |t|², |t|, qx, qy, |q|², |q|, offset of the per-pulse range (kernel ``_pulse_range``)."""
    nt = np.sqrt(np.sum(t.astype(np.longdouble) ** 2, axis=1))
    nq = np.sqrt(np.sum(q.astype(np.longdouble) ** 2, axis=1))
    off = (0.5 * (nt + nq) - r0.astype(np.longdouble)).astype(np.float64)
    nt, nq = nt.astype(np.float64), nq.astype(np.float64)
    return np.ascontiguousarray(np.stack([t[:, 0], t[:, 1], nt * nt, nt, q[:, 0], q[:, 1], nq * nq, nq, off]))


@njit(parallel=True, cache=True)
def _tone_weights(k, a, b, inv_h, inv_psi, out):
    """``out[p, j] *= Π_l 1/Ψ(k_j a[l, p] + b)``: a deapodized kernel's mean response at each
    pulse's tone on every level it passes (:func:`sarcli.formers._ffbp_grids.decide_deapodization`),
    divided out of the data. ``k``: wavenumbers [1 or P, M]; ``inv_psi``: 1/Ψ at ``ν = i/inv_h``
    (:func:`sarcli.formers.ffbp_model.deapodized_inverse`; Ψ is even), linearly interpolated."""
    n_p, m = out.shape
    top = inv_psi.size - 2
    per_pulse = 1 if k.shape[0] > 1 else 0
    for p in prange(n_p):
        kp = k[p * per_pulse]
        for j in range(m):
            acc = 1.0
            for l in range(a.shape[0]):
                x = abs(kp[j] * a[l, p] + b) * inv_h
                i = min(int(x), top)
                fr = x - i
                acc *= inv_psi[i] + fr * (inv_psi[i + 1] - inv_psi[i])
            out[p, j] *= acc
