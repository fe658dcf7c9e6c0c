"""The coarse-to-fine search of minimum entropy (:func:`coarse_to_fine`, the module docstring of
:mod:`sarcli.autofocus.entropy`), and independent searches side by side on threads (:func:`each`)."""

from __future__ import annotations

import numpy as np

from ._lbfgs import minimize
from ._levels import LEVELS, level_basis, spacing, without_gauge
from ._imager import Imager

__all__ = ["coarse_to_fine", "defocus_search", "each", "DEFOCUS_SCAN"]

#: Quadratic phases tried before the smooth level (rad at the aperture ends): a large quadratic
#: error puts the smooth level's L-BFGS in a local minimum, a scan over it does not.
DEFOCUS_SCAN = np.arange(-12.0, 12.5, 2.0)


def defocus_search(imager, phi, quad) -> np.ndarray:
    """``phi + a · quad`` for the ``a`` of :data:`DEFOCUS_SCAN` (``quad`` scaled to 1 at the ends)
    of lowest entropy (``a = 0`` included)."""
    q = quad / np.max(np.abs(quad))
    h = [imager.entropy(phi + a * q) for a in DEFOCUS_SCAN]
    return phi + DEFOCUS_SCAN[int(np.argmin(h))] * q


def coarse_to_fine(imager: Imager, start, gauge, levels=LEVELS, max_iter: int = 30,
                   max_fun: int | None = None):
    """The minimum-entropy estimate after each level, started from ``start``: at most ``max_iter``
    L-BFGS iterations and ``max_fun`` evaluations (default ``2 max_iter``) per level.

    Returns
    -------
    list of ndarray
        ``φ`` after each level of ``levels`` (each continues from the previous one).
    """
    P = gauge.shape[0]
    phi = np.asarray(start, np.float64).copy()
    out = []
    for level in levels:
        A = level_basis(level, P, gauge)
        # a phase smooth over `spacing` pulses needs no finer sub-apertures than that
        im = imager.coarsened(spacing(level, P))
        if level == "smooth" and A is not None:
            phi = defocus_search(im, phi, A[:, 0])
        base = phi

        if A is None:
            def fun(c, base=base, im=im):
                h, g = im.entropy_and_gradient(base + c)
                return h, g - gauge @ (gauge.T @ g)
            n = P
        else:
            def fun(c, base=base, A=A, im=im):
                h, g = im.entropy_and_gradient(base + A @ c)
                return h, A.T @ g
            n = A.shape[1]
        x = minimize(fun, n, max_iter, max_fun)
        step = x if A is None else A @ x
        # the phase the imager's images are exact for (block means on sub-apertures), constant
        # and linear part removed
        phi = without_gauge(imager.blockwise(base + step), gauge)
        out.append(phi.copy())
    return out


def each(fn, jobs) -> list:
    """``[fn(j) for j in jobs]``, the jobs side by side on up to ``sarcli._native.threads()``
    threads, each running its kernels on one (independent searches; each returns what it would
    alone)."""
    from .._native import threads, using_threads

    jobs = list(jobs)
    workers = min(len(jobs), threads())
    if workers <= 1:
        return [fn(j) for j in jobs]
    from concurrent.futures import ThreadPoolExecutor

    def one(j):
        with using_threads(1):
            return fn(j)

    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(one, jobs))
