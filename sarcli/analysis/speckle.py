"""Speckle and sharpness metrics of a complex (or magnitude) SAR image.

All metrics work on the intensity :math:`I = |f|^2` of an image ``f``:

* :func:`image_entropy` -- Shannon entropy of the normalised intensity
  :math:`p_i = I_i / \\sum_j I_j`, :math:`H = -\\sum_i p_i \\ln p_i` (nats). The standard SAR
  autofocus sharpness metric: energy concentrated in few pixels gives a low entropy, so
  *lower is sharper*. Between 0 (one bright pixel) and :math:`\\ln n` (flat image of n pixels).
* :func:`peak_to_mean` -- :math:`\\max I / \\operatorname{mean} I`; *higher is sharper*.
* :func:`equivalent_number_of_looks` -- :math:`\\mathrm{ENL} = \\operatorname{mean}(I)^2 /
  \\operatorname{var}(I)` over a homogeneous region. Fully developed single-look speckle has
  exponentially distributed intensity and ENL = 1; averaging L independent looks gives ENL = L.
  Speckle reduction raises the ENL.
* :func:`contrast` -- the speckle contrast :math:`\\operatorname{std}(I) / \\operatorname{mean}(I)
  = 1/\\sqrt{\\mathrm{ENL}}` over a region; speckle reduction lowers it.

A *region* is anything that indexes a 2-D array: a boolean mask of the image's shape, a tuple of
slices ``(slice(r0, r1), slice(c0, c1))``, or ``None`` for the whole image.
"""

from __future__ import annotations

import numpy as np

__all__ = ["image_entropy", "peak_to_mean", "equivalent_number_of_looks", "contrast",
           "speckle_metrics", "region_slices"]


def _intensity(image, region=None) -> np.ndarray:
    """|f|² (float64, flattened) over ``region`` of ``image``."""
    f = np.asarray(image)
    if f.size == 0:
        raise ValueError("the image is empty")
    if region is not None:
        f = f[region]
        if f.size == 0:
            raise ValueError("the region selects no pixels")
    inten = np.abs(f).astype(np.float64, copy=False) ** 2
    return inten.ravel()


def image_entropy(image) -> float:
    """Shannon entropy of the normalised intensity (nats); lower is sharper.

    Parameters
    ----------
    image : array_like
        Complex or real image of any shape.

    Returns
    -------
    float
        :math:`H = -\\sum_i p_i \\ln p_i` with :math:`p_i = |f_i|^2 / \\sum_j |f_j|^2`
        (terms with :math:`p_i = 0` contribute 0). 0 for one bright pixel, :math:`\\ln n` for
        a flat image of n pixels; 0 for an all-zero image.

    Examples
    --------
    >>> import numpy as np
    >>> bool(abs(image_entropy(np.ones((4, 4))) - np.log(16)) < 1e-12)
    True
    >>> image_entropy(np.eye(1, 16).reshape(4, 4))
    0.0
    """
    inten = _intensity(image)
    total = inten.sum()
    if not np.isfinite(total) or total <= 0.0:
        return 0.0
    p = inten[inten > 0.0] / total
    return float(-np.sum(p * np.log(p)) + 0.0)


def peak_to_mean(image) -> float:
    """Peak-to-mean intensity ratio :math:`\\max|f|^2 / \\operatorname{mean}|f|^2`; higher is sharper.

    Parameters
    ----------
    image : array_like
        Complex or real image.

    Returns
    -------
    float
        Between 1 (flat image) and n (one bright pixel of n); 0 for an all-zero image.

    Examples
    --------
    >>> import numpy as np
    >>> peak_to_mean(np.eye(1, 16).reshape(4, 4))
    16.0
    """
    inten = _intensity(image)
    m = inten.mean()
    return float(inten.max() / m) if m > 0.0 else 0.0


def equivalent_number_of_looks(image, region=None) -> float:
    """Equivalent number of looks :math:`\\operatorname{mean}(I)^2/\\operatorname{var}(I)`, I = |f|².

    Parameters
    ----------
    image : array_like
        Complex or real image.
    region : bool mask, tuple of slices or None
        A homogeneous (distributed-scatterer) region; ``None``: the whole image.

    Returns
    -------
    float
        1 for fully developed single-look speckle, L for an L-look average, ``inf`` for a
        constant region; ``nan`` for an all-zero region.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> f = rng.standard_normal((256, 256)) + 1j * rng.standard_normal((256, 256))
    >>> bool(abs(equivalent_number_of_looks(f) - 1.0) < 0.05)
    True
    """
    inten = _intensity(image, region)
    m = inten.mean()
    v = inten.var()
    if m <= 0.0:
        return float("nan")
    if v == 0.0:
        return float("inf")
    return float(m * m / v)


def contrast(image, region=None) -> float:
    """Speckle contrast :math:`\\operatorname{std}(I)/\\operatorname{mean}(I)` of I = |f|².

    Parameters
    ----------
    image : array_like
        Complex or real image.
    region : bool mask, tuple of slices or None
        Region to measure; ``None``: the whole image.

    Returns
    -------
    float
        :math:`1/\\sqrt{\\mathrm{ENL}}`: 1 for single-look speckle, 0 for a constant region,
        ``nan`` for an all-zero region.
    """
    inten = _intensity(image, region)
    m = inten.mean()
    if m <= 0.0:
        return float("nan")
    return float(inten.std() / m)


def speckle_metrics(image, region=None) -> dict:
    """All four metrics as a plain dict (JSON types).

    Entropy and peak-to-mean are measured over the whole image (they describe focus); ENL and
    contrast over ``region`` (they describe speckle in a homogeneous area).

    Returns
    -------
    dict
        ``{"entropy": .., "peak_to_mean": .., "enl": .., "contrast": ..}``.
    """
    return {"entropy": image_entropy(image), "peak_to_mean": peak_to_mean(image),
            "enl": equivalent_number_of_looks(image, region),
            "contrast": contrast(image, region)}


def region_slices(x_m, y_m, bounds) -> tuple[slice, slice]:
    """Row/column slices of the pixels whose centres lie in ``bounds = (x0, x1, y0, y1)`` (m).

    Parameters
    ----------
    x_m, y_m : array_like
        Increasing pixel-centre coordinates of the columns and rows.
    bounds : sequence of 4 floats

    Raises
    ------
    ValueError
        When the bounds are not 4 finite numbers with x0 < x1, y0 < y1, or select no pixel.
    """
    b = np.asarray(bounds, dtype=np.float64).ravel()
    if b.size != 4 or not np.all(np.isfinite(b)) or b[0] >= b[1] or b[2] >= b[3]:
        raise ValueError(f"region must be X0,X1,Y0,Y1 in metres with X0 < X1 and Y0 < Y1, got {bounds}")
    x, y = np.asarray(x_m), np.asarray(y_m)
    cols = np.flatnonzero((x >= b[0]) & (x <= b[1]))
    rows = np.flatnonzero((y >= b[2]) & (y <= b[3]))
    if cols.size == 0 or rows.size == 0:
        raise ValueError(f"region x {b[0]:g}..{b[1]:g}, y {b[2]:g}..{b[3]:g} m holds no pixel of the image "
                         f"(x {x[0]:g}..{x[-1]:g}, y {y[0]:g}..{y[-1]:g} m)")
    return slice(int(rows[0]), int(rows[-1]) + 1), slice(int(cols[0]), int(cols[-1]) + 1)
