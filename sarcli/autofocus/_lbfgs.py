"""Unbounded L-BFGS: scipy's L-BFGS-B routine (``setulb``) driven without importing ``scipy.optimize``.

Importing ``scipy.optimize`` (most of it ``scipy.linalg``, ``scipy.sparse`` and the
linear-programming modules) costs a ``sar autofocus`` run a tenth of its CPU time and a fifth of
its memory (docs/autofocus.md, "Cost"), and minimum entropy needs only the compiled L-BFGS-B
routine. :func:`lbfgs` loads that extension module by itself (it imports nothing from
``scipy.optimize``) and runs the same reverse-communication loop as
``scipy.optimize.minimize(method='L-BFGS-B')`` without bounds: the same points are evaluated in the
same order (``tests/test_autofocus_kernels.py`` checks it). The routine is private to scipy, so
the driver is pinned: where the module cannot be loaded that way (another scipy layout) or takes
other arguments (older scipy releases had the Fortran routine's; a trial on a small quadratic
tells), ``scipy.optimize.minimize`` runs instead (the same estimates, at that cost), and
``test_scipy_still_ships_the_lbfgsb_routine_the_driver_was_written_for`` fails, naming the scipy
release. :func:`minimize` is the search of one level of minimum entropy: L-BFGS from zero within a
budget of evaluations, ended when an iteration gains less than :data:`LEVEL_FTOL`, returning the
best point it evaluated.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import sys
from pathlib import Path

import numpy as np

__all__ = ["lbfgs", "minimize", "LEVEL_FTOL"]

_SETULB = []


def find_setulb():
    """scipy's compiled ``setulb``, loaded from its extension file; ``None`` if that fails."""
    if not _SETULB:
        fn = None
        try:
            mod = sys.modules.get("scipy.optimize._lbfgsb")
            if mod is None:
                spec = importlib.util.find_spec("scipy")
                root = Path(spec.origin).parent / "optimize"
                for suffix in importlib.machinery.EXTENSION_SUFFIXES:
                    path = root / f"_lbfgsb{suffix}"
                    if path.exists():
                        s = importlib.util.spec_from_file_location("scipy.optimize._lbfgsb", path)
                        mod = importlib.util.module_from_spec(s)
                        s.loader.exec_module(mod)
                        break
            fn = getattr(mod, "setulb", None)
            if fn is not None and not _works(fn):
                fn = None
        except Exception:  # noqa: BLE001 - any failure: scipy.optimize.minimize below
            fn = None
        _SETULB.append(fn)
    return _SETULB[0]


def _works(setulb) -> bool:
    """Whether ``setulb`` takes the arguments of the routine this driver was written for (that of
    scipy 1.17), tried on a small quadratic."""
    seen = []

    def quad(x):
        seen.append(x)
        r = x - np.array([1.0, -2.0])
        return float(r @ r), 2.0 * r

    try:
        _drive(setulb, quad, np.zeros(2), 20, 40, 1e-12, 1e-12, 10, 20)
    except Exception:  # noqa: BLE001 - another interface
        return False
    return bool(seen) and np.allclose(seen[-1], [1.0, -2.0], atol=1e-6)


def lbfgs(fun, x0, *, max_iter: int, max_fun: int, ftol: float = 1e-12, gtol: float = 1e-12,
          maxcor: int = 10, maxls: int = 20) -> None:
    """Minimise ``fun`` (returns value and gradient) from ``x0`` as
    ``scipy.optimize.minimize(fun, x0, jac=True, method='L-BFGS-B', options=...)`` does without
    bounds, for at most ``max_iter`` iterations (``maxfun`` = ``max_fun``, checked between
    iterations as scipy does). Returns nothing: the caller keeps what it needs from ``fun``'s calls
    (an exception raised by ``fun`` ends the search)."""
    setulb = find_setulb()
    x = np.array(np.asarray(x0, np.float64).ravel())
    if setulb is None:
        from scipy.optimize import minimize

        minimize(fun, x, jac=True, method="L-BFGS-B",
                 options={"maxiter": max_iter, "maxfun": max_fun, "ftol": ftol, "gtol": gtol,
                          "maxcor": maxcor, "maxls": maxls})
        return
    _drive(setulb, fun, x, max_iter, max_fun, ftol, gtol, maxcor, maxls)


#: A level ends when an L-BFGS iteration lowers the entropy by less than this fraction of it
#: (L-BFGS-B's ``ftol``): on minimum entropy's levels the later iterations change the entropy by far
#: less than the held-out gains its decision weighs.
LEVEL_FTOL = 1e-7


class _Spent(Exception):
    """The evaluations allowed to one level are spent."""


def minimize(fun, n: int, max_iter: int, max_fun: int | None) -> np.ndarray:
    """L-BFGS (scipy's L-BFGS-B routine, :func:`~sarcli.autofocus._lbfgs.lbfgs`) on ``fun`` (value
    and gradient) from zero, at most ``max_iter`` iterations and ``max_fun`` evaluations (default
    ``2 max_iter``; line searches included, which scipy's own ``maxfun`` checks only between
    iterations), ended earlier by :data:`LEVEL_FTOL`; the best point evaluated."""
    max_fun = 2 * max_iter if max_fun is None else max_fun
    best = [np.inf, np.zeros(n), 0]

    def counted(c):
        if best[2] >= max_fun:
            raise _Spent
        best[2] += 1
        h, g = fun(c)
        if h < best[0]:
            best[:2] = h, np.array(c, np.float64)
        return h, g

    try:
        lbfgs(counted, np.zeros(n), max_iter=max_iter, max_fun=max_fun, ftol=LEVEL_FTOL, gtol=1e-12)
    except _Spent:
        pass
    return best[1]


def _drive(setulb, fun, x, max_iter, max_fun, ftol, gtol, maxcor, maxls):
    """scipy's reverse-communication loop of ``_minimize_lbfgsb`` without bounds (module docstring)."""
    x = np.array(x, np.float64)
    n = x.size
    m = maxcor
    factr = ftol / np.finfo(float).eps
    nbd = np.zeros(n, np.int32)
    low = np.zeros(n, np.float64)
    high = np.zeros(n, np.float64)
    wa = np.zeros(2 * m * n + 5 * n + 11 * m * m + 8 * m, np.float64)
    iwa = np.zeros(3 * n, np.int32)
    task = np.zeros(2, np.int32)
    ln_task = np.zeros(2, np.int32)
    lsave = np.zeros(4, np.int32)
    isave = np.zeros(44, np.int32)
    dsave = np.zeros(29, np.float64)
    # scipy's ScalarFunction evaluates the start once, then answers a request for the point it
    # evaluated last from its cache; the routine starts from f = 0, g = 0 as scipy's loop does
    last_x = x.copy()
    h, gg = fun(last_x.copy())
    last = float(h), np.asarray(gg, np.float64).ravel().copy()
    f, g = np.array(0.0), np.zeros(n, np.float64)
    nfev, iterations = 1, 0
    while True:
        g = g.astype(np.float64)
        setulb(m, x, low, high, nbd, f, g, factr, gtol, wa, iwa, task, lsave, isave, dsave, maxls, ln_task)
        if task[0] == 3:
            if not np.array_equal(x, last_x):
                last_x = x.copy()
                h, gg = fun(last_x.copy())
                nfev += 1
                last = float(h), np.asarray(gg, np.float64).ravel().copy()
            f, g = last[0], last[1].copy()
        elif task[0] == 1:
            iterations += 1
            if iterations >= max_iter:
                task[0], task[1] = 5, 504
            elif nfev > max_fun:
                task[0], task[1] = 5, 502
        else:
            break
