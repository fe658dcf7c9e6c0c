"""Minimum-entropy autofocus, coarse to fine on sub-aperture images, with a cross-validated decision.

The image of the data corrected by ``φ`` is ``f(φ) = Σ_p e^{-iφ_p} b_p`` (``b_p``: pulse ``p``
backprojected) and its entropy ``H(φ) = -Σ_s q_s ln q_s`` (``q_s = |f_s|²/Σ|f|²``). On
sub-apertures of ``K`` consecutive pulses with a phase ``θ_b`` each (the block mean of ``φ``),
``f = Σ_b e^{-iθ_b} F_b`` and the exact gradient costs one product with the stack of the ``⌈P/K⌉``
sub-aperture images (:class:`~sarcli.autofocus._imager.BlockImager`); ``K = 1`` on small cases (one
phase per pulse), larger on large grids so that the stack stays within ``max_stack_mib``. The
estimate returned is constant over each sub-aperture: the phase the images were exact for.
(:class:`~sarcli.autofocus._imager.Imager` gives the same entropy and per-pulse gradient from one
backprojection and one reprojection, without any stack.)

Coarse to fine. The correction is searched in nested subspaces, each level started where the
previous one ended, by L-BFGS on ``c`` in ``φ = φ_prev + A c`` (gradient ``Aᵀ ∂H/∂φ``):

1. ``smooth``: a scan over the quadratic phase (:data:`DEFOCUS_SCAN`), then Legendre polynomials
   of degree 2 to ``K`` (``K = min(12, P/8)``) in the pulse index;
2. knots every 16, then every 4 pulses (piecewise-linear interpolation between them);
3. one phase per pulse (one per sub-aperture when ``K > 1``, which replaces the levels finer
   than ``K``).

A level whose phase is nearly constant over several sub-apertures runs on the stack with them
summed (:meth:`~sarcli.autofocus._imager.BlockImager.coarsened`). Each level gets at most
``max_iter`` L-BFGS iterations and ``2 max_iter`` evaluations, line searches included, and ends
when an iteration lowers the entropy by less than
:data:`~sarcli.autofocus._lbfgs.LEVEL_FTOL` of it.

Every basis is orthogonal to the constant and to the phase linear in look azimuth: those change
no image magnitude but shift it in cross-range, so they are neither searched nor returned. Each
level's estimate has them removed by a fit to the phase unwrapped across the pulses where that
leaves it nearer zero modulo ``2π`` (:func:`~sarcli.autofocus._levels.without_gauge`): a shift
written with ``2π`` jumps is orthogonal to them as it stands. Estimates are averaged modulo ``2π``.

The entropy is measured on the whole image grid, at full resolution up to
:data:`~sarcli.autofocus._common.MAX_ESTIMATION_PIXELS` pixels (a central window beyond), widened by a guard band on small grids
(:func:`~sarcli.autofocus._common.guarded_grid`: on a window that just holds a point scene a phase
error can lower the entropy by pushing sidelobes out of the window).

The metric. The entropy minimised is Rényi's of order ``α``, ``H_α = ln(Σ q^α)/(1 - α)``
(Shannon's at ``α = 1``): lower orders weigh the dim pixels more, and their minimum lies closer to
the true phase among clutter and farther from it on a scene of isolated points. By default
(``order='auto'``) each half of the scene (below) is searched with ``α = 1`` and, again from
zero, with ``α = 1/2`` (the four searches side by side on threads); the order whose two halves
agree more on the detail of the finest level (correlation of the last level's increments) is
used from there on: what a metric fits to one half's own clutter or sidelobes is not found in
the other half.

The decision: cross-validation on disjoint halves of the scene. The grid is split across range
(near and far halves, each holding whole cross-range lines, with a band between them: a phase
error moves energy only in cross-range) and the same coarse-to-fine search is run on each half
alone, from zero. Each level's estimate from one half is applied to the *other* half: a real
phase error is common to the whole scene and lowers the entropy of the half it was not estimated
on, whereas what an estimate fits to one half's own clutter and noise is independent of the
other half and, applied there, blurs it. A level passes when both held-out gains are positive
*and* the two halves' estimates correlate beyond chance
(:func:`~sarcli.autofocus._common.agreement_threshold`, ``2/√dof``): on sparse scenes either can
happen alone (a point's sidelobes pushed out of both halves' windows give well-correlated
estimates that blur the other half; a large held-out gain on one half can come with a loss on the
other). The level kept is the passing one with the largest total
held-out gain; a finer passing level is then taken when the detail the halves add to it
correlates above ``max(1/3, 2/√dof)`` (:data:`REFINE_CORRELATION`). None passes: no correction.
The whole grid is then searched at that level only, from the mean of the halves' estimates
there. One phase per pulse beyond the sub-apertures is searched on each half (exact
backprojection pair, on every other range line: whole cross-range lines, half the pixels), from
its estimate at the level kept or from zero when none was (an error from pulse to pulse can be
all there is), after a level of finer knots where the sub-apertures hold three of its knots or
more, and kept when each half's increment lowers the other half's entropy and the increments
agree (same test); the whole grid's estimate is then its sub-aperture estimate
plus the mean of the halves' increments. The halves' estimates at the level applied then predict
the whole grid's residual (:func:`~sarcli.autofocus._levels.predicted_residual`: half the rms of
their difference, the noise of their mean, plus how far the whole grid's estimate lies from that
mean); where that is not below the error they are sure of (``√⟨a, b⟩`` less two standard errors)
nothing is applied (``result.code`` ``'untrusted'``): two halves can agree beyond ``1/3`` and
still hold very unequal noise, one of them much further from the truth than the other, and then
their mean and the whole grid's estimate are too (a white error on speckle on a climbing path:
halves 0.46 and 0.13 rad rms from the truth, the whole grid's estimate 0.28 of an injected 0.23).
Finally the estimate is applied only if it leaves the image no less sharp (Shannon entropy not up, peak-to-mean not down), both on the guarded grid and
on the grid asked for. A grid whose guarded grid is too narrow across range to split in two halves
is an input error that names it and the pixels it needs
(:func:`~sarcli.autofocus._imager.check_splittable`).
"""


