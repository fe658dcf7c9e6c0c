"""Compiled kernels of fast factorised backprojection (:mod:`sarcli.formers.ffbp`), C++ in
``src/native/ffbp.cpp`` (module ``sarcli._native._ffbp``), and the arrays they take.

Each kernel is parallel over rows of its output:

- :func:`sarcli.formers.ffbp._stage0.stage0` backprojects the range profiles of each base
  sub-aperture onto its polar grid;
- :func:`merge` forms each parent sub-image on its polar grid from its children's (two 1-D
  interpolations along each parent row where the row's child range increases, else a 2-D
  stencil; re-referenced phase);
- :func:`final` forms the Cartesian image from the last sub-images.

A sub-aperture's polar grid is described by its centre ``c`` (|c|, ground distance ``ρ0`` of its
nadir from the scene origin, unit vector ``e0`` from that nadir towards the origin) and the
coordinates of a ground point ``x``: the differential slant range ``q = |c - x| - |c|`` and the
direction cosine ``u = ((x - c)·e⊥)/|c - x|`` of the ray from ``c`` to ``x`` across ``e0``
(``e⊥ = ẑ × e0``). Both are taken without cancellation, so virtual antennas 10^9 m away
(far-field data) keep their accuracy. Stored sub-images are demodulated:
``F(q, u) = I(x) exp(-i k_ref q)``, float32 real and imaginary planes ``[n, n_u, n_q]``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..._native import load
from ..._native.layout import FfbpFrame
from ...core import sampling

#: Taps of each interpolator, by its code (:data:`sarcli.core.sampling.INTERPOLATORS`).
NTAPS = tuple(i.taps for i in sorted(sampling.INTERPOLATORS.values(), key=lambda i: i.code))


def native():
    """The compiled module ``sarcli._native._ffbp``."""
    return load("ffbp")


def frame(level, a=0, b=None):
    """The kernels' description of sub-apertures ``a .. b-1`` of a level: the rows
    :class:`sarcli._native.layout.FfbpFrame` names (cx, cy, |c|, ρ0, e0x, e0y, cz from ``level.geo``,
    then q0, u0, Δu), float64 ``[10, n]``."""
    sl = slice(a, b)
    f = np.empty((len(FfbpFrame), len(level.q0[sl])))
    f[:FfbpFrame.Q0] = level.geo[:FfbpFrame.Q0, sl]
    f[FfbpFrame.Q0], f[FfbpFrame.U0], f[FfbpFrame.DU] = level.q0[sl], level.u0[sl], level.du[sl]
    return f


def table(coef):
    """A kernel's weight polynomials as the kernels read them: float32 ``[6, 8]``; ``None`` (the
    analytic kernels, which read none): zeros in its place."""
    if coef is None:
        return np.zeros((6, 8), np.float32)
    return np.ascontiguousarray(coef, dtype=np.float32)


class Interp(NamedTuple):
    """How the polar grids are read: the interpolator's code (:data:`NTAPS`), the range and
    angular weight polynomials (:func:`table`; None for the analytic kernels), the range spacing of
    every grid and the reference wavenumber of the demodulation."""

    kind: int
    tab_q: object
    tab_t: object
    dq: float
    kref: float


def merge(children, cframe, pframe, groups, interp: Interp, out, rows=None):
    """Parent sub-image s = Σ over children ``first[s] .. +count[s]`` interpolated at its nodes
    (those of ``rows``; the others set to zero).

    Parameters
    ----------
    children : (ndarray, ndarray), each shape (C, n_u, n_q), float32
        Children's sub-images, real and imaginary parts.
    cframe, pframe : ndarray, shape (10, C) and (10, S)
        Children's and parents' :func:`frame`.
    groups : (array_like of int, array_like of int), each shape (S,)
        ``(first, count)``: each parent's children (indices into ``children``).
    interp : Interp
    out : (ndarray, ndarray), each shape (S, n_u', n_q'), float32
        Parents' sub-images, real and imaginary parts (written).
    rows : ndarray of int64, shape (S, n_u', 2), optional
        The nodes ``start .. stop-1`` of each parent row to form
        (:meth:`sarcli.formers.ffbp._grids._Level.row_table`); None: every node.
    """
    (cre, cim), (first, count), (out_re, out_im) = children, groups, out
    rows = full_rows(out_re.shape) if rows is None else np.ascontiguousarray(rows, np.int64)
    native().merge(cre, cim, cframe, pframe, np.ascontiguousarray(first, np.int64),
                   np.ascontiguousarray(count, np.int64), rows, table(interp.tab_q), table(interp.tab_t),
                   int(interp.kind), float(interp.dq), float(interp.kref), out_re, out_im)


def full_rows(shape):
    """Row bounds ``[S, n_u, 2]`` that take every node of grids of ``shape`` ``(S, n_u, n_q)``."""
    out = np.zeros((shape[0], shape[1], 2), np.int64)
    out[..., 1] = shape[2]
    return out


def final(children, cframe, x, y, interp: Interp, img):
    """Add the sub-images ``children = (re, im)`` (frames ``cframe``), interpolated at every pixel
    ``(x[j], y[i])`` and re-modulated, to ``img`` (complex128 ``[ny, nx]``, C-contiguous)."""
    cre, cim = children
    native().final_stage(cre, cim, cframe, np.ascontiguousarray(x, np.float64), np.ascontiguousarray(y, np.float64),
                         table(interp.tab_q), table(interp.tab_t), int(interp.kind), float(interp.dq),
                         float(interp.kref), img)


def row_weights(kind, frac, coef=None):
    """The kernels' interpolation weights ``w[tap, i]`` at fractions ``frac`` (float64 or float32,
    as given; ``coef`` the polynomials of kind 3): the compiled evaluation, for tests."""
    frac = np.ascontiguousarray(frac)
    dt = np.float32 if frac.dtype == np.float32 else np.float64
    frac = frac.astype(dt, copy=False)
    tab = np.zeros((6, 8), dt) if coef is None else np.ascontiguousarray(coef, dtype=dt)
    out = np.empty((NTAPS[kind], frac.size), dt)
    native().row_weights(int(kind), frac, tab, out)
    return out
