"""Complex-native linear operators with forward, adjoint and composition.

A :class:`Linop` maps arrays of shape ``ishape`` to arrays of shape ``oshape``; subclasses
implement ``_forward`` and ``_adjoint``. ``.H`` is the adjoint operator, ``A @ B`` composes,
``A + B`` / ``A - B`` add, ``c * A`` scales; the adjoints of the results come for free, so a new
operator built from old ones never needs its own adjoint test beyond the shared contract
(``tests/test_linops.py``).
"""

from __future__ import annotations

import numbers

import numpy as np

from ._reduce import norm2

__all__ = ["Linop", "Identity", "Diagonal", "MatrixLinop", "Compose", "Sum", "Scaled", "Adjoint",
           "power_norm", "gram_eigmax"]


def _shape(s) -> tuple[int, ...]:
    return tuple(int(v) for v in (s if np.iterable(s) else (s,)))


class Linop:
    """A linear operator ``A: C^ishape -> C^oshape`` with its adjoint.

    Parameters
    ----------
    ishape, oshape : tuple of int
        Shapes of the input and output arrays.
    dtype : numpy dtype
        Complex dtype of the outputs (complex128 unless an operator says otherwise).
    """

    def __init__(self, ishape, oshape, dtype=np.complex128):
        self.ishape = _shape(ishape)
        self.oshape = _shape(oshape)
        self.dtype = np.dtype(dtype)

    # -- to implement -------------------------------------------------------------------------
    def _forward(self, x: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _adjoint(self, y: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _forward_scaled(self, x: np.ndarray, scale) -> np.ndarray:
        """``scale · A x``; operators that can fold the scalar into their last pass override this."""
        return scale * self._forward(x)

    def _adjoint_scaled(self, y: np.ndarray, scale) -> np.ndarray:
        """``scale · Aᴴ y`` (see :meth:`_forward_scaled`)."""
        return scale * self._adjoint(y)

    # -- public -------------------------------------------------------------------------------
    def forward(self, x) -> np.ndarray:
        """``A x`` for ``x`` of shape ``ishape``."""
        x = np.asarray(x)
        if x.shape != self.ishape:
            raise ValueError(f"{type(self).__name__}: input shape {x.shape} != {self.ishape}")
        return self._forward(x)

    def adjoint(self, y) -> np.ndarray:
        """``Aᴴ y`` for ``y`` of shape ``oshape``."""
        y = np.asarray(y)
        if y.shape != self.oshape:
            raise ValueError(f"{type(self).__name__}: adjoint input shape {y.shape} != {self.oshape}")
        return self._adjoint(y)

    __call__ = forward

    @property
    def H(self) -> "Linop":
        """The adjoint operator ``Aᴴ``."""
        return Adjoint(self)

    def gram(self) -> "Linop":
        """``AᴴA``; operators with a faster normal operator (Toeplitz) override this."""
        return Compose(self.H, self)

    # -- algebra ------------------------------------------------------------------------------
    def __matmul__(self, other):
        if isinstance(other, Linop):
            return Compose(self, other)
        return self.forward(other)

    def __add__(self, other):
        if not isinstance(other, Linop):
            return NotImplemented
        return Sum(self, other)

    def __sub__(self, other):
        if not isinstance(other, Linop):
            return NotImplemented
        return Sum(self, Scaled(other, -1.0))

    def __mul__(self, scalar):
        if not isinstance(scalar, numbers.Number):
            return NotImplemented
        return Scaled(self, scalar)

    __rmul__ = __mul__

    def __neg__(self):
        return Scaled(self, -1.0)

    def __repr__(self):
        return f"<{type(self).__name__} {self.oshape} <- {self.ishape}>"


class Adjoint(Linop):
    """The adjoint of another operator (``A.H``); its ``.H`` is ``A`` again."""

    def __init__(self, op: Linop):
        super().__init__(op.oshape, op.ishape, op.dtype)
        self.op = op

    def _forward(self, x):
        return self.op._adjoint(x)

    def _adjoint(self, y):
        return self.op._forward(y)

    @property
    def H(self):
        return self.op


class Compose(Linop):
    """``A B``: apply ``B`` then ``A``."""

    def __init__(self, a: Linop, b: Linop):
        if a.ishape != b.oshape:
            raise ValueError(f"cannot compose {a} with {b}: {a.ishape} != {b.oshape}")
        super().__init__(b.ishape, a.oshape, np.result_type(a.dtype, b.dtype))
        self.a, self.b = a, b

    def _forward(self, x):
        return self.a._forward(self.b._forward(x))

    def _adjoint(self, y):
        return self.b._adjoint(self.a._adjoint(y))


class Sum(Linop):
    """``A + B`` (same shapes)."""

    def __init__(self, a: Linop, b: Linop):
        if a.ishape != b.ishape or a.oshape != b.oshape:
            raise ValueError(f"cannot add {a} and {b}: shapes differ")
        super().__init__(a.ishape, a.oshape, np.result_type(a.dtype, b.dtype))
        self.a, self.b = a, b

    def _forward(self, x):
        return self.a._forward(x) + self.b._forward(x)

    def _adjoint(self, y):
        return self.a._adjoint(y) + self.b._adjoint(y)


class Scaled(Linop):
    """``c A`` for a (complex) scalar ``c``; the adjoint is ``conj(c) Aᴴ``."""

    def __init__(self, op: Linop, scalar):
        super().__init__(op.ishape, op.oshape, op.dtype)
        self.op, self.scalar = op, complex(scalar) if np.iscomplexobj(scalar) else float(scalar)

    def _forward(self, x):
        return self.op._forward_scaled(x, self.scalar)

    def _adjoint(self, y):
        return self.op._adjoint_scaled(y, np.conj(self.scalar))

    def gram(self):
        return Scaled(self.op.gram(), abs(self.scalar) ** 2)


class Identity(Linop):
    """The identity on arrays of ``shape`` (the ℓ1 prior's T)."""

    def __init__(self, shape, dtype=np.complex128):
        super().__init__(shape, shape, dtype)

    def _forward(self, x):
        return x.astype(self.dtype, copy=True)

    def _adjoint(self, y):
        return y.astype(self.dtype, copy=True)


class Diagonal(Linop):
    """Pointwise multiplication by an array ``d`` (adjoint: by ``conj(d)``)."""

    def __init__(self, d):
        d = np.asarray(d)
        super().__init__(d.shape, d.shape, np.result_type(d.dtype, np.complex64))
        self.d = d

    def _forward(self, x):
        return self.d * x

    def _adjoint(self, y):
        return np.conj(self.d) * y


class MatrixLinop(Linop):
    """A dense matrix acting on flattened arrays: small test problems and baselines.

    Parameters
    ----------
    matrix : ndarray, shape (m, n)
    ishape, oshape : tuple, optional
        Shapes with ``prod(ishape) = n`` and ``prod(oshape) = m`` (default ``(n,)``, ``(m,)``).
    """

    def __init__(self, matrix, ishape=None, oshape=None):
        m = np.asarray(matrix)
        ishape = (m.shape[1],) if ishape is None else ishape
        oshape = (m.shape[0],) if oshape is None else oshape
        super().__init__(ishape, oshape, np.result_type(m.dtype, np.complex64))
        if int(np.prod(self.ishape)) != m.shape[1] or int(np.prod(self.oshape)) != m.shape[0]:
            raise ValueError(f"matrix {m.shape} does not fit shapes {self.oshape} <- {self.ishape}")
        self.matrix = m

    def _forward(self, x):
        return (self.matrix @ x.reshape(-1)).reshape(self.oshape)

    def _adjoint(self, y):
        return (self.matrix.conj().T @ y.reshape(-1)).reshape(self.ishape)


def gram_eigmax(gram: Linop, *, iters: int = 30, seed: int = 0, callback=None) -> float:
    """Largest eigenvalue of a Hermitian positive semi-definite operator (power iteration).

    Deterministic (fixed seed); 30 iterations give a few digits, which is all a scaling needs.
    ``callback(i)`` is called after each application of ``gram`` (i = 1, 2, ...).
    """
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(gram.ishape) + 1j * rng.standard_normal(gram.ishape)
    x /= np.sqrt(norm2(x))
    lam = 0.0
    for i in range(iters):
        y = gram.forward(x)
        lam = float(np.sqrt(norm2(y)))
        if callback is not None:
            callback(i + 1)
        if lam == 0.0 or not np.isfinite(lam):
            return lam
        x = y / lam
    return lam


def power_norm(op: Linop, *, iters: int = 30, seed: int = 0) -> float:
    """Spectral norm ``‖A‖₂``, the square root of :func:`gram_eigmax` of ``op.gram()``."""
    return float(np.sqrt(gram_eigmax(op.gram(), iters=iters, seed=seed)))