from __future__ import annotations

from dataclasses import dataclass

from .._util.options import with_options
from ..core.grid import Grid
from ._common import AutofocusResult
from ._imager import single_threaded_blas
from ._levels import LEVELS, level_basis
from ._run import ORDERS, REFINE_CORRELATION, MinEntropyRun
from ._search import DEFOCUS_SCAN, coarse_to_fine

__all__ = ["min_entropy", "MinEntropyOptions", "coarse_to_fine", "level_basis", "LEVELS", "DEFOCUS_SCAN", "ORDERS",
           "REFINE_CORRELATION"]


@dataclass(frozen=True)
class MinEntropyOptions:
    """The knobs of :func:`min_entropy` (each also a keyword argument of it).

    Attributes
    ----------
    start : 'zero', 'pga' or array_like
        Start of the search on the whole grid: no correction (default; the smooth level finds
        what PGA would), PGA's estimate where it lowers the entropy, or a given estimate. The
        halves always start from zero, so that their estimates are independent.
    levels : sequence
        The levels of :func:`coarse_to_fine` (default :data:`LEVELS`); those finer than the
        sub-apertures are replaced by the sub-aperture level.
    max_iter, pulse_iter : int
        L-BFGS iterations per level on the sub-apertures, and at one phase per pulse beyond them
        (on each half, on the exact backprojection pair, :class:`~sarcli.autofocus._imager.Imager`:
        two images per evaluation, no stack; 0 skips that level).
    pulse_lines : int
        The level of one phase per pulse beyond the sub-apertures runs on every
        ``pulse_lines``-th range line of each half
        (:func:`~sarcli.autofocus._imager.every_nth_line`: whole cross-range lines; 1: all).
    full_pulse_iter : int
        L-BFGS iterations at one phase per pulse on the whole grid, from its sub-aperture estimate
        plus the mean of the halves' per-pulse increments (0: that start is the estimate).
    max_blocks, max_stack_mib : int, float
        Most sub-aperture images held, and most memory for them (MiB): the sub-apertures have
        ``K = max(⌈P / max_blocks⌉, ⌈P · image bytes / max_stack_mib⌉)`` pulses
        (:class:`~sarcli.autofocus._imager.BlockImager`), and the estimate is constant over each.
    validate : bool
        Keep only the levels that pass the cross-validation (module docstring); without it the
        finest level is taken.
    guard : bool
        Keep the estimate only when it leaves the image no less sharp.
    pga_options : PGAOptions or dict, optional
        PGA's knobs for ``start='pga'`` (:class:`~sarcli.autofocus.pga.PGAOptions`, or a dict of
        its fields).
    order : 'auto' or float
        Order of the Rényi entropy minimised (:func:`~sarcli.autofocus._imager.entropy_of`; 1 is
        Shannon's). Orders below 1 weigh dim pixels more: their minimum lies closer to the true
        phase among clutter and farther from it on scenes of isolated points. ``'auto'``: each
        half is searched with Shannon's entropy and, again from zero, with order ``1/2``
        (:data:`ORDERS`; the searches side by side on threads), and the order whose halves agree
        more on the detail of the finest level is used from there on (module docstring). The
        sharpness guard measures Shannon's entropy whatever the order.
    """

    start: object = "zero"
    levels: tuple = LEVELS
    max_iter: int = 15
    pulse_iter: int = 3
    pulse_lines: int = 2
    full_pulse_iter: int = 0
    max_blocks: int = 128
    max_stack_mib: float = 64.0
    validate: bool = True
    guard: bool = True
    pga_options: object = None
    order: object = "auto"


