"""The pre-gridded form of the SAR normal operator: ``AᴴA`` by FFTs on a 2N × 2N grid.

For the pixel model (``fourier.py``) ``(AᴴA f)[j] = Σ_j' K[j - j'] f[j']`` with the kernel
``K[m] = Σ_l w_l exp(+i (k1_l m1 + k2_l m2))``, ``m ∈ [-N, N)²``: a Toeplitz matrix. Embedded in a
2N × 2N circulant it is applied by one zero-padded FFT, a pointwise product and one inverse FFT
(paper Appendix A, "Computational Cost": re-grid once, then only FFTs). The kernel is computed
once by a FINUFFT type-1 transform of the weights onto the 2N × 2N modes, and ``Aᴴb`` once by the
NUFFT adjoint; the grid-centre phase ramp cancels in ``AᴴA``.
"""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor

import finufft
import numpy as np
import scipy.fft

from .._native import threads
from ..formers.planning.cost import NUFFT_EPS
from ._reduce import empty, norm2, rdot
from .base import Linop

__all__ = ["ToeplitzGram", "NormalEquations", "normal_equations"]

_BLOCK_BYTES = 1 << 20


class ToeplitzGram(Linop):
    """``AᴴA`` (Hermitian, positive semi-definite) applied through a 2N × 2N circulant embedding.

    Parameters
    ----------
    k1, k2 : ndarray
        Dimensionless (wrapped) frequencies along x (columns) and y (rows), any shape.
    shape : (ny, nx)
        Image shape.
    weights : ndarray, optional
        Per-sample weights ``w_l`` (``AᴴWA``); default 1.
    eps : float
        FINUFFT tolerance of the kernel.
    fft_dtype : numpy dtype, optional
        Precision of the FFTs: complex128, or complex64 (faster, relative
        error ~1e-7, enough for an operator requested at ``eps ≥ 1e-6``). Default: complex64 when
        ``eps ≥ 1e-6``, else complex128. Outputs are complex128 either way.
    """

    def __init__(self, k1, k2, shape, *, weights=None, eps: float = NUFFT_EPS, fft_dtype=None):
        super().__init__(shape, shape, np.complex128)
        if fft_dtype is None:
            fft_dtype = np.complex64 if eps >= 1e-6 else np.complex128
        self.fft_dtype = np.dtype(fft_dtype)
        if self.fft_dtype not in (np.complex64, np.complex128):
            raise ValueError(f"fft_dtype must be complex64 or complex128, got {fft_dtype}")
        ny, nx = self.ishape
        k1 = np.ascontiguousarray(np.asarray(k1, np.float64).ravel())
        k2 = np.ascontiguousarray(np.asarray(k2, np.float64).ravel())
        w = np.ones(k1.size, np.complex128) if weights is None else \
            np.ascontiguousarray(np.asarray(weights, np.complex128).ravel())
        # K[m2, m1] for m in [-N, N): modes in increasing order (FINUFFT modeord 0)
        kernel = finufft.nufft2d1(k2, k1, w, (2 * ny, 2 * nx), eps=eps, isign=+1)
        # circulant first column: move m = 0 to index 0
        self.kernel_hat = scipy.fft.fft2(np.fft.ifftshift(kernel), workers=threads()).astype(self.fft_dtype)
        self.padded_shape = (2 * ny, 2 * nx)
        # rows per block of the x-pass: about 1 MiB of the padded grid, so a block stays in cache
        self._block = max(1, min(2 * ny, _BLOCK_BYTES // (2 * nx * self.fft_dtype.itemsize)))
        # work arrays kept between calls: a fresh 2N × N array each call costs page faults that
        # add a fifth to the transforms' time; a second thread in apply allocates its own
        self._lock = threading.Lock()
        self._work = None
        self._pool, self._pool_size = None, 0   # threads beside the caller's for the x-pass

    def _buffers(self, n: int = 1):
        """The y-pass's grid and ``n`` row blocks of the x-pass (one per thread)."""
        ny, nx = self.ishape
        if self._work is None or len(self._work[1]) < n:
            self._work = (empty((2 * ny, nx), self.fft_dtype),
                          [empty((self._block, 2 * nx), self.fft_dtype) for _ in range(n)])
        return self._work

    def _x_pass(self, y, zb, rows):
        """Rows ``rows`` of the y-transformed grid ``y`` in blocks through ``zb``: the transform along
        x, the product with the kernel and the inverse (one thread's share of :meth:`apply`)."""
        nx = self.ishape[1]
        for r in rows:
            m = min(self._block, y.shape[0] - r)
            z = zb[:m]
            z[:, :nx] = y[r:r + m]
            z[:, nx:] = 0
            z = scipy.fft.fft(z, axis=1, workers=1, overwrite_x=True)
            z *= self.kernel_hat[r:r + m]
            z = scipy.fft.ifft(z, axis=1, workers=1, overwrite_x=True)
            y[r:r + m] = z[:, :nx]

    def _forward(self, x):
        return self.apply(x)

    def _adjoint(self, y):
        return self.apply(y)  # Hermitian

    def _forward_scaled(self, x, scale):
        return self.apply(x, scale)

    def _adjoint_scaled(self, y, scale):
        return self.apply(y, scale)

    def apply(self, x, scale=1.0, out=None) -> np.ndarray:
        """``scale · AᴴA x`` (complex128, image shape, or written into ``out`` of any complex
        dtype); the scale costs no extra pass.

        Columns first: the zero-padded input has only ``nx`` nonzero columns, so the transform
        along y touches ``nx`` columns of length ``2ny``; then, in blocks of rows small enough to
        stay in cache, the transform along x, the product with the kernel and the inverse along x
        (keeping the ``nx`` columns the crop needs); last the inverse along y of those columns.
        Three quarters of the 1-D transforms of two full 2-D FFTs, and only the row passes (the
        fast, contiguous ones) run over the full 2N × 2N grid. With several kernel threads the
        column transforms split their columns among them and the blocks of rows are shared out, a
        thread each (a block's transforms are too small to split).
        """
        ny, nx = self.ishape
        workers = threads()   # the calling thread's count (sarcli._native.threads)
        mine = self._lock.acquire(blocking=False)
        try:
            if mine:
                y, zbs = self._buffers(workers)
            else:
                y = np.empty((2 * ny, nx), self.fft_dtype)
                zbs = [np.empty((self._block, 2 * nx), self.fft_dtype) for _ in range(workers)]
            # every transform runs in place (overwrite_x on an aligned complex array of its dtype)
            y[:ny] = x
            y[ny:] = 0
            y = scipy.fft.fft(y, axis=0, workers=workers, overwrite_x=True)  # (2ny, nx)
            starts = range(0, 2 * ny, self._block)
            if workers == 1 or len(starts) < 2 or not mine:   # the pool serves the lock's holder
                self._x_pass(y, zbs[0], starts)
            else:
                n = min(workers, len(starts))
                if self._pool_size != n - 1:
                    if self._pool is not None:
                        self._pool.shutdown()
                    self._pool, self._pool_size = ThreadPoolExecutor(n - 1), n - 1
                later = [self._pool.submit(self._x_pass, y, zbs[k], starts[k::n]) for k in range(1, n)]
                self._x_pass(y, zbs[0], starts[0::n])
                for fut in later:
                    fut.result()
            y = scipy.fft.ifft(y, axis=0, workers=workers, overwrite_x=True)
            if out is None:
                out = empty(self.ishape)
            if scale == 1.0:
                out[...] = y[:ny]
            else:
                np.multiply(y[:ny], scale, out=out, dtype=out.dtype)
            return out
        finally:
            if mine:
                self._lock.release()


class NormalEquations:
    """What a least-squares solver needs of ``‖Af - b‖²``: ``AᴴA``, ``Aᴴb`` and ``‖b‖²``.

    ``‖Af - b‖² = Re⟨f, AᴴA f⟩ - 2 Re⟨f, Aᴴb⟩ + ‖b‖²`` so the data term is evaluated without A.

    Attributes
    ----------
    gram : Linop
        ``AᴴA`` (NUFFT pair composed, or :class:`ToeplitzGram`).
    atb : ndarray
        ``Aᴴb`` (image shape).
    bnorm2 : float
        ``‖b‖²``.
    """

    def __init__(self, gram: Linop, atb, bnorm2: float):
        self.gram = gram
        self.atb = np.asarray(atb)
        self.bnorm2 = float(bnorm2)

    def residual_norm2(self, f, gram_f) -> float:
        """``‖Af - b‖²`` from ``f`` and ``AᴴA f`` (clipped at 0 against round-off)."""
        return self.residual_from_dots(rdot(f, gram_f), rdot(f, self.atb))

    def residual_from_dots(self, f_gram_f: float, f_atb: float) -> float:
        """``‖Af - b‖²`` from ``Re⟨f, AᴴA f⟩`` and ``Re⟨f, Aᴴb⟩`` (clipped at 0 against round-off)."""
        val = f_gram_f - 2.0 * f_atb + self.bnorm2
        return max(float(val), 0.0)

    def scaled(self, a_scale: float, b_scale: float) -> "NormalEquations":
        """The normal equations of ``A / a_scale`` and ``b / b_scale``."""
        from .base import Scaled

        return NormalEquations(Scaled(self.gram, 1.0 / a_scale**2), self.atb / (a_scale * b_scale),
                               self.bnorm2 / b_scale**2)


def normal_equations(op: Linop, b, *, form: str = "nufft") -> NormalEquations:
    """Build :class:`NormalEquations` of ``op`` and data ``b``.

    Parameters
    ----------
    op : Linop
        The forward operator (a :class:`~sarcli.linops.fourier.NufftOperator` for ``'toeplitz'``).
    form : {'nufft', 'toeplitz'}
        ``'nufft'``: ``AᴴA = Aᴴ ∘ A`` (two NUFFTs per application); ``'toeplitz'``: the
        pre-gridded FFT form (``op.toeplitz_gram()``); other operators use ``op.gram()``.
    """
    b = np.asarray(b)
    atb = op.adjoint(b)
    if form == "toeplitz":
        if not hasattr(op, "toeplitz_gram"):
            raise ValueError(f"{type(op).__name__} has no Toeplitz form")
        gram = op.toeplitz_gram()
    else:
        gram = op.gram()
    return NormalEquations(gram, atb, norm2(b))
