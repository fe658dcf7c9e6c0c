"""One run of minimum-entropy autofocus, step by step (:class:`MinEntropyRun`): the start, the
halves' searches and the entropy's order, the level kept, the whole grid, the decision's words, one
phase per pulse and the checks of the result. The method, its decision and its options are
described in :mod:`sarcli.autofocus.entropy`, whose :func:`~sarcli.autofocus.entropy.min_entropy`
runs the steps in order."""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import SarcliInputError
from ._common import (MAX_ESTIMATION_PIXELS, MAX_GUARDED_PIXELS, AutofocusResult, AutofocusWarning,
                      agreement_threshold, correlation, estimation_grid, guarded_grid, sharpness)
from ._imager import SPLIT_GAP, BlockImager, Imager, check_splittable, every_nth_line, range_axis, split_grid
from ._levels import dof, gauge_basis, phase_mean, predicted_residual, spacing, without_gauge
from ._search import coarse_to_fine, each
from ._sharpness import sharpness_imager

__all__ = ["MinEntropyRun", "ORDERS", "REFINE_CORRELATION", "orders_of", "block_size", "heldout"]

#: Orders of the Rényi entropy tried by ``order='auto'``, each on all levels of both halves.
ORDERS = (1.0, 0.5)


def block_size(P: int, max_blocks: int) -> int:
    """Pulses per sub-aperture for at most ``max_blocks`` of them."""
    return max(1, -(-P // max_blocks))


def heldout(halves, paths):
    """Per level, the held-out entropy gains (each half's estimate applied to the other half,
    against no correction) and the correlation of the two halves' estimates."""
    P = len(paths[0][0])
    h0 = [im.entropy(np.zeros(P)) for im in halves]
    gains = [(h0[0] - halves[0].entropy(b), h0[1] - halves[1].entropy(a)) for a, b in zip(*paths)]
    return gains, [correlation(a, b) for a, b in zip(*paths)]


#: Least correlation of the detail two halves add at a finer level for that level to be taken:
#: with ``ρ = s/(s + n)`` (``s`` the common detail's power, ``n`` one half's estimation noise),
#: the whole scene's estimate (noise about ``n/2``) gains from the detail when ``s > n/2``, i.e.
#: ``ρ > 1/3``.
REFINE_CORRELATION = 1.0 / 3.0


def orders_of(order) -> tuple:
    """The Rényi orders searched for ``order`` (:data:`ORDERS` for ``'auto'``); anything but a
    positive number is an input error."""
    if order == "auto":
        return ORDERS
    try:
        orders = (float(order),)
    except (TypeError, ValueError):
        orders = (float("nan"),)
    if not orders[0] > 0:
        raise SarcliInputError(f"entropy order must be 'auto' or a positive number, got {order!r}")
    return orders


class MinEntropyRun:
    """One run of :func:`~sarcli.autofocus.entropy.min_entropy`, one method a step of the module docstring (the start, the
    halves' searches and the order, the level, the whole grid, the decision's words, one phase per
    pulse, the checks of the result); its attributes are what a step hands to the next, and
    ``hist`` the result's history."""

    def __init__(self, ph, grid, o):
        self.ph, self.o = ph, o
        self.orders = orders_of(o.order)
        acq = ph.acquisition
        self.asked = asked = grid or acq.grid
        self.est = est = estimation_grid(asked, MAX_ESTIMATION_PIXELS, acq)
        self.P = P = ph.data.shape[0]
        self.gauge = gauge_basis(acq)
        g_est = guarded_grid(est, acq, max_pixels=max(est.nx * est.ny, MAX_GUARDED_PIXELS))
        image_mib = g_est.nx * g_est.ny * 8 / 2 ** 20
        self.K = K = max(block_size(P, o.max_blocks), int(np.ceil(P * image_mib / o.max_stack_mib)))
        coarse = tuple(lv for lv in o.levels if lv == "smooth" or int(lv) > K)
        if any(lv != "smooth" and int(lv) <= K for lv in o.levels):
            coarse += (K,)
        self.coarse, self.names = coarse, [str(lv) for lv in coarse]
        self.axis = range_axis(acq)
        check_splittable(asked, est, g_est, acq, self.axis)
        self.full = BlockImager(ph, g_est, K, self.axis, order=self.orders[0])
        self.halves = self.full.halves()
        self.hist: dict = {"levels": [str(lv) for lv in coarse], "block_pulses": K,
                           "estimation_grid": [est.ny, est.nx], "guarded_grid": [self.full.grid.ny, self.full.grid.nx]}
        self.zero = np.zeros(P)
        self.fine_imagers = []

    def choose_start(self) -> None:
        """The whole grid's start ``phi0``: zero, PGA's estimate where it lowers the entropy, or the
        one given (gauge removed)."""
        o, full, gauge, hist = self.o, self.full, self.gauge, self.hist
        self.phi0, hist["start"] = self.zero, "zero"
        if isinstance(o.start, str) and o.start == "pga":
            from .pga import PGAOptions, pga

            po = o.pga_options
            if isinstance(po, PGAOptions):
                cand = pga(self.ph, grid=self.est, options=po, guard=False).phase_rad
            else:
                cand = pga(self.ph, grid=self.est, guard=False, **(po or {})).phase_rad
            cand = cand - gauge @ (gauge.T @ cand)
            if full.entropy(cand) < full.entropy(self.zero):
                self.phi0, hist["start"] = cand, "pga"
            else:
                hist["start"] = "zero (pga did not lower the entropy)"
        elif not isinstance(o.start, str):
            phi0 = np.asarray(o.start, np.float64)
            self.phi0, hist["start"] = phi0 - gauge @ (gauge.T @ phi0), "given"

    def search_halves(self) -> None:
        """Each half with each order, from zero (``paths``), and the order ``chosen``: the one
        whose halves agree more on the detail of the finest level."""
        P, orders, coarse, hist = self.P, self.orders, self.coarse, self.hist
        # independent searches, side by side on threads (a pass over the stack runs on one thread
        # and releases the GIL)
        for im in self.halves:  # the merged stacks, built before the threads share them
            for lv in coarse:
                im.coarsened(spacing(lv, P))
        runs = each(lambda im: coarse_to_fine(im, self.zero, self.gauge, coarse, self.o.max_iter),
                    [im.with_order(o) for o in orders for im in self.halves])
        by_order = {o: runs[2 * k:2 * k + 2] for k, o in enumerate(orders)}
        chosen, hist["order"] = orders[0], orders[0]
        if len(orders) > 1:
            # the order whose halves agree more on the detail of the finest level is the one less
            # drawn to what is particular to each half (clutter, or the sidelobes of a few points)
            def detail(ps):
                return correlation(*(p[-1] - (p[-2] if len(p) > 1 else 0.0) for p in ps))

            agree = {o: detail(by_order[o]) for o in orders}
            for o in orders[1:]:
                if agree[o] > agree[chosen]:
                    chosen = o
            self.halves = [im.with_order(chosen) for im in self.halves]
            hist["order"], hist["order_agreement"] = chosen, {str(k): v for k, v in agree.items()}
        self.chosen, self.paths = chosen, by_order[chosen]
        self.full = self.full.with_order(chosen)

    def choose_level(self) -> None:
        """The level kept (``best``; ``kept`` False when none passes): the passing one of largest
        total held-out gain, refined to a finer passing one whose added detail the halves agree
        on."""
        validate, paths, coarse = self.o.validate, self.paths, self.coarse
        self.gains, self.corrs = gains, corrs = heldout(self.halves, paths)
        self.dofs = dofs = [dof(lv, self.P, self.gauge) for lv in coarse]
        # a level passes when each half's estimate lowers the other half's entropy and the two
        # halves' estimates agree beyond chance; the one kept has the largest total held-out gain
        passed = [min(g) > 0 and c > agreement_threshold(n) for g, c, n in zip(gains, corrs, dofs)]
        self.score = score = [sum(g) if ok else -np.inf for g, ok in zip(gains, passed)]
        best = int(np.argmax(score)) if validate else len(coarse) - 1
        self.kept = kept = validate is False or np.isfinite(score[best])
        self.refined = []
        if validate and kept:
            # a finer level that passes is taken when the detail each half adds to the level kept
            # agrees between the halves: a half's held-out gain undervalues it (the whole scene
            # estimates that detail with half a half's noise, REFINE_CORRELATION)
            for j in range(best + 1, len(coarse)):
                rho = correlation(paths[0][j] - paths[0][best], paths[1][j] - paths[1][best])
                if passed[j] and rho > max(REFINE_CORRELATION, agreement_threshold(dofs[j])):
                    best = j
                    self.refined.append(f"{self.names[j]} (the detail it adds correlates {rho:.2f} between the halves)")
        self.best = best

    def search_whole(self) -> None:
        """The whole grid's estimate ``phi`` at the level kept (zero when none is)."""
        best, coarse, max_iter = self.best, self.coarse, self.o.max_iter
        self.phi = self.zero
        if self.kept and np.any(self.phi0):
            self.phi = coarse_to_fine(self.full, self.phi0, self.gauge, coarse[:best + 1], max_iter)[-1]
        elif self.kept:
            # the whole grid searches the level kept only, from the mean of the halves' estimates
            # at that level (the coarser levels have brought each half there already)
            start = phase_mean(self.paths[0][best], self.paths[1][best])
            self.phi = coarse_to_fine(self.full, start, self.gauge, coarse[best:best + 1], max_iter,
                                      max_fun=max_iter)[-1]

    def describe(self) -> None:
        """The history of the halves' searches and the decision's words so far."""
        hist, paths, coarse, names, gains, corrs = self.hist, self.paths, self.coarse, self.names, self.gains, self.corrs
        full, best, kept = self.full, self.best, self.kept
        hist.update(entropy_start=full.entropy(self.phi0),
                    entropy_levels=[full.entropy(phase_mean(a, b)) for a, b in zip(*paths)],
                    heldout_gain=gains, halves_correlation=corrs, level=names[best] if kept else None,
                    detail_correlation=[correlation(*(p[j] - (p[j - 1] if j else 0.0) for p in paths))
                                        for j in range(len(coarse))])
        if not self.o.validate:
            hist["decision"] = f"finest level {names[-1]} (not cross-validated)"
        elif not kept:
            hist["decision"] = (f"no error common to the scene{' at the sub-apertures' if self.K > 1 else ''}: at no "
                                "level did the estimates from the two halves of the scene both lower the other half's "
                                "entropy and agree beyond chance")
        else:
            first = int(np.argmax(self.score))
            hist["decision"] = (f"level {names[first]}: its estimates from each half of the scene lower the "
                                f"entropy of the other half the most (held-out gains {gains[first][0]:.4f}, "
                                f"{gains[first][1]:.4f} nats; halves' estimates correlate {corrs[first]:.2f}, "
                                f"chance {agreement_threshold(self.dofs[first]):.2f})")
            if self.refined:
                hist["decision"] += "; refined to level " + ", then ".join(self.refined)
        if self.o.validate and len(self.orders) > 1:
            agree = hist["order_agreement"]
            hist["decision"] = (f"Rényi entropy of order {self.chosen:g} (the halves' finest detail correlates "
                                + ", ".join(f"{v:.2f} with order {k.rstrip('0').rstrip('.')}" for k, v in agree.items())
                                + "); " + hist["decision"])
        hist["block_level"] = hist["level"]  # the level kept on the sub-apertures (None: none passed)
        self.judge = full  # the images the estimate is exact for
        # the halves' own estimates at the level applied (the prediction of its residual compares them)
        self.pair = (paths[0][best], paths[1][best]) if kept else None

    def per_pulse(self) -> None:
        """One phase per pulse, beyond the sub-apertures, on the exact backprojection pair (no
        stack) on every ``pulse_lines``-th range line of each half (whole cross-range lines): each
        half refines its own estimate at the level kept (from zero when none was: an error from
        pulse to pulse can be all there is), and the level is kept when each half's per-pulse
        increment lowers the other half's entropy and the increments agree."""
        o, P, K, gauge, hist, kept = self.o, self.P, self.K, self.gauge, self.hist, self.kept
        if not (K > 1 and o.pulse_iter > 0 and any(lv != "smooth" and int(lv) < K for lv in o.levels)):
            return
        low, high = split_grid(every_nth_line(self.full.grid, self.axis, o.pulse_lines), self.axis, SPLIT_GAP)[:2]
        # the range profiles of the stack's backprojector, made once
        sides = [Imager(self.ph, g, self.chosen, like=self.full) for g in (low, high)]
        starts = [p[self.best] if kept else self.zero for p in self.paths]
        # a finer level of knots first where the sub-apertures hold three of its knots or more: one
        # phase per pulse alone, in a few iterations, leaves much of a smooth error within them
        fine = tuple(lv for lv in o.levels if lv != "smooth" and 1 < int(lv) and 3 * int(lv) <= K) + (1,)
        ends = [coarse_to_fine(im, s0, gauge, fine, o.pulse_iter)[-1] for im, s0 in zip(sides, starts)]
        # on the half's lines, the other half's start against its per-pulse estimate
        g1 = tuple(side.entropy(starts[1 - i]) - side.entropy(ends[1 - i]) for i, side in enumerate(sides))
        # each half's increment, continuous across the pulses (2π jumps between the start's and
        # the end's representations undone; a smooth increment of any size kept)
        steps = [np.unwrap(e - s0) for e, s0 in zip(ends, starts)]
        c1 = correlation(*steps)
        self.fine_imagers += sides
        hist["heldout_gain"] = self.gains + [g1]
        hist["halves_correlation"] = self.corrs + [c1]
        hist["levels"] = self.names + ["1"]
        what = ("increment", "increments") if kept else ("estimate (from zero)", "estimates (from zero)")
        ok = bool(min(g1) > 0 and c1 > max(REFINE_CORRELATION, agreement_threshold(P - gauge.shape[1])))
        hist["pulse_level"] = {"kept": ok, "from_zero": not kept}
        if ok:
            # the whole grid: from its sub-aperture estimate plus the mean of the halves'
            # per-pulse increments, a few more iterations on all of it
            exact = Imager(self.ph, self.full.grid, self.chosen, like=self.full)
            self.fine_imagers.append(exact)
            start1 = without_gauge(self.phi + phase_mean(steps[0], steps[1]), gauge)
            if o.full_pulse_iter > 0:
                start1 = coarse_to_fine(exact, start1, gauge, (1,), o.full_pulse_iter)[-1]
            self.phi, self.judge, hist["level"] = start1, exact, "1"
            self.pair = tuple(ends)
            hist["decision"] += (f"; {'then ' if kept else 'but at '}one phase per pulse: each half's per-pulse "
                                 f"{what[0]} lowers the other half's entropy ({g1[0]:.4f}, {g1[1]:.4f} nats; "
                                 f"correlation {c1:.2f})")
        else:
            hist["decision"] += (f"; one phase per pulse not kept: the halves' per-pulse {what[1]} (held-out gains "
                                 f"{g1[0]:.4f}, {g1[1]:.4f} nats; correlation {c1:.2f}) do not both lower the "
                                 f"other half's entropy and agree")

    def result(self) -> AutofocusResult:
        """The result: the estimate, its predicted residual and sharpness, applied only when the
        halves trust it and it leaves the image no less sharp (``guard``); warnings name the
        caller of :func:`~sarcli.autofocus.entropy.min_entropy`."""
        phi, hist, est, asked, full, guard = self.phi, self.hist, self.est, self.asked, self.full, self.o.guard
        hist["estimation_pixel_m"] = [est.dx, est.dy]
        if (est.dx, est.dy) != (asked.dx, asked.dy):
            hist["decision"] = (f"estimated on {est.nx} x {est.ny} pixels of {est.dx:.3g} x {est.dy:.3g} m, the "
                                f"grid's {asked.dx:.3g} x {asked.dy:.3g} m being too coarse for the image's band; "
                                + hist["decision"])
        if self.pair is not None and np.any(phi):
            hist["trust"] = predicted_residual(phi, *self.pair, self.gauge)
        hist["evaluations"] = evals = full.evaluations + sum(im.evaluations
                                                             for im in [*self.halves, *self.fine_imagers])
        res = AutofocusResult(phi, "min-entropy", iterations=evals, history=hist)
        # the uncorrected image from the stack (exact for a zero phase; sharpness ignores pixel order)
        (h0, m0), (h1, m1) = sharpness(full.image(self.zero)), sharpness(self.judge.image(phi))
        hist["guarded_sharpness"] = {"before": (h0, m0), "after": (h1, m1)}
        # what is reported, and judged last: the images of the grid asked for (the estimation grid),
        # formed as PGA forms them (sharpness_imager), so both methods report the same numbers
        mine = sharpness_imager(self.ph, est, like=full)
        (u0, n0), (u1, n1) = sharpness(mine.image(self.zero)), sharpness(mine.image(phi))
        res.entropy_before, res.peak_to_mean_before = u0, n0
        res.entropy_after, res.peak_to_mean_after = u1, n1
        hist["asked_sharpness"] = {"before": (u0, n0), "after": (u1, n1)}
        trust = hist.get("trust")
        if not np.any(phi):
            res.code = "no_common_error"
        if self.o.validate and trust is not None and not trust["trusted"]:
            # the halves' own estimates at the level applied: their spread plus the whole scene's
            # departure from their mean is the residual they predict, and it is not below the least
            # error they are sure of (predicted_residual)
            why = (f"the halves predict it leaves {trust['predicted_rad']:.3f} rad rms (spread "
                   f"{trust['spread_rad']:.3f} + departure {trust['departure_rad']:.3f}), not below the "
                   f"{trust['signal_low_rad']:.3f} rad rms of error they are sure of")
            res.reject(f"; but {why}: not applied", code="untrusted")
            warnings.warn(f"autofocus (min-entropy) applied no correction: {why}", AutofocusWarning, stacklevel=3)
        elif guard and np.any(phi) and not (h1 < h0 and m1 >= m0):
            # never less sharp, on the images the estimate was made on (exact for its block phases)
            res.reject("; but it left the image less sharp (entropy or peak-to-mean): not applied")
            warnings.warn(f"autofocus (min-entropy) did not sharpen the image (entropy {h0:.4f}, peak-to-mean "
                          f"{m0:.4g} before): no correction applied", AutofocusWarning, stacklevel=3)
        elif guard and np.any(phi) and not (u1 < u0 and n1 >= n0):
            # and on the grid asked for, inside the guard band: on a grid of a few pixels a search
            # can sharpen the band by moving energy that the grid itself loses
            which = f"{est.nx} x {est.ny} pixel " + (
                "grid asked for" if (est.dx, est.dy) == (asked.dx, asked.dy) else "estimation grid")
            res.reject(f"; but it left the {which} less sharp (entropy {u0:.4f} -> {u1:.4f}, peak-to-mean "
                       f"{n0:.4g} -> {n1:.4g}): not applied")
            warnings.warn(f"autofocus (min-entropy) did not sharpen the {which} (entropy {u0:.4f}, peak-to-mean "
                          f"{n0:.4g} before): no correction applied", AutofocusWarning, stacklevel=3)
        return res