def min_entropy(ph, *, grid: Grid | None = None, options: MinEntropyOptions | None = None,
                **knobs) -> AutofocusResult:
    """Minimum-entropy autofocus: coarse to fine to one phase per pulse, cross-validated.

    Parameters
    ----------
    ph : PhaseHistory
    grid : Grid, optional
        The image grid (default the acquisition's); the entropy is measured on all of it, at
        most :data:`~sarcli.autofocus._common.MAX_ESTIMATION_PIXELS` pixels (a central window beyond), widened by a guard band
        where that stays within :data:`~sarcli.autofocus._common.MAX_GUARDED_PIXELS`.
    options : MinEntropyOptions, optional
        The knobs (default ``MinEntropyOptions()``).
    **knobs
        Fields of :class:`MinEntropyOptions` given as keyword arguments
        (``min_entropy(ph, max_blocks=32)``); they replace those of ``options``.

    Returns
    -------
    AutofocusResult
        ``history`` records the start, the whole grid's entropy at the mean of the halves'
        estimates per level, the held-out gains and the correlation between the halves per level,
        the level kept (``'level'``; ``'block_level'`` the one kept on the sub-apertures, None
        when none passed), whether one phase per pulse was searched and kept (``'pulse_level'``:
        ``kept``, ``from_zero``), the estimation grid's pixel (``'estimation_pixel_m'``), the
        sharpness (entropy, peak-to-mean) before and after on the guarded grid and on the grid
        asked for (``'guarded_sharpness'``, ``'asked_sharpness'``) and why (``'decision'``).
    """
    from ._lbfgs import find_setulb

    o = with_options(MinEntropyOptions, options, knobs)
    # L-BFGS-B's BLAS (scipy's own OpenBLAS) is loaded first, so that the one-thread limit reaches
    # it too: its idle threads spin after every call, on cores shared with other jobs
    find_setulb()
    with single_threaded_blas():
        run = MinEntropyRun(ph, grid, o)
        run.choose_start()
        run.search_halves()
        run.choose_level()
        run.search_whole()
        run.describe()
        run.per_pulse()
        return run.result()  # its warnings name the caller of min_entropy (stacklevel 3)
