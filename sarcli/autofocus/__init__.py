"""Autofocus: estimate per-pulse phase errors from the data and remove them.

A phase history with an unknown per-pulse phase error ``ε_p`` (platform motion not measured to a
fraction of a wavelength) is ``d[p, j] = d0[p, j] · exp(i ε_p)``; its image blurs in cross-range.
Autofocus estimates ``ε̂`` and returns ``d · exp(-i ε̂_p)`` with the estimate recorded
(``/autofocus/phase_rad`` and its ``method``, docs/conventions.md).

What the data cannot tell
-------------------------
A constant phase changes no image magnitude, and a phase linear in the look angle only shifts
the image in cross-range (a scene has no absolute position in its own data). Neither is
observable, so every estimate here is returned with its constant and linear part (least-squares
fit against look azimuth) removed; comparisons with a known error must remove them too
(:func:`remove_linear_phase`).

Methods
-------
``pga``
    Phase gradient autofocus (:mod:`sarcli.autofocus.pga`): dominant-scatterer selection,
    centre shift, windowing, phase-gradient estimate, integration, iterated to convergence;
    the range samples come from each scatterer's own exact range history, so any flight path
    (and a bistatic one) works.
``min-entropy`` (the default)
    Minimum image entropy (:mod:`sarcli.autofocus.entropy`), coarse to fine on sub-aperture
    images with the entropy's exact gradient; the entropy's order (Shannon's or Rényi's of
    order 1/2) and the level of detail kept are chosen by cross-validation between two
    disjoint halves of the scene (their estimates must sharpen each other and agree).

Both never return a correction that leaves the image less sharp than it was: the result is kept
only when the image entropy does not rise and the peak-to-mean ratio does not fall (measured on
the estimation grid); otherwise the estimate is zero and a warning says so. Nor one that the two
halves of the scene cannot vouch for: their estimates must predict a residual below the error
they find (:func:`~sarcli.autofocus._levels.predicted_residual`). What was applied and why is
recorded (``attrs['autofocus_decision']``, :meth:`AutofocusResult.describe`; the decision's code,
one of :data:`DECISION_CODES`, is ``AutofocusResult.code``).
"""

from __future__ import annotations

from ._common import (DECISION_CODES, AutofocusResult, apply_phase_correction, estimation_grid,
                      remove_linear_phase)

__all__ = ["autofocus", "METHODS", "DEFAULT_METHOD", "AutofocusResult", "DECISION_CODES", "apply_phase_correction",
           "remove_linear_phase", "estimation_grid"]

#: Autofocus methods (``sar autofocus --method``, ``form-image --autofocus``).
METHODS = ("pga", "min-entropy")


#: The method of ``sar autofocus`` and :func:`autofocus` when none is named.
DEFAULT_METHOD = "min-entropy"


def autofocus(ph, method: str = DEFAULT_METHOD, *, grid=None, **options):
    """Estimate and remove per-pulse phase errors.

    Parameters
    ----------
    ph : PhaseHistory
    method : {'pga', 'min-entropy'}
    grid : Grid, optional
        The image grid to focus (default the acquisition's); large grids are cut to a central
        estimation window (:func:`estimation_grid`).
    **options
        Passed to :func:`sarcli.autofocus.pga.pga` or :func:`sarcli.autofocus.entropy.min_entropy`:
        fields of :class:`~sarcli.autofocus.pga.PGAOptions` or
        :class:`~sarcli.autofocus.entropy.MinEntropyOptions`, or ``options=`` one of them.

    Returns
    -------
    corrected : PhaseHistory
        ``data · exp(-i ε̂_p)``, attrs ``autofocus_phase_rad`` (written as ``/autofocus/phase_rad``;
        it accumulates over repeated runs), ``autofocus_method`` and ``autofocus_decision``.
    result : AutofocusResult
    """
    from ..errors import SarcliInputError

    if method not in METHODS:
        raise SarcliInputError(f"unknown autofocus method {method!r}; choose one of {', '.join(METHODS)}")
    if method == "pga":
        from .pga import PGAOptions as Options
        from .pga import pga as estimate
    else:
        from .entropy import MinEntropyOptions as Options
        from .entropy import min_entropy as estimate
    from dataclasses import fields

    known = [f.name for f in fields(Options)] + ["options"]
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise SarcliInputError(f"unknown {method} option {unknown[0]!r}; choose from {', '.join(known)}")
    res = estimate(ph, grid=grid, **options)
    import logging

    decision = res.describe()
    logging.getLogger("sarcli.autofocus").debug(decision)
    return apply_phase_correction(ph, res.phase_rad, method, decision), res
