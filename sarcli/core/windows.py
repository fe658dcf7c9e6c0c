"""Window (taper) weights for the matched filter and every image former.

The weights ``w_pj`` of eq. ``mf`` are the outer product of a cross-range window over pulses and a
range window over frequencies. Every former divides by ``W = Σ w_pj`` (docs/conventions.md "Image
formation and its normalisation"), so a unit point scatterer keeps a peak of 1 whatever window is
chosen; a window trades resolution for lower sidelobes.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = ["WINDOW_KINDS", "window_weights", "window_1d", "check_taylor", "IRW_FACTOR_UNIFORM", "irw_factor",
           "TAYLOR_NBAR", "TAYLOR_SLL_DB", "TAYLOR_NBAR_RANGE", "TAYLOR_SLL_DB_RANGE", "blackman_harris",
           "BLACKMAN_HARRIS_MAINLOBE_BINS"]

#: The window kinds :func:`window_weights` understands.
WINDOW_KINDS = ("none", "hann", "hamming", "taylor")

#: -3 dB impulse-response width of the unweighted (uniform) aperture in resolution cells: the
#: half-power width of ``sinc`` is 0.8859 / bandwidth (Harris, Proc. IEEE 66, 1978, Table 1).
#: The IRW factor of any other window: :func:`irw_factor`.
IRW_FACTOR_UNIFORM = 0.8859

#: Taylor window defaults and the ranges accepted (the CLI's options are built from these).
TAYLOR_NBAR = 4
TAYLOR_NBAR_RANGE = (1, 64)
TAYLOR_SLL_DB = -35.0
TAYLOR_SLL_DB_RANGE = (-120.0, -13.0)


def check_taylor(nbar, sll_db) -> tuple[int, float]:
    """Validate the Taylor parameters: ``nbar`` an integer in ``TAYLOR_NBAR_RANGE`` and ``sll_db``
    (sidelobe level, dB, negative) in ``TAYLOR_SLL_DB_RANGE``.

    Raises
    ------
    ValueError
        Naming the parameter, its value and the accepted range.

    Examples
    --------
    >>> check_taylor(4, -35)
    (4, -35.0)
    """
    lo, hi = TAYLOR_NBAR_RANGE
    if isinstance(nbar, bool) or not float(nbar).is_integer() or not lo <= int(nbar) <= hi:
        raise ValueError(f"Taylor nbar must be an integer from {lo} to {hi}, got {nbar!r}")
    sll = float(sll_db)
    lo, hi = TAYLOR_SLL_DB_RANGE
    if not lo <= sll <= hi:
        raise ValueError(f"Taylor sidelobe level must be from {lo:g} to {hi:g} dB (negative: below the "
                         f"main lobe; a Taylor window cannot go above the uniform -13.3 dB), got {sll_db!r}")
    return int(nbar), sll


def window_1d(n: int, kind: str = "none", *, nbar: int = TAYLOR_NBAR, sll_db: float = TAYLOR_SLL_DB) -> np.ndarray:
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
        Taylor sidelobe level in dB relative to the main lobe (negative: -35 means sidelobes
        35 dB down); see :func:`check_taylor`.

    Returns
    -------
    w : ndarray, shape (n,)
        Peak-normalised weights. Where a window would be all zeros (Hann with two samples) the
        weights are ones: a window needs three samples to taper.

    Raises
    ------
    ValueError
        For an unknown kind (the message names the valid kinds), ``n < 1`` or Taylor
        parameters out of range.
    """
    if kind not in WINDOW_KINDS:
        raise ValueError(f"unknown window {kind!r}; choose one of {', '.join(WINDOW_KINDS)}")
    n = int(n)
    if n < 1:
        raise ValueError(f"a window needs at least one sample, got {n}")
    if kind == "taylor":
        nbar, sll_db = check_taylor(nbar, sll_db)
    if n == 1 or kind == "none":
        return np.ones(n)
    from scipy.signal import windows as _sw  # slow to import: only when a window is asked for

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


def window_weights(n_pulses: int, n_freqs: int, kind: str = "none", *, nbar: int = TAYLOR_NBAR,
                   sll_db: float = TAYLOR_SLL_DB) -> np.ndarray:
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


@functools.lru_cache(maxsize=32)
def irw_factor(kind: str = "none", *, nbar: int = TAYLOR_NBAR, sll_db: float = TAYLOR_SLL_DB,
               n: int = 2048, pad: int = 64) -> float:
    """-3 dB impulse-response width of a window, in resolution cells of the unweighted aperture.

    The continuous limit: the window (:func:`window_1d`, ``n`` samples) transformed with
    ``pad``-fold zero padding, and the half-power point of its main lobe found by linear
    interpolation of the amplitude between transform samples (1/``pad`` of a cell apart).
    Uniform gives 0.886 (:data:`IRW_FACTOR_UNIFORM`), Hamming 1.30, Hann 1.44 (Harris, Proc. IEEE
    66, 1978, Table 1).

    Raises
    ------
    ValueError
        An unknown window or bad Taylor parameters.
    """
    w = np.ones(n) if kind in (None, "none", "uniform", "rect") else window_1d(n, kind, nbar=nbar, sll_db=sll_db)
    amp = np.abs(np.fft.fft(w, n * pad)[: n * pad // 2]) / np.sum(w)   # the main lobe's right half
    i = int(np.argmax(amp < np.sqrt(0.5)))                               # first sample below half power
    frac = (amp[i - 1] - np.sqrt(0.5)) / (amp[i - 1] - amp[i])
    return float(2.0 * (i - 1 + frac) / pad)


# -- a low-sidelobe analysis window (not an image-forming taper) ----------------------------------

_BH = (0.35875, 0.48829, 0.14128, 0.01168)
#: Half-width of the Blackman-Harris main lobe, in bins of the unpadded DFT.
BLACKMAN_HARRIS_MAINLOBE_BINS = 4


def blackman_harris(m: int) -> np.ndarray:
    """The 4-term Blackman-Harris window (-92 dB sidelobes), symmetric, length ``m``: the range
    window of the noise estimate of :func:`sarcli.regularize.regparam.estimate_noise_power`."""
    if m < 2:
        return np.ones(m)
    t = 2 * np.pi * np.arange(m) / (m - 1)
    return _BH[0] - _BH[1] * np.cos(t) + _BH[2] * np.cos(2 * t) - _BH[3] * np.cos(3 * t)
