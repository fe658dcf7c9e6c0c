"""What a run of ``regularize`` costs: its AᴴA products counted, its time forecast.

:class:`CountedGram` counts every application of ``AᴴA`` (the cost in products, the same on every
machine); :class:`Forecast` predicts the run's seconds from the scaling's products and the solver's
own work per iteration, and announces a long run before it goes on (docs/regularize.md, "Cost,
counted" and "Progress and the forecast").
"""

from __future__ import annotations

import time

import numpy as np

from ..linops import shrink_update
from ..linops.base import Linop
from .lampath import PATH_FIRST_ITERS, PATH_ITERS
from .regparam import LAM_MIN, SELECT_PATH

__all__ = ["CountedGram", "Forecast", "solver_overhead", "LONG_RUN_S", "PATH_POINTS", "FINAL_SHARE"]


#: A run predicted to last longer than this many seconds is announced (``notice``) with the
#: estimate and what would shorten it.
LONG_RUN_S = 60.0
#: The forecast's λ path length (points) and final solve (share of ``iters``): the middle of what
#: the benchmarks of docs/regularize.md show (paths of 4-6 points; final solves of 0.3-1 × the cap).
PATH_POINTS, FINAL_SHARE = 5, 0.55


class CountedGram(Linop):
    """``AᴴA`` that counts its applications (``count``): the cost of a run in products, the same on
    every machine, for the scaling's power iterations, the λ path and the final solve alike."""

    def __init__(self, op: Linop):
        super().__init__(op.ishape, op.oshape, op.dtype)
        self.op, self.count = op, 0

    def _forward(self, x):
        self.count += 1
        return self.op.forward(x)

    def _adjoint(self, y):
        self.count += 1
        return self.op.adjoint(y)

    def _forward_scaled(self, x, scale):
        self.count += 1
        return self.op._forward_scaled(x, scale)

    def _adjoint_scaled(self, y, scale):
        self.count += 1
        return self.op._adjoint_scaled(y, scale)


