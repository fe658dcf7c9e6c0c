"""ADMM for ``min_f ‖Af - b‖² + λ‖Tf‖₁`` exactly as the paper's Appendix A.

Augmented Lagrangian (eq. ``eq: l1ag``)::

    L(f, g, σ) = ‖Af - b‖² + λ‖g‖₁ + β/2 ‖Tf - g‖² - Re σᴴ(Tf - g)

and one iteration (eq. ``eq: iters``):

1. f-step: gradient descent on ``L(·, g, σ)`` (gradient eq. ``eq: grad``, update eq. ``eq: updatef``)
   with a Barzilai-Borwein step ``τ = ‖s‖² / Re⟨s, H s⟩`` (``s`` the previous step, ``H = 2AᴴA + βTᴴT``
   the Hessian of the quadratic f-subproblem) and backtracking: when the BB step breaks the Armijo
   condition the exact minimiser along the gradient is taken instead. ``AᴴA s`` and ``AᴴA ∇`` follow
   from stored products by linearity, so each inner step costs exactly one ``AᴴA`` application.
2. g-step: complex shrinkage (eq. ``eq: updateg``); isotropic: per-pixel vector of differences.
3. multiplier: ``σ ← σ - β (Tf - g)``.

The solver is a small state machine: :meth:`ADMM.step` until :meth:`ADMM.done`; ``history``
holds per-iteration objective, data residual, ``‖Tf‖₁``, relative change, step size and elapsed
seconds. It sees the data only through :class:`~sarcli.linops.toeplitz.NormalEquations`, so the
NUFFT pair and the pre-gridded Toeplitz form are interchangeable.
"""

from __future__ import annotations

import sys
import time
import warnings
from typing import Callable, NamedTuple

import numpy as np

from ..errors import ConvergenceWarning
from ..linops import (add_twice_diff, axpy, empty, norm2, norm2_diff, rdot, rdot_diff, rdot_diff2,
                     shrink_update, step_dots)
from ..linops.base import Linop
from ..linops.toeplitz import NormalEquations
from .shrink import shrink

__all__ = ["ADMM", "Reestimate", "HISTORY_KEYS"]

HISTORY_KEYS = ("objective", "data_residual", "reg_norm", "relative_change", "step_size",
                "elapsed_s")

_ARMIJO = 1e-4


class Reestimate(NamedTuple):
    """A sparsifying transform re-estimated from the iterate: ``transform(f) -> T`` every
    ``every`` iterations (phase-corrected TV: Θ from the current iterate; ``every`` 0: never)."""

    every: int
    transform: Callable[[np.ndarray], Linop]


