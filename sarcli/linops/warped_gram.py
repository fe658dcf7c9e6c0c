"""``AᴴA`` of the warped operator (:class:`~sarcli.linops.warped.WarpedNufftOperator`) by FFTs.

``AᴴA = Σ_s Eᴴ Sᵀ T_s S E``: per run of pulses, the pixels spread onto the run's grid, its Toeplitz
form applied by FFTs, the grid interpolated back (each run's ``gram`` in :mod:`sarcli.linops.warped`),
all in single precision with work arrays kept between calls.
"""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .._native import threads, using_threads
from .base import Linop

__all__ = ["WarpedGram"]


class _RunWork:
    """A Gram's work arrays for one run, kept between calls: fresh arrays of this size cost page
    faults that outweigh the arithmetic."""

    def __init__(self, run):
        self.toeplitz = run.toeplitz()
        self.grid = np.empty(run.shape, np.complex64)
        self.applied = np.empty(run.shape, np.complex64)
        self.scratch = np.empty((0,) + run.shape, np.complex64)


class WarpedGram(Linop):
    """``AᴴA`` of a :class:`WarpedNufftOperator`: ``Σ_s Eᴴ Sᵀ T_s S E`` in single precision
    (Hermitian and positive semi-definite to its rounding, ~1e-7; equal to ``Aᴴ(A x)`` to the
    NUFFT's ``eps``); the operator's ``eps`` is at least 1e-6 here.

    With several runs and several kernel threads (:func:`sarcli._native.threads` of the calling
    thread) the runs are shared out, one thread each, every thread summing its own; with one run
    the run's kernels take the threads. A run's transforms gain little from a second thread, its
    neighbour's gain it all."""

    def __init__(self, op):
        super().__init__(op.ishape, op.ishape, np.complex128)
        self.op = op
        for run in op.runs:
            run.toeplitz()
        n = int(np.prod(op.ishape))
        self._f32 = np.empty(n, np.complex64)   # kept between calls
        self._work = None    # a _RunWork per run, made on the first product
        self._sums = []      # per thread: (complex64 part, complex128 sum), made on first use
        self._pool, self._pool_size = None, 0    # threads beside the caller's, one per run at most
        self._lock = threading.Lock()   # the work arrays serve one call at a time

    def _forward(self, x):
        return self._forward_scaled(x, 1.0)

    def _share(self, k: int, n: int, total=None) -> np.ndarray:
        """Thread ``k`` of ``n``: runs k, k + n, ... summed into ``total`` (complex128; default the
        thread's own, kept between calls); returns it."""
        while len(self._sums) <= k:
            self._sums.append([np.empty(self._f32.size, np.complex64), None])
        part = self._sums[k][0]
        if total is None:
            if self._sums[k][1] is None:
                self._sums[k][1] = np.empty(self._f32.size, np.complex128)
            total = self._sums[k][1]
        runs = list(zip(self.op.runs, self._work))[k::n]
        for i, (run, work) in enumerate(runs):
            run.gram(self._f32, part, work)
            if i == 0:
                total[...] = part
            else:
                total += part
        return total

    def _forward_scaled(self, x, scale):
        # linear: the scale goes onto the single-precision copy of x, no pass or array of its own
        with self._lock:
            f = self._f32
            if scale == 1.0:
                np.copyto(f, np.reshape(x, -1), casting="same_kind")
            else:
                np.multiply(np.reshape(x, -1), scale, out=f, casting="same_kind")
            if self._work is None:
                self._work = [_RunWork(run) for run in self.op.runs]
            out = np.empty(f.size, np.complex128)   # the caller's; thread 0 sums into it directly
            n = min(threads(), len(self.op.runs))
            if n <= 1:
                self._share(0, 1, out)
            else:
                if self._pool_size != n - 1:
                    if self._pool is not None:
                        self._pool.shutdown()
                    self._pool = ThreadPoolExecutor(n - 1, initializer=threads, initargs=(1,))
                    self._pool_size = n - 1
                with using_threads(1):
                    later = [self._pool.submit(self._share, k, n) for k in range(1, n)]
                    self._share(0, n, out)
                for fut in later:
                    out += fut.result()
        return out.reshape(self.ishape)

    def _adjoint(self, y):
        return self._forward(y)

    def _adjoint_scaled(self, y, scale):
        return self._forward_scaled(y, np.conj(scale))
