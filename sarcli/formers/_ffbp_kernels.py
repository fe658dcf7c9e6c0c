"""Compiled (numba) kernels of fast factorised backprojection (:mod:`sarcli.formers.ffbp`).

Three kernels, each parallel over rows of its output:

- ``_ffbp_stage0._stage0`` backprojects the range profiles of each base sub-aperture onto its
  polar grid (its own module; it uses the helpers here);
- :func:`_merge` forms each parent sub-image on its polar grid from its children's (two 1-D
  interpolations along each parent row, :func:`_separable_row`; re-referenced phase);
- :func:`_final` forms the Cartesian image from the last sub-images.

A sub-aperture's polar grid is described by its centre ``c`` (|c|, ground distance ``ρ0`` of its
nadir from the scene origin, unit vector ``e0`` from that nadir towards the origin) and the
coordinates of a ground point ``x``: the differential slant range ``q = |c - x| - |c|`` and the
direction cosine ``u = ((x - c)·e⊥)/|c - x|`` of the ray from ``c`` to ``x`` across ``e0``
(``e⊥ = ẑ × e0``). Both are taken without cancellation, so virtual antennas 10^9 m away
(far-field data) keep their accuracy. Stored sub-images are demodulated:
``F(q, u) = I(x) exp(-i k_ref q)``. (The code's ``tau``/``t`` names the angular coordinate u.)
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ._bp_kernels import _F1, _F2, _FM, _U1, _U2, _U3, _U4, _U5, _keys, _lanczos, _sincos

#: Interpolation kernels (codes 0-2 shared with backprojection; 3: a 6-tap kernel whose weights
#: are polynomials in the fraction) and their number of taps.
NTAPS = (2, 4, 6, 6)
_Z32 = np.float32(0.0)


@njit(inline="always")
def _coords(x, y, cx, cy, cn, rho0, e0x, e0y):
    """Polar coordinates ``(q, u)`` of the ground point (x, y, 0) about a sub-aperture centre."""
    num = x * x + y * y - 2.0 * (cx * x + cy * y)
    q = num / (math.sqrt(cn * cn + num) + cn)
    return q, (e0x * y - e0y * x) / (cn + q)


@njit(inline="always")
def _node(q, u, cn, rho0, e0x, e0y):
    """Ground point (x, y) of the polar node ``(q, u)``: the inverse of :func:`_coords`.

    With ``R = |c| + q`` the point lies ``uR`` across the line from the nadir to the origin and
    ``a = √(ρ0² + g − (uR)²)`` along it (``g = q(2|c| + q) = R² − |c|²``); its offset along that
    line from the origin, ``a − ρ0 = (g − (uR)²)/(a + ρ0)``, is formed without cancellation."""
    g = q * (2.0 * cn + q)
    across = u * (cn + q)
    a2 = g - across * across
    along = a2 / (math.sqrt(rho0 * rho0 + a2) + rho0)
    return along * e0x - across * e0y, along * e0y + across * e0x


@njit(inline="always")
def _one_way(x, y, ax, ay, a2, na):
    """``|a - x| - |a|`` for a ground point, cancellation-free."""
    num = x * x + y * y - 2.0 * (ax * x + ay * y)
    return num / (math.sqrt(a2 + num) + na)


@njit(inline="always")
def _pulse_range(x, y, g, bistatic):
    """Differential range of a pulse to (x, y, 0): THE per-pulse range of ffbp.

    ``g`` = (tx, ty, |t|², |t|, qx, qy, |q|², |q|, offset) of the pulse. Monostatic:
    ``|t - x| - r0``; bistatic: ``(|t - x| + |q - x|)/2 - r0`` (offset holds ``(|t|+|q|)/2 - r0``).
    """
    d = _one_way(x, y, g[0], g[1], g[2], g[3])
    if bistatic:
        d = 0.5 * (d + _one_way(x, y, g[4], g[5], g[6], g[7]))
    return d + g[8]


@njit(inline="always")
def _row_weights(kind, frac, w, tab):
    """Interpolation weights ``w[tap, i]`` for every fraction of a row (vectorisable pass).

    ``tab[tap, k]`` (kind 3) holds the coefficients of the weights as polynomials of degree 7 in
    ``2·frac − 1`` (:func:`sarcli.formers.ffbp_model.optimal_kernel`), evaluated tap by tap so
    that the loop over the row vectorises. With float32 fractions and coefficients the arithmetic
    is float32 (eight lanes a vector), else float64.
    """
    n = frac.size
    if kind == 3:
        for j in range(6):
            c0, c1, c2, c3 = tab[j, 0], tab[j, 1], tab[j, 2], tab[j, 3]
            c4, c5, c6, c7 = tab[j, 4], tab[j, 5], tab[j, 6], tab[j, 7]
            for i in range(n):
                x = _F2 * frac[i] - _F1
                w[j, i] = ((((((c7 * x + c6) * x + c5) * x + c4) * x + c3) * x + c2) * x + c1) * x + c0
    elif kind == 0:
        for i in range(n):
            w[0, i] = 1.0 - frac[i]
            w[1, i] = frac[i]
    elif kind == 1:
        for i in range(n):
            w[0, i], w[1, i], w[2, i], w[3, i] = _keys(frac[i])
    else:
        for i in range(n):
            w[0, i], w[1, i], w[2, i], w[3, i], w[4, i], w[5, i] = _lanczos(frac[i])


@njit(inline="always")
def _locate(f, lo, n, ntap):
    """Stencil start and fraction of fractional index ``f``; ``ok`` False when the stencil leaves
    ``[0, n)`` (the start is then clamped so every access stays in bounds). The start is formed
    in floating point and converted once to int32: AVX2 converts four doubles to int32 in one
    instruction but has no vector conversion to int64, which would keep the loop scalar."""
    fl = math.floor(f)
    s = fl + lo
    ok = (s >= 0.0) & (s + ntap <= n)
    s = min(max(s, 0.0), float(n - ntap))
    return np.int32(s), f - fl, ok


@njit(inline="always")
def _row_scratch(n, ntap):
    """Work arrays of :func:`_polar_row` for a row of ``n`` points: stencil starts (q, u),
    float32 weights (q, u), carrier (re, im), float32 fractions (q, u), and the 6-tap gather's
    flat index."""
    return (np.empty(n, np.int32), np.empty(n, np.int32), np.empty((ntap, n), np.float32),
            np.empty((ntap, n), np.float32), np.empty(n), np.empty(n), np.empty(n, np.float32),
            np.empty(n, np.float32), np.empty(n, np.int32))


@njit(inline="always")
def _gather6(are, aim, idx_q, idx_t, wq, wt, cr, ci, acc_re, acc_im, flat):
    """The gather of :func:`_polar_row` for 6-tap kernels.

    Literal trip counts (the compiler unrolls the 36 taps), one 32-bit flat index per node and
    float32 weights and sums (the sub-images are stored in float32; the 36-term sums round at
    ~1e-7 relative, far below any interpolation error), so the pass vectorises across nodes with
    gathers as backprojection's does.
    """
    n = idx_q.size
    nq = are.shape[1]
    fr = are.reshape(are.size)
    fi = aim.reshape(aim.size)
    for i in range(n):
        flat[i] = idx_t[i] * nq + idx_q[i]
    unq = np.uint64(nq)
    for i in range(n):
        k = np.uint64(flat[i])
        w0, w1, w2, w3, w4, w5 = wq[0, i], wq[1, i], wq[2, i], wq[3, i], wq[4, i], wq[5, i]
        vr = _Z32
        vi = _Z32
        for a in range(6):
            rr = (w0 * fr[k] + w1 * fr[k + _U1] + w2 * fr[k + _U2] + w3 * fr[k + _U3] + w4 * fr[k + _U4]
                  + w5 * fr[k + _U5])
            ri = (w0 * fi[k] + w1 * fi[k + _U1] + w2 * fi[k + _U2] + w3 * fi[k + _U3] + w4 * fi[k + _U4]
                  + w5 * fi[k + _U5])
            ta = wt[a, i]
            vr += ta * rr
            vi += ta * ri
            k += unq
        ur = np.float64(vr)
        ui = np.float64(vi)
        acc_re[i] += ur * cr[i] - ui * ci[i]
        acc_im[i] += ur * ci[i] + ui * cr[i]


@njit(inline="always")
def _polar_row(are, aim, q0, dq, t0, dtau, kref, qs, ts, qref, kind, ntap, lo, idx_q, idx_t, wq, wt,
               cr, ci, fq, ft, acc_re, acc_im, tab_q, tab_t, flat):
    """Add one sub-image, interpolated at the polar coordinates ``(qs, ts)`` of a row of points and
    re-modulated by ``exp(i k_ref (q - qref))``, to ``acc``: three passes (positions and carriers,
    weights, gather) so the first two vectorise."""
    n = qs.size
    nt, nq = are.shape
    inv_dq = 1.0 / dq
    inv_dt = 1.0 / dtau
    for i in range(n):
        sq, tq, okq = _locate((qs[i] - q0) * inv_dq, lo, nq, ntap)
        st, tt, okt = _locate((ts[i] - t0) * inv_dt, lo, nt, ntap)
        idx_q[i] = sq
        idx_t[i] = st
        fq[i] = tq
        ft[i] = tt
        c, s = _sincos(kref * (qs[i] - qref[i]))
        m = 1.0 if (okq and okt) else 0.0
        cr[i] = m * c
        ci[i] = m * s
    _row_weights(kind, fq, wq, tab_q)
    _row_weights(kind, ft, wt, tab_t)
    if ntap == 6:
        _gather6(are, aim, idx_q, idx_t, wq, wt, cr, ci, acc_re, acc_im, flat)
        return
    for i in range(n):
        sq = idx_q[i]
        st = idx_t[i]
        vr = 0.0
        vi = 0.0
        for a in range(ntap):
            rr = 0.0
            ri = 0.0
            for b in range(ntap):
                rr += wq[b, i] * are[st + a, sq + b]
                ri += wq[b, i] * aim[st + a, sq + b]
            vr += wt[a, i] * rr
            vi += wt[a, i] * ri
        acc_re[i] += vr * cr[i] - vi * ci[i]
        acc_im[i] += vr * ci[i] + vi * cr[i]


@njit(inline="always")
def _taps_acc(src_re, src_im, start, shift, w, ntap, cr, ci, acc_re, acc_im):
    """``acc[i] += (cr + i·ci)[i] · Σ_b w[b, i] · src[start[i] - shift + b]`` for every ``i`` of
    ``start``: a 1-D interpolation with any number of taps, re-modulated and accumulated (the
    general path; the 6-tap kernels have literal, unrolled loops)."""
    for i in range(start.size):
        k = start[i] - shift
        vr = 0.0
        vi = 0.0
        for b in range(ntap):
            vr += w[b, i] * src_re[k + b]
            vi += w[b, i] * src_im[k + b]
        acc_re[i] += vr * cr[i] - vi * ci[i]
        acc_im[i] += vr * ci[i] + vi * cr[i]


@njit(inline="always")
def _separable_row(are, aim, q0, dq, t0, dtau, kref, qs, ts, qref, kind, ntap, lo, idx_q, fq, wq, idx_t, ft,
                   wt, okc, gre, gim, cr, ci, acc_re, acc_im, tab_q, tab_t, extra):
    """:func:`_polar_row` in two 1-D passes, for a row of points whose child range ``qs``
    increases strictly (a parent's row of constant u seen from a child: the merge stages).

    Along the row the child coordinates trace a smooth curve ``u = T(q)``. Pass 1 interpolates
    every child column ``j`` the row's stencils touch in u, at ``T(q_j)`` (``T`` linear between the
    row's points, extrapolated past its ends: the curve bends on the scale of the range, so the
    error is ~1e-12 in u): ``g_j = F(q_j, T(q_j))``. Pass 2 interpolates ``g`` in q at each point.
    ``g`` is band-limited like F in q (the curve's slope adds ~``δ/ρ²`` times the angular band,
    a few per cent at most), so the two passes cost 2·ntap taps per point instead of ntap².
    Returns False (nothing added) when the row's stencils reach no column.

    ``extra``: work arrays (slopes of T between the row's points, float32 fractions in u and in q)
    passed as one tuple (numba cannot inline a call with more arguments). The weights are
    float32 polynomials (``tab_q``, ``tab_t`` float32), eight lanes a vector.
    """
    slope, ft32, fq32 = extra
    n = qs.size
    nt, nq = are.shape
    inv_dq = 1.0 / dq
    inv_dt = 1.0 / dtau
    for i in range(n):   # vectorisable: positions, fractions, carriers
        sq, tq, okq = _locate((qs[i] - q0) * inv_dq, lo, nq, ntap)
        idx_q[i] = sq
        fq[i] = tq
        c, s = _sincos(kref * (qs[i] - qref[i]))
        m = 1.0 if okq else 0.0
        cr[i] = m * c
        ci[i] = m * s
        okc[i] = np.float32(m)
    # columns the stencils touch (qs increases, so the first and last points in range bound them)
    i0 = 0
    while i0 < n and okc[i0] == 0.0:
        i0 += 1
    if i0 == n:
        return
    i1 = n - 1
    while okc[i1] == 0.0:
        i1 -= 1
    jlo = idx_q[i0]
    ncol = idx_q[i1] + ntap - jlo
    # T at the columns: walk the row (scalar), then locate in u (vectorisable)
    for i in range(n - 1):
        slope[i] = (ts[i + 1] - ts[i]) / (qs[i + 1] - qs[i])
    k = 0
    for jj in range(ncol):
        qj = q0 + (jlo + jj) * dq
        while k < n - 2 and qs[k + 1] <= qj:
            k += 1
        ft[jj] = ts[k] + (qj - qs[k]) * slope[k]
    for jj in range(ncol):
        st, tt, okt = _locate((ft[jj] - t0) * inv_dt, lo, nt, ntap)
        idx_t[jj] = st
        ft32[jj] = np.float32(tt)
        okc[jj] = np.float32(1.0) if okt else _Z32
    _row_weights(kind, ft32[:ncol], wt, tab_t)
    fr = are.reshape(are.size)
    fi = aim.reshape(aim.size)
    if ntap == 6:   # runs of columns reading the same six child rows: contiguous loads
        j0 = 0
        while j0 < ncol:
            st = idx_t[j0]
            j1 = j0 + 1
            while j1 < ncol and idx_t[j1] == st:
                j1 += 1
            r0 = are[st, jlo:]
            r1 = are[st + 1, jlo:]
            r2 = are[st + 2, jlo:]
            r3 = are[st + 3, jlo:]
            r4 = are[st + 4, jlo:]
            r5 = are[st + 5, jlo:]
            m0 = aim[st, jlo:]
            m1 = aim[st + 1, jlo:]
            m2 = aim[st + 2, jlo:]
            m3 = aim[st + 3, jlo:]
            m4 = aim[st + 4, jlo:]
            m5 = aim[st + 5, jlo:]
            for jj in range(np.uint64(j0), np.uint64(j1)):   # unsigned: no wrap-around tests
                w0, w1, w2, w3, w4, w5 = wt[0, jj], wt[1, jj], wt[2, jj], wt[3, jj], wt[4, jj], wt[5, jj]
                m = okc[jj]
                gre[jj] = m * (w0 * r0[jj] + w1 * r1[jj] + w2 * r2[jj] + w3 * r3[jj] + w4 * r4[jj] + w5 * r5[jj])
                gim[jj] = m * (w0 * m0[jj] + w1 * m1[jj] + w2 * m2[jj] + w3 * m3[jj] + w4 * m4[jj] + w5 * m5[jj])
            j0 = j1
    else:
        for jj in range(ncol):
            k = idx_t[jj] * nq + jlo + jj
            vr = 0.0
            vi = 0.0
            for a in range(ntap):
                vr += wt[a, jj] * fr[k + a * nq]
                vi += wt[a, jj] * fi[k + a * nq]
            gre[jj] = okc[jj] * vr
            gim[jj] = okc[jj] * vi
    for i in range(n):
        fq32[i] = np.float32(fq[i])
    _row_weights(kind, fq32, wq, tab_q)
    if ntap == 6:   # runs of points whose stencil starts advance with them: contiguous loads
        i = 0
        while i < n:
            off = idx_q[i] - jlo - i
            e = i + 1
            while e < n and idx_q[e] - jlo - e == off:
                e += 1
            for k in range(np.uint64(i), np.uint64(e)):
                b = k + np.uint64(off)   # modulo 2**64: the sum is the (non-negative) index
                w0, w1, w2, w3, w4, w5 = wq[0, k], wq[1, k], wq[2, k], wq[3, k], wq[4, k], wq[5, k]
                vr = np.float64(w0 * gre[b] + w1 * gre[b + _U1] + w2 * gre[b + _U2] + w3 * gre[b + _U3]
                                + w4 * gre[b + _U4] + w5 * gre[b + _U5])
                vi = np.float64(w0 * gim[b] + w1 * gim[b + _U1] + w2 * gim[b + _U2] + w3 * gim[b + _U3]
                                + w4 * gim[b + _U4] + w5 * gim[b + _U5])
                acc_re[k] += vr * cr[k] - vi * ci[k]
                acc_im[k] += vr * ci[k] + vi * cr[k]
            i = e
    else:
        _taps_acc(gre, gim, idx_q, jlo, wq, ntap, cr, ci, acc_re, acc_im)


@njit(parallel=True, cache=True, fastmath=_FM)
def _merge(cre, cim, cgeo, cq0, dq, ct0, cdtau, pgeo, pq0, pt0, pdtau, first, count, kind, tab_q, tab_t,
           kref, out_re, out_im):
    """Parent sub-image s = Σ over children ``first[s] .. +count[s]`` interpolated at its nodes."""
    n_par, nt, nq = out_re.shape
    ntap = NTAPS[kind]
    tab_q32 = tab_q.astype(np.float32)
    tab_t32 = tab_t.astype(np.float32)
    lo = -(ntap // 2 - 1)
    for job in prange(n_par * nt):
        s = job // nt
        it = job - s * nt
        tau = pt0[s] + it * pdtau[s]
        pq = pq0[s]
        p2, p3, p4, p5 = pgeo[2, s], pgeo[3, s], pgeo[4, s], pgeo[5, s]
        xs = np.empty(nq)
        ys = np.empty(nq)
        qp = np.empty(nq)
        qs = np.empty(nq)
        ts = np.empty(nq)
        idx_q, idx_t, wq, wt, cr, ci, fq, ft, flat = _row_scratch(nq, ntap)
        acc_re = np.zeros(nq)
        acc_im = np.zeros(nq)
        ncmax = max(cre.shape[2], nq) + ntap
        idx_t2 = np.empty(ncmax, np.int32)
        ftc = np.empty(ncmax)
        # the separable passes run in float32 (the precision the sub-images are stored in): eight
        # lanes a vector where float64 has four
        wtc = np.empty((ntap, ncmax), np.float32)
        wq32 = np.empty((ntap, nq), np.float32)
        okc = np.empty(ncmax, np.float32)
        gre = np.empty(ncmax, np.float32)
        gim = np.empty(ncmax, np.float32)
        slope = np.empty(nq)
        ft32 = np.empty(ncmax, np.float32)
        fq32 = np.empty(nq, np.float32)
        for iq in range(nq):
            qp[iq] = pq + iq * dq
            xs[iq], ys[iq] = _node(qp[iq], tau, p2, p3, p4, p5)
        for c in range(first[s], first[s] + count[s]):
            g0, g1, g2, g3, g4, g5 = cgeo[0, c], cgeo[1, c], cgeo[2, c], cgeo[3, c], cgeo[4, c], cgeo[5, c]
            for iq in range(nq):
                qs[iq], ts[iq] = _coords(xs[iq], ys[iq], g0, g1, g2, g3, g4, g5)
            mono = True
            for iq in range(1, nq):
                if not qs[iq] > qs[iq - 1]:
                    mono = False
                    break
            if mono and nq >= 2:
                _separable_row(cre[c], cim[c], cq0[c], dq, ct0[c], cdtau[c], kref, qs, ts, qp, kind, ntap, lo,
                               idx_q, fq, wq32, idx_t2, ftc, wtc, okc, gre, gim, cr, ci, acc_re, acc_im,
                               tab_q32, tab_t32, (slope, ft32, fq32))
                continue
            _polar_row(cre[c], cim[c], cq0[c], dq, ct0[c], cdtau[c], kref, qs, ts, qp, kind, ntap, lo,
                       idx_q, idx_t, wq, wt, cr, ci, fq, ft, acc_re, acc_im, tab_q32, tab_t32, flat)
        out_re[s, it] = acc_re
        out_im[s, it] = acc_im


@njit(parallel=True, cache=True, fastmath=_FM)
def _final(cre, cim, cgeo, cq0, dq, ct0, cdtau, x, y, kind, tab_q, tab_t, kref, out_re, out_im):
    """Cartesian image: Σ over the sub-images, interpolated at each pixel, re-modulated and added
    to ``out``."""
    ny = y.size
    nx = x.size
    n_child = cre.shape[0]
    ntap = NTAPS[kind]
    lo = -(ntap // 2 - 1)
    tab_q32 = tab_q.astype(np.float32)
    tab_t32 = tab_t.astype(np.float32)
    for row in prange(ny):
        yv = y[row]
        zero = np.zeros(nx)
        qs = np.empty(nx)
        ts = np.empty(nx)
        idx_q, idx_t, wq, wt, cr, ci, fq, ft, flat = _row_scratch(nx, ntap)
        acc_re = np.zeros(nx)
        acc_im = np.zeros(nx)
        for c in range(n_child):
            g0, g1, g2, g3, g4, g5 = cgeo[0, c], cgeo[1, c], cgeo[2, c], cgeo[3, c], cgeo[4, c], cgeo[5, c]
            for ix in range(nx):
                qs[ix], ts[ix] = _coords(x[ix], yv, g0, g1, g2, g3, g4, g5)
            _polar_row(cre[c], cim[c], cq0[c], dq, ct0[c], cdtau[c], kref, qs, ts, zero, kind, ntap, lo,
                       idx_q, idx_t, wq, wt, cr, ci, fq, ft, acc_re, acc_im, tab_q32, tab_t32, flat)
        for ix in range(nx):   # added: the image is formed from groups of sub-images in turn
            out_re[row, ix] += acc_re[ix]
            out_im[row, ix] += acc_im[ix]