class ADMM:
    """Alternating direction method of multipliers for ``‖Af-b‖² + λ‖Tf‖₁``.

    Parameters
    ----------
    normal : NormalEquations
        ``AᴴA``, ``Aᴴb`` and ``‖b‖²``.
    T : Linop
        Sparsifying transform (identity, D, Dᵏ, DΘ); its input shape is the image shape.
    lam : float
        Regularisation weight λ > 0.
    beta : float
        Penalty β > 0 of the augmented Lagrangian.
    x0 : ndarray, optional
        Initial image (default 0).
    isotropic : bool
        Shrink the vector ``(Tf)[:, pixel]`` by its norm (isotropic TV) when T stacks several
        difference directions on axis 0; otherwise every entry alone (anisotropic, ℓ1).
    tol : float
        Stop when ``‖f_k - f_{k-1}‖ / ‖f_k‖ < tol``.
    max_iter : int
        Iteration cap; reaching it without meeting ``tol`` warns (:class:`ConvergenceWarning`).
    inner_iters : int
        Gradient steps of the f-step per iteration (Appendix A: "a few"; 1 is enough with BB steps
        and keeps an iteration at one ``AᴴA`` application).
    reestimate : Reestimate, optional
        ``reestimate.transform(f) -> T`` called every ``reestimate.every`` iterations
        (phase-corrected TV: Θ from the current iterate); None or ``every`` 0: never.
    """

    def __init__(self, normal: NormalEquations, T: Linop, lam: float, beta: float, *, x0=None,
                 isotropic: bool = True, tol: float = 1e-4, max_iter: int = 200,
                 inner_iters: int = 1, reestimate: Reestimate | None = None):
        if not lam >= 0 or not np.isfinite(lam):
            raise ValueError(f"lam must be finite and >= 0, got {lam}")
        if not beta > 0 or not np.isfinite(beta):
            raise ValueError(f"beta must be finite and > 0, got {beta}")
        self.normal = normal
        self.lam, self.beta = float(lam), float(beta)
        self.tol, self.max_iter, self.inner_iters = float(tol), int(max_iter), max(1, int(inner_iters))
        self.reestimate = None if reestimate is None or int(reestimate.every) <= 0 else \
            Reestimate(int(reestimate.every), reestimate.transform)
        self._t0 = time.perf_counter()
        shape = normal.gram.ishape
        self.f = np.zeros(shape, np.complex128) if x0 is None else np.array(x0, np.complex128)
        self.Gf = normal.gram.forward(self.f)
        self._set_T(T, isotropic)
        self.sigma = empty(self.T.oshape)
        self.sigma.fill(0.0)
        self.g = empty(self.T.oshape)
        self.g[...] = shrink(self.Tf, self.lam / self.beta, group_axis=self.group_axis)
        self._prev = None
        # by-products of one pass kept for the next, each with the arrays it was computed from
        # (checked by identity, so a stale value is never used): w = β(Tf - g) - σ from the g-step,
        # ‖f - f_p‖² and Re⟨f - f_p, Gf - Gf_p⟩ from the end of an iteration, ‖Tf - Tf_p‖² from the
        # backtracking test
        self._w = self._w_of = None
        self._bb = self._bb_of = None
        self._tt = self._tt_of = None
        self.tau = 0.0
        self.iteration = 0
        self.relative_change = np.inf
        self.history: dict[str, list[float]] = {k: [] for k in HISTORY_KEYS}

    # -- helpers ----------------------------------------------------------------------------------
    def _set_T(self, T: Linop, isotropic: bool):
        if T.ishape != self.f.shape:
            raise ValueError(f"T acts on {T.ishape}, the image is {self.f.shape}")
        self.T = T
        self.isotropic = bool(isotropic)
        stacked = len(T.oshape) == len(T.ishape) + 1
        self.group_axis = 0 if (isotropic and stacked) else None
        self.Tf = T.forward(self.f)

    def reg_norm(self, Tf=None) -> float:
        """``‖Tf‖₁`` (isotropic: the sum over pixels of the norms of the difference vectors)."""
        Tf = self.Tf if Tf is None else Tf
        if self.group_axis is None:
            return float(np.sum(np.abs(Tf)))
        return float(np.sum(np.sqrt(np.sum(Tf.real**2 + Tf.imag**2, axis=self.group_axis))))

    def data_residual2(self) -> float:
        """``‖Af - b‖²`` of the current iterate."""
        return self.normal.residual_norm2(self.f, self.Gf)

    def _private(self, name: str):
        """The attribute ``name`` when nothing outside the solver refers to it or to its memory
        (so the next value can be written into it), else None. CPython reference counts: one
        for the attribute and one for the argument of ``getrefcount``."""
        a = self.__dict__.get(name)
        if not isinstance(a, np.ndarray) or not a.flags.c_contiguous or not a.flags.writeable \
                or a.dtype != np.complex128 or sys.getrefcount(a) != 3:
            return None
        # getrefcount(a) counts the dict entry, the local name and the argument
        if a.base is not None and (not isinstance(a.base, np.ndarray) or sys.getrefcount(a.base) != 2):
            return None  # some other view shares the memory
        return a

    @staticmethod
    def _same(a, b) -> bool:
        return a is not None and len(a) == len(b) and all(x is y for x, y in zip(a, b))

    def objective(self) -> float:
        """``‖Af - b‖² + λ‖Tf‖₁`` (eq. ``eq: main-L1``) at the current iterate."""
        return self.data_residual2() + self.lam * self.reg_norm()

    def gradient(self) -> np.ndarray:
        """``∇_f L = 2Aᴴ(Af - b) + βTᴴ(Tf - g) - Tᴴσ`` (eq. ``eq: grad``)."""
        return self._gradient()[0]

    def _gradient(self):
        """The gradient (a new array) and its squared norm, in two passes over the image."""
        if self._same(self._w_of, (self.Tf, self.g, self.sigma)):
            w = self._w
        else:
            w = self.beta * (self.Tf - self.g) - self.sigma
        v = np.asarray(self.T.adjoint(w), dtype=np.complex128, order="C")
        if v is w:
            v = v.copy()
        gg = add_twice_diff(self.Gf, self.normal.atb, v)
        return v, gg

    # -- the state machine --------------------------------------------------------------------------
    def _f_step(self):
        grad, gg = self._gradient()
        if gg == 0.0 or not np.isfinite(gg):
            self.tau = 0.0
            return
        gram, beta = self.normal.gram, self.beta
        tt = None
        if self._prev is None:
            # exact minimiser along -grad of the quadratic f-subproblem
            Gd, Td = gram.forward(grad), self.T.forward(grad)
            curv = 2.0 * rdot(grad, Gd) + beta * norm2(Td)
            tau = gg / curv if curv > 0 else 0.0
            f_new, Gf_new, Tf_new = self.f - tau * grad, self.Gf - tau * Gd, self.Tf - tau * Td
        else:
            # Barzilai-Borwein: τ = ‖s‖² / Re⟨s, H s⟩ with H s = 2AᴴA s + βTᴴT s from stored products
            f_p, Gf_p, Tf_p = self._prev
            if self._same(self._bb_of, (self.f, f_p, self.Gf, Gf_p)):
                ss, c1 = self._bb
            else:
                ss, c1 = norm2_diff(self.f, f_p), rdot_diff2(self.f, f_p, self.Gf, Gf_p)
            c2 = self._tt if self._same(self._tt_of, (Tf_p, self.Tf)) else norm2_diff(self.Tf, Tf_p)
            curv = 2.0 * c1 + beta * c2
            tau = ss / curv if (curv > 0 and ss > 0) else self.tau
            f_new = axpy(self.f, tau, grad)
            Gf_new, Tf_new = gram.forward(f_new), self.T.forward(f_new)
            if tau > 0:
                # backtracking: the f-subproblem is quadratic, so its decrease along -grad is known
                # exactly: τ²·curv_d = 2τ Re⟨∇, AᴴA(f - f_new)⟩ + β‖T(f - f_new)‖²
                tt = norm2_diff(self.Tf, Tf_new)
                curv_d = (2.0 * tau * rdot_diff(grad, self.Gf, Gf_new) + beta * tt) / tau**2
                if not 0.5 * tau * curv_d <= (1.0 - _ARMIJO) * gg:
                    Gd, Td = (self.Gf - Gf_new) / tau, (self.Tf - Tf_new) / tau
                    tau = gg / curv_d
                    f_new, Gf_new, Tf_new = self.f - tau * grad, self.Gf - tau * Gd, self.Tf - tau * Td
                    tt = None
        self._prev = (self.f, self.Gf, self.Tf)
        self._tt, self._tt_of = (tt, (self.Tf, Tf_new)) if tt is not None else (None, None)
        self.f, self.Gf, self.Tf, self.tau = f_new, Gf_new, Tf_new, float(tau)

    def step(self) -> None:
        """One ADMM iteration: f-step, g-step (shrinkage), multiplier update; logs the history."""
        f_old = self.f
        for _ in range(self.inner_iters):
            self._f_step()
        if self._w is None or self._w.shape != self.Tf.shape:
            self._w = empty(self.Tf.shape)
        # g and σ are replaced: when only the solver holds them, the new values go into their memory
        self._w_of = None
        g_out, s_out = self._private("g"), self._private("sigma")
        if g_out is not None and (g_out.shape != self.Tf.shape or g_out is self.Tf):
            g_out = None
        if s_out is not None and (s_out.shape != self.Tf.shape or s_out is self.Tf):
            s_out = None
        self.g, self.sigma, reg = shrink_update(self.Tf, self.sigma, self.beta, self.lam / self.beta,
                                                self.group_axis is not None, w=self._w, g_out=g_out,
                                                sigma_out=s_out)
        self._w_of = (self.Tf, self.g, self.sigma)
        self.iteration += 1
        # f_old's AᴴA product is at hand when the last f-step started from f_old (one inner step)
        pair = self._prev is not None and self._prev[0] is f_old and self._prev[1] is not None
        Gf_old = self._prev[1] if pair else self.Gf
        nf2, nd2, c1, fg, fb = step_dots(self.f, f_old, self.Gf, Gf_old, self.normal.atb)
        self._bb, self._bb_of = ((nd2, c1), (self.f, f_old, self.Gf, Gf_old)) if pair else (None, None)
        nf, nd = np.sqrt(nf2), np.sqrt(nd2)
        self.relative_change = float(nd / nf) if nf > 0 else (0.0 if nd == 0 else np.inf)
        if self.reestimate is not None and self.iteration % self.reestimate.every == 0:
            self._set_T(self.reestimate.transform(self.f), self.isotropic)
            self._prev = None
            self.g = shrink(self.Tf - self.sigma / self.beta, self.lam / self.beta,
                            group_axis=self.group_axis)
            reg = self.reg_norm()
        r2 = self.normal.residual_from_dots(fg, fb)
        h = self.history
        h["objective"].append(r2 + self.lam * reg)
        h["data_residual"].append(float(np.sqrt(r2 / self.normal.bnorm2)) if self.normal.bnorm2 > 0
                                  else float(np.sqrt(r2)))
        h["reg_norm"].append(reg)
        h["relative_change"].append(self.relative_change)
        h["step_size"].append(self.tau)
        h["elapsed_s"].append(time.perf_counter() - self._t0)

    @property
    def converged(self) -> bool:
        return self.iteration > 0 and self.relative_change < self.tol

    def done(self) -> bool:
        """True once the relative change is below ``tol`` or the iteration cap is reached."""
        return self.converged or self.iteration >= self.max_iter

    def run(self, callback: Callable[["ADMM"], None] | None = None) -> np.ndarray:
        """Iterate to :meth:`done`, calling ``callback(self)`` after each step; returns ``f``.

        Warns with :class:`ConvergenceWarning` (and the final relative change) at the cap.
        """
        while not self.done():
            self.step()
            if callback is not None:
                callback(self)
        if not self.converged:
            warnings.warn(f"ADMM stopped at its iteration cap ({self.max_iter}) with relative change "
                          f"{self.relative_change:.3g} > tol {self.tol:.3g}", ConvergenceWarning,
                          stacklevel=2)
        return self.f

    def history_arrays(self) -> dict[str, np.ndarray]:
        """The history as float64 arrays (for :class:`sarcli.core.types.Image`)."""
        return {k: np.asarray(v, np.float64) for k, v in self.history.items()}
