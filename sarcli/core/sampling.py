"""How a collection is sampled in frequency, and how range profiles are resampled.

The one home for:

* "equally spaced frequencies": the least-squares frequency line ``α_pj ≈ α_ref,p + (j - j_c) Δα_p``
  (:func:`frequency_line`), the deviation of a pulse's frequencies from it
  (:func:`spacing_deviation`) and the one tolerance every consumer applies
  (:data:`SPACING_TOLERANCE`, :func:`equally_spaced`): backprojection, ffbp, the planner's error
  model, CPHD export and the noise estimate of the automatic λ;
* range wavenumbers ``k = 4π α / c`` (:func:`range_wavenumbers`; the projected wavenumbers of
  eq. ``k-values`` are :func:`sarcli.core.geometry.wavenumbers`);
* the interpolators that read range profiles and polar grids (:data:`INTERPOLATORS`): their names,
  the codes the compiled kernels know them by, and their taps.

Transmit and receive positions come from one place too, :meth:`sarcli.core.Acquisition.range_geometry`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SarcliInputError
from .geometry import C

__all__ = ["SPACING_TOLERANCE", "frequency_line", "spacing_deviation", "equally_spaced", "range_wavenumbers",
           "Interpolator", "INTERPOLATORS", "PROFILE_INTERPOLATORS"]

#: Largest deviation of a pulse's frequencies from its least-squares line, as a fraction of the
#: step Δα, for the frequencies to count as equally spaced. A deviation δ costs at most π δ/Δα rad
#: of phase inside the unambiguous range window ``c / (2 Δα)`` (0.006 rad at the tolerance); float32
#: files such as GOTCHA round their frequencies by about 3e-4 of a step.
SPACING_TOLERANCE = 2e-3

#: Pulses per block when a [P, M] table is checked, so that no [P, M] temporary is made.
_ROWS = 256


def _rows(freq_hz) -> np.ndarray:
    f = np.asarray(freq_hz, dtype=np.float64)
    return f[None, :] if f.ndim == 1 else f


def frequency_line(freq_hz, jc=None):
    """Least-squares line ``α_j ≈ α_ref + (j - jc) Δα`` through each row of ``freq_hz``.

    Range profiles by FFT place sample j at ``α_ref + (j - jc) Δα``; a deviation ``δ_j`` costs the
    phase ``4π δ_j Δr / c`` at differential range ``Δr``. The least-squares line minimises the
    sum of the squared deviations (the mean squared phase error over the band), where a line
    through the end samples is set by their two deviations alone (on GOTCHA, whose frequencies are
    rounded to float32, backprojection's error against the exact matched filter is 2.1e-4 with
    this line and 3.0e-4 with the end points').

    Parameters
    ----------
    freq_hz : array_like, shape (M,) or (rows, M)
        Frequencies (Hz).
    jc : float, optional
        Reference sample; default ``M // 2``, the sample the profiles' FFT puts at slot 0.

    Returns
    -------
    alpha_ref, dalpha : ndarray, shape (rows,)
        The line's value at ``jc`` and its slope (Hz), one per row (one row for 1-D input).
    """
    f = _rows(freq_hz)
    m = f.shape[1]
    jc = m // 2 if jc is None else jc
    j = np.arange(m) - (m - 1) / 2.0
    mean = f.mean(axis=1)
    slope = (f @ j) / (j @ j) if m > 1 else np.zeros_like(mean)
    return mean + slope * (jc - (m - 1) / 2.0), slope


def spacing_deviation(freq_hz):
    """How far each row of ``freq_hz`` is from equally spaced.

    Returns
    -------
    worst : float
        Largest ``|α_j - line_j| / |Δα|`` over all rows and samples (``inf`` when a row's step is
        zero; 0 for fewer than two frequencies), the line being :func:`frequency_line`'s.
    rms_hz : float
        Root-mean-square deviation (Hz) over all samples, the planner's frequency-error input.
    """
    f = _rows(freq_hz)
    m = f.shape[1]
    if m < 2:
        return 0.0, 0.0
    worst, sq = 0.0, 0.0
    for r in range(0, f.shape[0], _ROWS):
        blk = f[r:r + _ROWS]
        ref, step = frequency_line(blk, 0)
        dev = blk - (ref[:, None] + np.arange(m) * step[:, None])
        sq += float(np.sum(dev * dev))
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.abs(dev) / np.abs(step)[:, None]
        worst = max(worst, float(np.max(rel)) if np.all(step != 0) else np.inf)
    return worst, float(np.sqrt(sq / f.size))


def equally_spaced(freq_hz, who: str, *, remedy: str = "use method 'direct'", increasing: bool = False):
    """Check that every row of ``freq_hz`` is equally spaced; return its least-squares line.

    Parameters
    ----------
    freq_hz : array_like, shape (M,) or (rows, M)
    who : str
        What needs the spacing, named in the error.
    remedy : str
        What the user can do instead, appended to the error.
    increasing : bool
        Also require increasing frequencies (a positive step).

    Returns
    -------
    alpha_ref, dalpha : ndarray, shape (rows,)
        :func:`frequency_line` at ``jc = M // 2``.

    Raises
    ------
    SarcliInputError
        Fewer than two frequencies, a repeated frequency, a deviation above
        :data:`SPACING_TOLERANCE`, or (``increasing``) a decreasing row: one line naming ``who``,
        the deviation and the tolerance.
    """
    f = _rows(freq_hz)
    tail = f"; {remedy}" if remedy else ""
    if f.shape[1] < 2:
        raise SarcliInputError(f"{who} needs at least two frequencies per pulse{tail}")
    alpha_ref, dalpha = frequency_line(f)
    if not np.all(dalpha != 0):
        raise SarcliInputError(f"{who} needs equally spaced frequencies in every pulse (a pulse has one "
                               f"frequency repeated){tail}")
    if increasing and not np.all(dalpha > 0):
        raise SarcliInputError(f"{who} needs increasing frequencies in every pulse{tail}")
    worst, _ = spacing_deviation(f)
    if not worst <= SPACING_TOLERANCE:
        raise SarcliInputError(f"{who} needs equally spaced frequencies in every pulse (largest deviation "
                               f"{worst:.3g} of the spacing, tolerance {SPACING_TOLERANCE:g}){tail}")
    return alpha_ref, dalpha


def range_wavenumbers(freq_hz) -> np.ndarray:
    """Two-way range wavenumbers ``k = 4π α / c`` (rad/m) of frequencies ``α`` (Hz), any shape."""
    return (4.0 * np.pi / C) * np.asarray(freq_hz, dtype=np.float64)


@dataclass(frozen=True)
class Interpolator:
    """An interpolator of range profiles or polar grids.

    Attributes
    ----------
    name : str
        Its name in the API and on the command line.
    code : int
        The code the compiled kernels (``src/native``) know it by.
    taps : int
        Samples it reads per output value (per dimension).
    """

    name: str
    code: int
    taps: int


#: Every interpolator, by name: linear (2 taps), Keys cubic (4, ``a = -1/2``), Lanczos-3 (6), ffbp's
#: ``optimal`` 6-tap kernel designed for the oversampling at hand (:mod:`sarcli.formers.ffbp.model`)
#: and the cubic Lagrange polynomial through 4 samples (``lagrange``: exact for cubics, so its error
#: at a frequency ν cycles a sample falls as ν⁴ where Keys' falls as ν³).
INTERPOLATORS = {i.name: i for i in (Interpolator("linear", 0, 2), Interpolator("cubic", 1, 4),
                                     Interpolator("lanczos", 2, 6), Interpolator("optimal", 3, 6),
                                     Interpolator("lagrange", 4, 4))}
#: The interpolators backprojection offers (``optimal`` is designed per level, for ffbp only).
PROFILE_INTERPOLATORS = ("linear", "cubic", "lanczos", "lagrange")
