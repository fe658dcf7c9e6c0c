"""Planning of fast factorised backprojection (:mod:`sarcli.formers.ffbp._image`, whose module docstring
explains it): the stages' layout (:func:`layout_stages`, :class:`StageLayout`), its error floor, and
the complete plan with its deapodization and predicted error (:func:`plan_stages`,
:class:`FfbpPlan`). No data needed: geometry and knobs only."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from ...core.sampling import range_wavenumbers
from ...core.grid import Grid
from ...errors import SarcliInputError
from .model import INTERPOLATORS, NTAPS, angle_interp_error, deapodized_edge_error, deapodized_error
from .model import default_upsample, frequency_error, interp_error, predict_error
from ._grids import level_grid, apertures, band_excess, decide_deapodization, ground_reach
from ._rows import with_rows

#: Default knobs (see docs/ffbp.md for the error-vs-time frontier behind them); ``upsample`` not
#: given is :func:`default_upsample` for ``optimal``, :data:`UPSAMPLE_ANALYTIC` for the others.
DEFAULTS = {"base": 16, "merge": 4, "os_range": 2.0, "os_angle": 2.0, "interp": "optimal"}
#: ``os_range`` tried first when it is not given (``interp='optimal'``): kept where the plan
#: deapodizes the range kernel and its range error is predicted no larger than at the default 2.
OS_RANGE_DEAPODIZED = 1.5
#: ``os_angle`` tried first when it is not given (``interp='optimal'``), on the same terms.
OS_ANGLE_DEAPODIZED = 1.5
#: How far (ratio) the pulses' tones may reach past the polar grids' nominal bands before the
#: grids are sampled finer to hold them (:func:`sarcli.formers.ffbp._grids.band_excess`).
BAND_SLACK = 1.02
#: Profile upsampling of the analytic kernels (only ``optimal``'s profiles are deapodized).
UPSAMPLE_ANALYTIC = 4.0
#: The predicted error of a plan whose polar grids reach past the ground (``|u| > 1``,
#: :func:`sarcli.formers.ffbp._grids.ground_reach`): the error model does not cover it, so no
#: accuracy is promised and ``auto`` picks another method (measured 4.2e-2 where the model gave 1.2e-3).
UNCOVERED_ERROR = 1.0
#: Polar sub-images (bytes) formed at once: the last level's sub-images are formed and imaged in
#: groups whose subtrees fit this (:func:`subtree_groups`), so memory does not grow with the pulses.
SUBTREE_BYTES = 256 * 2 ** 20
#: The polar frames hold the grid grown by this many pixels on every side.
MARGIN_PIXELS = 2
#: A level's grid holds the stencils of every later level, plus this many samples on each side
#: (measured on GOTCHA: the image edges lose nothing down to 0.7 of the stencils' reach, and break
#: at 0.5).
EXTRA_SAMPLES = 1
#: The grid's extension across (u) also holds this fraction of its extension in range, in ground
#: metres.
U_FOR_Q_EXTENSION = 0.2
#: Whether one more merge pays is judged on the merged level's grids extended by this many
#: half-stencils on each side.
MERGE_TEST_EXTENSION = 2


@dataclass
class FfbpPlan:
    """The stages FFBP will run: sizes, operation counts and the predicted error."""

    levels: list
    dq: float
    kref: float
    n_final: int
    ops: dict = field(default_factory=dict)
    knobs: dict = field(default_factory=dict)
    predicted_error: float = float("nan")
    #: whether the range profiles' kernel is deapodized, whether the polar grids' range kernel is
    #: (:func:`plan_stages`), and the error the latter's frequency mismatch is predicted to cost
    profiles_deapodized: bool = False
    range_deapodized: bool = False
    range_mismatch: float = 0.0
    #: and each pulse's tones on every level (cycles per sample per unit wavenumber, [levels, P],
    #: and the range tones' offset; :func:`sarcli.formers.ffbp._grids.decide_deapodization`);
    #: the same for the polar grids' angular kernel
    range_rates: np.ndarray | None = None
    range_offset: float = 0.0
    angle_deapodized: bool = False
    angle_mismatch: float = 0.0
    angle_rates: np.ndarray | None = None
    #: factors (range, angle) by which the grids' bands were widened to hold every pulse's tones
    band_scale: tuple = (1.0, 1.0)

    @property
    def n_stages(self) -> int:
        """Interpolation stages after stage 0: merges plus the final stage."""
        return len(self.levels)


#: The knobs :func:`plan_stages` and :func:`layout_stages` take (None or absent: the default).
KNOBS = ("base", "merge", "os_range", "os_angle", "interp", "upsample", "final")


def _knobs(knobs: dict) -> dict:
    """Every knob of :data:`KNOBS`, None where not given; an unknown one is one line naming it."""
    unknown = sorted(set(knobs) - set(KNOBS))
    if unknown:
        raise SarcliInputError(f"ffbp has no knob {unknown[0]!r} (its knobs: {', '.join(KNOBS)})")
    return {name: knobs.get(name) for name in KNOBS}


def plan_stages(antenna_position_m, freq_hz, grid: Grid, *, receive_position_m=None, **knobs) -> FfbpPlan:
    """The FFBP stages for a geometry (no data needed): levels, operation counts, predicted error
    (:func:`layout_stages`, then :meth:`StageLayout.plan`). ``os_range=None`` with ``optimal``
    kernels: :data:`OS_RANGE_DEAPODIZED`
    where the range kernel is deapodized and its range error (aliases plus frequency mismatch) is
    no larger than the minimax stencil's at the default, else the default; ``os_angle=None``
    likewise with :data:`OS_ANGLE_DEAPODIZED` and the angular kernel. ``upsample=None``:
    :func:`default_upsample` for ``optimal`` (deapodized profiles), :data:`UPSAMPLE_ANALYTIC` for
    the others.
    ``receive_position_m``: separate receive positions (``antenna_position_m`` then transmits).
    ``knobs``: those of :data:`KNOBS` (:func:`ffbp`'s)."""
    kw = _knobs(knobs)
    os_range, os_angle = kw.pop("os_range"), kw.pop("os_angle")
    kw["receive_position_m"] = receive_position_m
    auto = kw["interp"] in (None, "optimal")
    # (oversampling, tentative): a tentative one is kept only where its kernel's deapodization pays
    r_try = ((OS_RANGE_DEAPODIZED, True), (None, False)) if os_range is None and auto else ((os_range, False),)
    a_try = ((OS_ANGLE_DEAPODIZED, True), (None, False)) if os_angle is None and auto else ((os_angle, False),)

    def pays(plan, deapodized, mismatch, os_fine, default):
        # the coarse sampling tried first is kept where its kernel is deapodized and errs no more
        # than the minimax stencil at the default
        n = len(plan.levels)
        return deapodized and n * deapodized_error(os_fine) + mismatch <= n * interp_error("optimal", default)

    for o_r, r_tentative in r_try:
        for o_a, a_tentative in a_try:
            plan = layout_stages(antenna_position_m, freq_hz, grid, os_range=o_r, os_angle=o_a, **kw).plan()
            if ((not r_tentative or pays(plan, plan.range_deapodized, plan.range_mismatch, o_r, DEFAULTS["os_range"]))
                    and (not a_tentative
                         or pays(plan, plan.angle_deapodized, plan.angle_mismatch, o_a, DEFAULTS["os_angle"]))):
                return plan
    return plan


@dataclass(eq=False)
class StageLayout:
    """The stages of a plan short of its error model (:func:`layout_stages`): the sub-apertures of
    every level and their polar frames, then, when first asked for, the polar grids (``levels``)
    and the operation counts (``ops``). :meth:`error_floor` bounds the plan's predicted error from
    below at little cost; :meth:`plan` completes the plan.

    Its fields: the resolved ``knobs``; each level's polar ``frames`` and ``children``; the
    ``apertures``; the polar grids' range spacing ``dq``, reference and largest wavenumbers
    ``kref``, ``kmax`` and their ``band_scale``; and the collection as the error model sees it
    (``freq_hz``, the mean positions ``pos``, the ``grid``)."""

    knobs: dict
    frames: list
    children: list
    apertures: object
    dq: float
    kref: float
    kmax: float
    band_scale: tuple
    freq_hz: np.ndarray
    pos: np.ndarray
    grid: Grid

    @functools.cached_property
    def levels(self) -> list:
        """Every level's polar grids, extended to hold the stencils of the levels after it and of
        the final stage (:func:`layout_stages`)."""
        frames, children, dq = self.frames, self.children, self.dq
        half = NTAPS[INTERPOLATORS[self.knobs["interp"]]] // 2
        n_lev = len(frames)
        levels = []
        for l, fr in enumerate(frames):
            # reach in u of the stencils of this level and of every later one, per sub-aperture:
            # each later level counted at the spacing of the sub-aperture's own ancestor there
            reach = fr.du.copy()
            anc = np.arange(fr.first.size)
            for j in range(l + 1, n_lev):
                anc = np.searchsorted(children[j][0], anc, side="right") - 1
                reach += frames[j].du[anc]
            ext_q = int(math.ceil(half * (n_lev - l))) + EXTRA_SAMPLES
            ext_u = np.ceil(half * reach / fr.du + U_FOR_Q_EXTENSION * ext_q * dq / (fr.metres_per_u * fr.du)
                            ).astype(np.int64) + EXTRA_SAMPLES
            levels.append(with_rows(level_grid(fr, dq, ext_q, ext_u, children[l]), self.apertures.bounds, dq, ext_q,
                                    ext_u))
        return levels

    @functools.cached_property
    def ops(self) -> dict:
        """Operation counts of the stages (:func:`layout_stages`)."""
        levels, merge = self.levels, int(self.knobs["merge"])
        ntap = NTAPS[INTERPOLATORS[self.knobs["interp"]]]
        n_pix = self.grid.nx * self.grid.ny
        P = self.pos.shape[0]
        n_freq = int(np.shape(self.freq_hz)[-1])
        # the nodes formed: each row's that later stencils can read (StageLayout.levels' rows)
        lv0 = levels[0]
        ops = {"stage0": float(np.dot(lv0.grid_nodes, lv0.count)) * ntap, "merge": 0.0,
               "final": float(n_pix) * levels[-1].n * ntap * ntap,
               "nodes": float(max(lv.n * lv.n_u * lv.n_q for lv in levels)),
               "stage0_nodes": lv0.nodes,
               "final_pairs": float(n_pix) * levels[-1].n, "merge_pairs": 0.0,
               # the deapodized kernels' weights: per pulse, sample, level and axis (both axes
               # counted, before the plan decides which it deapodizes)
               "tones": float(P) * n_freq * len(levels) * 2 if self.knobs["interp"] == "optimal" else 0.0,
               # bytes first touched: every level's polar grids and the complex128 image
               "fresh_bytes": float(sum(lv.nbytes for lv in levels)) + 16.0 * n_pix}
        for lv in levels[1:]:
            ops["merge"] += lv.nodes * merge * 2 * ntap
            ops["merge_pairs"] += lv.nodes * merge
        ops["pairs"] = ops["merge_pairs"] + ops["final_pairs"]
        return ops

    @property
    def rates(self) -> list:
        """Every level's pulse tones (:meth:`sarcli.formers.ffbp._grids.Apertures.rates`)."""
        n_lev = len(self.frames)
        return [self.apertures.rates(l, l == n_lev - 1) for l in range(n_lev)]

    def _profiles_deapodized(self) -> bool:
        # the profiles' kernel is deapodized exactly, but near upsample 1 its Ψ vanishes at the
        # band edge (1.8e-3 at β = 1) and the minimax stencil errs less
        up = float(self.knobs["upsample"])
        return self.knobs["interp"] == "optimal" and bool(deapodized_edge_error(up) < interp_error("optimal", up))

    def error_floor(self, frequency_err=None, above=math.inf) -> float:
        """A lower bound of :meth:`plan`'s ``predicted_error`` (``optimal`` kernels; 0 for the others)
        short of the deapodization's decisions: whichever way each axis goes
        (:func:`sarcli.formers.ffbp._grids.decide_deapodization`), its error is at least the smaller
        of its deapodized aliases (the mismatch adds to them) and the minimax stencils' error, and
        the deapodized profiles err at least their own aliases (:func:`predict_error`).
        ``frequency_err``: :func:`frequency_error` of these frequencies, positions and grid, where at
        hand. Where the bound passes ``above`` without the angular kernel's error, that is left out
        (the bound returned is lower, and still above ``above``)."""
        knobs = self.knobs
        if knobs["interp"] != "optimal":
            return 0.0
        up, os_r, os_a = float(knobs["upsample"]), float(knobs["os_range"]), float(knobs["os_angle"])
        n = len(self.frames)
        floor = deapodized_error(up) if self._profiles_deapodized() else interp_error("optimal", up)
        floor += n * min(deapodized_error(os_r), interp_error("optimal", os_r))
        floor += self._frequency_error(frequency_err)
        if floor > above:
            return floor
        return floor + min(n * deapodized_error(os_a),
                           sum(angle_interp_error("optimal", fr.beta, int(fr.count.max()), os_a) for fr in self.frames))

    def _frequency_error(self, given) -> float:
        return frequency_error(self.freq_hz, self.pos, self.grid) if given is None else float(given)

    def plan(self, frequency_err=None) -> FfbpPlan:
        """The complete :class:`FfbpPlan`: deapodization decisions, peak memory, predicted error.
        ``frequency_err`` as for :meth:`error_floor`."""
        knobs, frames, levels, ops = self.knobs, self.frames, self.levels, dict(self.ops)
        deapodized = {}
        if knobs["interp"] == "optimal":
            dec = decide_deapodization(self.rates, frames, self.kmax, self.kref, self.dq, knobs["os_range"],
                                       knobs["os_angle"])
            deapodized = dict(zip(("range_deapodized", "range_mismatch", "range_rates", "range_offset"), dec["range"]))
            deapodized.update(zip(("angle_deapodized", "angle_mismatch", "angle_rates"), dec["angle"]))
            deapodized["profiles_deapodized"] = self._profiles_deapodized()
        # peak bytes of polar grids (float32 pairs): two adjacent levels of one depth-first group
        lv_bytes = [lv.nbytes for lv in levels]
        pair = max([a + b for a, b in zip(lv_bytes, lv_bytes[1:])] or lv_bytes)
        a0, b0 = subtree_groups(self)[0]
        ops["grid_bytes"] = pair * (b0 - a0) / levels[-1].n
        error = predict_error([(int(fr.count.max()), fr.beta) for fr in frames], interp=knobs["interp"],
                              os_range=knobs["os_range"], os_angle=knobs["os_angle"], upsample=knobs["upsample"],
                              **{name: deapodized[name] for name in ("profiles_deapodized", "range_deapodized",
                                                                      "range_mismatch", "angle_deapodized",
                                                                      "angle_mismatch") if name in deapodized})
        error += self._frequency_error(frequency_err)
        if ground_reach(levels) > 1.0:
            error = max(error, UNCOVERED_ERROR)   # grids past the ground: no accuracy is promised
        return FfbpPlan(levels, self.dq, self.kref, levels[-1].n, ops, dict(knobs), error,
                        band_scale=self.band_scale, **deapodized)


def layout_stages(antenna_position_m, freq_hz, grid: Grid, *, receive_position_m=None, _band=None,
                  **knobs) -> StageLayout:
    """The stages of :func:`plan_stages` for given knobs (``None``: :data:`DEFAULTS`), without the
    error model (:class:`StageLayout`).

    Parameters as for :func:`ffbp`. ``ops`` holds the multiply-add counts of stage 0
    (pulse × node × taps, the nodes each row forms: :mod:`sarcli.formers.ffbp._rows`), the merges
    (node × child × 2 taps: two 1-D passes) and the final stage
    (pixel × child × taps²), the stage-0 nodes and the (node or pixel, child) pairs of the merges
    and the final stage (each with its own coordinates and carrier; ``merge_pairs`` and
    ``final_pairs`` apart), the deapodized kernels' tone weights (``tones``) and the bytes first
    touched (``fresh_bytes``), from which :mod:`sarcli.formers.planning.planner` predicts the time; the completed plan adds ``grid_bytes``, the
    peak bytes of polar grids (two adjacent levels of one depth-first group).

    ``final``: merge until at most that many sub-images remain (default: while a merge costs less
    than it saves in the final stage).

    Level ℓ must be accurate wherever level ℓ+1's (or the final stage's) stencils reach, so its
    grid extends beyond the image by the stencil half-widths of every later level, in its own
    samples (range spacing is common; angular spacings shrink by ``merge`` per level).
    """
    given = _knobs(knobs)
    final = given.pop("final")
    knobs = _resolved(given)
    base, merge = knobs["base"], knobs["merge"]
    t = np.asarray(antenna_position_m, dtype=np.float64)
    rcv = t if receive_position_m is None else np.asarray(receive_position_m, dtype=np.float64)
    f = np.asarray(freq_hz, dtype=np.float64)
    fmin, fmax = float(f.min()), float(f.max())
    if not fmax > fmin:
        raise SarcliInputError("ffbp needs a bandwidth (more than one frequency)")
    kband = range_wavenumbers(fmax - fmin)
    kmax = range_wavenumbers(fmax)
    kref = range_wavenumbers(0.5 * (fmax + fmin))
    bq, bu = _band or (1.0, 1.0)
    dq = np.pi / (kband / 2 * bq) / knobs["os_range"]
    half = NTAPS[INTERPOLATORS[knobs["interp"]]] // 2   # a stencil reaches ntap/2 samples past its point
    n_pix = grid.nx * grid.ny
    margin = MARGIN_PIXELS * max(grid.dx, grid.dy)
    ap = apertures(t, rcv, grid, margin, base, merge)
    frames, children = _merged_levels(ap, kmax, knobs["os_angle"], bu, level_test=(dq, half, n_pix, merge),
                                      final=final)
    # every pulse's tones on every level's grid: where they overflow the bands the grids were
    # sampled for (a receiver far from the transmitter, a wide baseline), sample that much finer
    n_lev = len(frames)
    excess = band_excess([ap.tone_reach(l, l == n_lev - 1) for l in range(n_lev)], frames, range_wavenumbers(fmin),
                         kmax, kref, knobs["os_angle"])
    if _band is None and max(excess) > BAND_SLACK:
        return layout_stages(antenna_position_m, freq_hz, grid, receive_position_m=receive_position_m,
                             _band=tuple(max(e, 1.0) * BAND_SLACK for e in excess), final=final, **knobs)
    return StageLayout({**knobs, "base": base, "merge": merge}, frames, children, ap, dq, kref, kmax, (bq, bu), f,
                       t if rcv is t else 0.5 * (t + rcv), grid)


def _resolved(given: dict) -> dict:
    """The stage knobs with :data:`DEFAULTS` where not given (``upsample`` from ``os_range`` and the
    interpolator), checked: one line naming the first that is out of range."""
    knobs = {**DEFAULTS, **{name: v for name, v in given.items() if v is not None}}
    if given.get("upsample") is None:
        knobs["upsample"] = (default_upsample(float(knobs["os_range"])) if knobs["interp"] == "optimal"
                             else UPSAMPLE_ANALYTIC)
    knobs["base"], knobs["merge"] = int(knobs["base"]), int(knobs["merge"])
    if knobs["base"] < 1 or knobs["merge"] < 2:
        raise SarcliInputError(f"ffbp needs base >= 1 and merge >= 2, got base={knobs['base']}, merge={knobs['merge']}")
    if not (knobs["os_range"] >= 1 and knobs["os_angle"] >= 1 and knobs["upsample"] >= 1):
        raise SarcliInputError("ffbp oversampling factors (os_range, os_angle, upsample) must be >= 1")
    if knobs["interp"] not in INTERPOLATORS:
        raise SarcliInputError(f"unknown interpolation {knobs['interp']!r}; choose one of {sorted(INTERPOLATORS)}")
    return knobs


def _merged_levels(ap, kmax, os_angle, bu, *, level_test, final):
    """Every level's frame and children: merge while it costs less than it saves in the final stage
    (or, with ``final``, until at most that many sub-images remain). ``level_test``: the range
    spacing, the stencil half-width, the pixels and the merge factor the test weighs."""
    dq, half, n_pix, merge = level_test
    frames, children = [ap.frame(0, kmax, os_angle, bu)], [None]
    while frames[-1].first.size > 1:
        n_cur = frames[-1].first.size
        nxt = ap.frame(len(frames), kmax, os_angle, bu)
        lv = level_grid(nxt, dq, MERGE_TEST_EXTENSION * half, MERGE_TEST_EXTENSION * half)
        if final is not None:
            if n_cur <= int(final):
                break
        elif float(lv.n) * lv.n_u * lv.n_q * merge + float(n_pix) * lv.n >= float(n_pix) * n_cur:
            break
        children.append(ap.children[len(frames)])
        frames.append(nxt)
    return frames, children


def subtree_groups(plan, limit=SUBTREE_BYTES):
    """Groups ``(a, b)`` of the last level's sub-images whose subtrees (every level's polar grids
    below them, float32) fit ``limit`` bytes together; at least one sub-image a group.
    ``plan``: an :class:`FfbpPlan` or :class:`StageLayout` (its ``levels``)."""
    levels = plan.levels
    n_last = levels[-1].n
    per = sum(lv.nbytes for lv in levels) / n_last
    g = max(1, min(n_last, int(limit // per)))
    return [(a, min(n_last, a + g)) for a in range(0, n_last, g)]