class Forecast:
    """The run's time, from the scaling's AᴴA products (the median of those after the first, which
    carries one-time set-up) and the solver's own work per iteration, announced by ``notice`` when
    it exceeds :data:`LONG_RUN_S`.

    Expected: the scaling, a λ path of :data:`PATH_POINTS` points of ``PATH_ITERS + 1`` iterations
    for each of its two solvers (the first point ``PATH_FIRST_ITERS + 1``), and a final solve of
    :data:`FINAL_SHARE` of ``iters``; the bound: the path down to its floor and the final solve to
    its cap. Each iteration costs one product (two for CG, which logs its residual) plus the
    solver's passes over the image (differences, shrinkage, reductions), measured by
    :func:`solver_overhead`: with a fast operator they are a third of an iteration. A path
    iteration is timed on its own operator (:meth:`path_timed`: for a warped one, half the
    sub-apertures).
    """

    def __init__(self, prior, operator, power_iters, iters, auto, notice, tick):
        self.per = 2 if prior == "tikhonov" else 1
        self.path_points = len(SELECT_PATH) + int(np.floor(np.log(min(SELECT_PATH) / LAM_MIN) /
                                                           np.log(SELECT_PATH[0] / SELECT_PATH[1]) + 1e-9))
        self.first = min(iters, PATH_FIRST_ITERS) - min(iters, PATH_ITERS)  # the first point's extra iterations
        self.power_iters = power_iters
        self.prior, self.operator, self.iters, self.auto = prior, operator, iters, auto
        self.notice, self.tick, self.estimate, self.t = notice, tick, {}, [time.perf_counter()]
        self.gram_s = None
        self.path_s = None   # one path iteration of one solver, timed (:meth:`path_timed`)

    def path_timed(self, product_s: float, overhead_s: float) -> None:
        """One of the path's products (its own operator) and its solver's passes."""
        self.path_s = self.per * product_s + overhead_s

    def _path_iterations(self, points):
        return 2 * ((PATH_ITERS + 1) * points + self.first) if self.auto else 0

    def on_power(self, i):
        """After the scaling's ``i``-th product: the product's time is the median of those after the
        first (which carries one-time set-up), so one product slowed by another process does not
        move the forecast."""
        self.tick(1)
        self.t.append(time.perf_counter())
        if i >= 2:
            self.gram_s = float(np.median(np.diff(self.t[1:])))

    def seconds(self, path_points, final_iterations, overhead_s):
        """Seconds of the scaling, a path of ``path_points`` and a final solve of ``final_iterations``."""
        g, path = self.gram_s, self._path_iterations(path_points)
        if self.path_s is None:
            path_s = path * (self.per * g + overhead_s)
        else:
            path_s = path * self.path_s
        return g * self.power_iters + path_s + final_iterations * (self.per * g + overhead_s)

    def announce(self, overhead_s: float, memory_bytes: float | None = None) -> None:
        """Record the estimate (``predicted_s``, ``predicted_max_s``, ``seconds_per_product``,
        ``seconds_per_iteration``, ``predicted_bytes``) and, for a long run, say it (with the
        memory it will take) and what would shorten it."""
        if self.gram_s is None:
            return
        g = self.gram_s
        predicted = self.seconds(PATH_POINTS, FINAL_SHARE * self.iters, overhead_s)
        bound = self.seconds(self.path_points, self.iters, overhead_s)
        self.estimate.update(predicted_s=predicted, predicted_max_s=bound, seconds_per_product=g,
                             seconds_per_iteration=self.per * g + overhead_s)
        if memory_bytes is not None:
            self.estimate["predicted_bytes"] = float(memory_bytes)
        if self.notice is None or predicted <= LONG_RUN_S:
            return
        fixed = self.seconds(0, FINAL_SHARE * self.iters, overhead_s) - g * self.power_iters
        faster = [f"give --lam (skips the lam path, about {fixed:.0f} s)"] if self.auto else []
        faster += ["fewer --iters", "a coarser --pixel-size or a smaller --extent"]
        if self.operator == "spherical":
            faster.append("--operator warped (sub-aperture NUFFTs held to --tolerance)")
        elif self.operator == "warped":
            faster.append("a larger --tolerance (fewer sub-apertures)")
        path = (f"a lam path of about {PATH_POINTS} and up to {self.path_points} points of up to {PATH_ITERS} "
                f"iterations x 2 solvers, then " if self.auto else "")
        memory = "" if memory_bytes is None else f", about {memory_bytes / 2**30:.2g} GiB of memory"
        self.notice(f"regularize {self.prior}: about {predicted:.0f} s predicted, up to {bound:.0f} s ({path}"
                    f"up to {self.iters} iterations, {g:.2g} s per AhA product, {self.per * g + overhead_s:.2g} s "
                    f"per iteration{memory}); faster: {', '.join(faster)}")


def solver_overhead(T, D, image) -> float:
    """Seconds of one iteration's passes over the image besides its AᴴA product, measured on
    ``image`` (the faster of two tries): ADMM's ``T`` and ``Tᴴ`` and its fused shrinkage, twice (the
    reductions and the step's axpy take about as long again); CG's ``DᴴD``."""
    x = np.ascontiguousarray(image, np.complex128)
    best = np.inf
    for _ in range(2):   # the faster of two: the first may pay for fresh pages, or wait for another process
        t0 = time.perf_counter()
        if D is not None:
            D.adjoint(D.forward(x))
            best = min(best, time.perf_counter() - t0)
            continue
        tx = np.ascontiguousarray(T.forward(x), np.complex128)
        T.adjoint(tx)
        stacked = len(T.oshape) == len(T.ishape) + 1
        shrink_update(tx, np.zeros_like(tx), 1.0, 0.1, stacked, w=np.empty_like(tx))
        best = min(best, 2.0 * (time.perf_counter() - t0))
    return best
