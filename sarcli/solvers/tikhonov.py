"""Tikhonov regularisation ``min ‖Af - b‖² + λ‖Df‖²`` by conjugate gradients (eq. ``eq: Tik``).

The minimiser solves ``(AᴴA + λ DᴴD) f = Aᴴb``; the system matrix is Hermitian positive
(semi-)definite and is handed to :func:`scipy.sparse.linalg.cg` as a ``LinearOperator``.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
from scipy.sparse.linalg import LinearOperator, cg

from ..errors import ConvergenceWarning
from ..linops import norm2
from ..linops.base import Linop
from ..linops.toeplitz import NormalEquations

__all__ = ["tikhonov"]


def tikhonov(normal: NormalEquations, D: Linop, lam: float, *, x0=None, tol: float = 1e-8,
             max_iter: int = 500, callback=None):
    """Solve ``(AᴴA + λ DᴴD) f = Aᴴb`` by CG.

    Parameters
    ----------
    normal : NormalEquations
    D : Linop
        Regularisation operator on the image (e.g. :class:`FiniteDifference`).
    lam : float
        λ ≥ 0.
    x0 : ndarray, optional
        Initial image.
    tol : float
        CG relative residual tolerance.
    max_iter : int
        CG iteration cap (warns with :class:`ConvergenceWarning` when reached).
    callback : callable, optional
        ``callback(iteration, objective)`` after each CG iteration.

    Returns
    -------
    f : ndarray
        The image (shape of ``Aᴴb``).
    history : dict of str -> ndarray
        Per-iteration ``objective`` (``‖Af-b‖² + λ‖Df‖²``), ``data_residual`` (relative),
        ``reg_norm`` (``‖Df‖²``), ``relative_change`` and ``elapsed_s`` (ADMM's keys but
        ``step_size``, which scipy's CG keeps to itself).
    """
    shape = normal.atb.shape
    n = int(np.prod(shape))
    lam = float(lam)

    def matvec(v):
        x = np.asarray(v).reshape(shape)
        out = normal.gram.forward(x)
        if lam != 0.0:
            out = out + lam * D.adjoint(D.forward(x))
        return out.reshape(-1)

    op = LinearOperator((n, n), matvec=matvec, rmatvec=matvec, dtype=np.complex128)
    t0 = time.perf_counter()
    hist = {"objective": [], "data_residual": [], "reg_norm": [], "relative_change": [],
            "elapsed_s": []}
    prev = [np.zeros(n, np.complex128) if x0 is None else np.asarray(x0, np.complex128).reshape(-1)]

    def _log(xk):
        x = xk.reshape(shape)
        r2 = normal.residual_norm2(x, normal.gram.forward(x))
        reg = norm2(D.forward(x))
        obj = r2 + lam * reg
        nx = np.sqrt(norm2(xk))
        hist["objective"].append(obj)
        hist["reg_norm"].append(reg)
        hist["data_residual"].append(float(np.sqrt(r2 / normal.bnorm2)) if normal.bnorm2 > 0 else 0.0)
        hist["relative_change"].append(float(np.sqrt(norm2(xk - prev[0])) / nx) if nx > 0 else 0.0)
        hist["elapsed_s"].append(time.perf_counter() - t0)
        prev[0] = xk.copy()
        if callback is not None:
            callback(len(hist["objective"]), obj)

    b = normal.atb.reshape(-1).astype(np.complex128)
    x, info = cg(op, b, x0=prev[0].copy(), rtol=tol, atol=0.0, maxiter=int(max_iter), callback=_log)
    if info > 0:
        warnings.warn(f"Tikhonov CG stopped at its iteration cap ({max_iter}); relative residual "
                      f"{np.linalg.norm(matvec(x) - b) / max(np.linalg.norm(b), 1e-300):.3g} "
                      f"> tol {tol:.3g}", ConvergenceWarning, stacklevel=2)
    return x.reshape(shape), {k: np.asarray(v, np.float64) for k, v in hist.items()}
