"""The windowed samples every former starts from, and the shape check of their k-space coordinates.

Kept apart from the formers so that a light former (NUFFT, PFA) does not import a compiled one.
"""

from __future__ import annotations

import numpy as np

__all__ = ["weighted_samples", "WeightedSamples", "is_lazy"]


def weighted_samples(data, weights=None):
    """The products ``w_pj d[p, j]`` (complex128) and their normaliser ``W = Σ w_pj``.

    Parameters
    ----------
    data : array_like, shape (P, M)
        Phase history d[p, j].
    weights : array_like, shape (P, M), optional
        Window weights (ones when omitted).

    Returns
    -------
    wd : ndarray, shape (P, M), complex128
    total : float
        ``W``; a ValueError is raised when it is not positive.
    """
    d = np.asarray(data)
    if d.ndim != 2:
        raise ValueError(f"phase history must be 2-D [pulses, frequencies], got shape {d.shape}")
    d = d.astype(np.complex128, copy=False)
    if weights is None:
        return d, float(d.size)
    w = np.asarray(weights, dtype=np.float64)
    if w.shape != d.shape:
        raise ValueError(f"weights shape {w.shape} does not match the data shape {d.shape}")
    total = float(w.sum())
    if not total > 0:
        raise ValueError(f"window weights must have a positive sum, got {total}")
    return d * w, total


def check_kspace(data_shape, kx, ky):
    kx = np.asarray(kx, dtype=np.float64)
    ky = np.asarray(ky, dtype=np.float64)
    if kx.shape != tuple(data_shape) or ky.shape != tuple(data_shape):
        raise ValueError(f"k-space coordinates {kx.shape}, {ky.shape} do not match the data {data_shape}")
    return kx, ky


def is_lazy(data) -> bool:
    """True for samples left on disk (a :class:`sarcli.io.pulses.PulseSource`): read them in blocks."""
    return not isinstance(data, np.ndarray) and hasattr(data, "shape") and hasattr(data, "__getitem__") \
        and getattr(data, "ndim", None) == 2


class WeightedSamples:
    """``w_pj d[p, j]`` served by blocks of pulses, and ``W = Σ w_pj``.

    An in-memory array is weighted once (:func:`weighted_samples`); a lazy one
    (:func:`is_lazy`) is read and weighted one block at a time, so a former that visits the pulses
    in blocks never holds the whole phase history.
    """

    def __init__(self, data, weights=None):
        self.lazy = is_lazy(data)
        if not self.lazy:
            self._wd, self.total = weighted_samples(data, weights)
            self.shape = self._wd.shape
            return
        self._data = data
        self.shape = tuple(data.shape)
        self._w = None if weights is None else np.asarray(weights, dtype=np.float64)
        if self._w is not None and self._w.shape != self.shape:
            raise ValueError(f"weights shape {self._w.shape} does not match the data shape {self.shape}")
        self.total = float(self.shape[0] * self.shape[1]) if self._w is None else float(self._w.sum())
        if not self.total > 0:
            raise ValueError(f"window weights must have a positive sum, got {self.total}")

    def __getitem__(self, sl) -> np.ndarray:
        if not self.lazy:
            return self._wd[sl]
        block = np.asarray(self._data[sl]).astype(np.complex128, copy=False)
        return block if self._w is None else block * self._w[sl]
