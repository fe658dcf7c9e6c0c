"""Window (taper) weights for the matched filter and every image former.

The weights ``w_pj`` of eq. ``mf`` are the outer product of a cross-range window over pulses and a
range window over frequencies. Every former divides by ``W = Σ w_pj`` (CONVENTIONS.md "Image
formation and its normalisation"), so a unit point scatterer keeps a peak of 1 whatever window is
chosen; a window trades resolution for lower sidelobes.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import windows as _sw

__all__ = ["WINDOW_KINDS", "window_weights", "window_1d"]

#: The window kinds :func:`window_weights` understands.
WINDOW_KINDS = ("none", "hann", "hamming", "taylor")


def window_1d(n: int, kind: str = "none", *, nbar: int = 4, sll_db: float = -35.0) -> np.ndarray:
    """One symmetric window of length ``n`` (float64), from :mod:`scipy.signal.windows`.

    Parameters
    ----------
    n : int
        Number of samples (>= 1). A single sample gets weight 1.
    kind : {'none', 'hann', 'hamming', 'taylor'}
        ``'none'`` gives ones.
    nbar : int
        Number of nearly constant-level sidelobes of the Taylor window.
    sll_db : float
        Taylor sidelobe level in dB below the main lobe; the sign is ignored (-35 and 35 both
        mean sidelobes 35 dB down).

    Returns
    -------
    w : ndarray, shape (n,)
        Peak-normalised weights. Where a window would be all zeros (Hann with two samples) the
        weights are ones: a window needs three samples to taper.

    Raises
    ------
    ValueError
        For an unknown kind (the message names the valid kinds) or ``n < 1``.
    """
    if kind not in WINDOW_KINDS:
        raise ValueError(f"unknown window {kind!r}; choose one of {', '.join(WINDOW_KINDS)}")
    n = int(n)
    if n < 1:
        raise ValueError(f"a window needs at least one sample, got {n}")
    if n == 1 or kind == "none":
        return np.ones(n)
    if kind == "hann":
        w = _sw.hann(n, sym=True)
    elif kind == "hamming":
        w = _sw.hamming(n, sym=True)
    else:
        w = _sw.taylor(n, nbar=int(nbar), sll=abs(float(sll_db)), norm=True, sym=True)
    w = np.asarray(w, dtype=np.float64)
    if not np.any(w > 0):
        return np.ones(n)
    return w


def window_weights(n_pulses: int, n_freqs: int, kind: str = "none", *, nbar: int = 4,
                   sll_db: float = -35.0) -> np.ndarray:
    """Separable window weights ``w[p, j] = w_cr[p] · w_r[j]`` for eq. ``mf``.

    Parameters
    ----------
    n_pulses, n_freqs : int
        Number of pulses P (cross-range window) and of frequencies M (range window).
    kind : {'none', 'hann', 'hamming', 'taylor'}
        The same window shape is used in both directions; ``'none'`` gives ones.
    nbar, sll_db : int, float
        Taylor parameters (see :func:`window_1d`).

    Returns
    -------
    w : ndarray, shape (P, M), float64

    Examples
    --------
    >>> w = window_weights(4, 3, "hamming")
    >>> w.shape, float(w.max()) <= 1.0
    ((4, 3), True)
    """
    w_cr = window_1d(n_pulses, kind, nbar=nbar, sll_db=sll_db)
    w_r = window_1d(n_freqs, kind, nbar=nbar, sll_db=sll_db)
    return np.outer(w_cr, w_r)
