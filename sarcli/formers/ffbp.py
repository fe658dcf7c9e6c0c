"""Fast factorised backprojection (FFBP): the spherical matched filter in ~O(N² log P).

Backprojection (:mod:`sarcli.formers.backprojection`) sums every pulse into every pixel,
O(N²·P). FFBP (Ulander, Hellsten and Stenström 2003) exploits that a *short* sub-aperture's image
varies slowly across angle seen from the sub-aperture's centre: it needs few angular samples on a
polar grid centred there. So

1. **stage 0**: the pulses are split into base sub-apertures of ``base`` pulses; each is
   backprojected (exact spherical ranges, the range profiles of backprojection) onto its own polar
   grid;
2. **merges**: groups of ``merge`` neighbouring sub-apertures are combined into one, whose polar
   grid has ``merge`` times finer angular sampling (its aperture is that much longer): every node
   of the parent interpolates each child at the same ground point, in two 1-D passes along the
   parent's row (u at the child's columns, then q at the nodes: 2·taps per node, not taps²);
3. **final stage**: when one more merge would cost more than it saves, the remaining sub-images are
   interpolated at every Cartesian pixel and summed.

The tree is walked depth first: the last level's sub-images are taken in groups whose subtrees
fit :data:`SUBTREE_BYTES`, and each group's stage 0, merges and final stage run before the next
group's, adding to the image. So memory is the image plus one group's polar grids, whatever the
number of pulses (a whole circular pass of 40 000 pulses), and short collections run in one group.

Every step evaluates the exact spherical geometry of its own sub-aperture centre, so curved and
climbing paths are fine; far-field data are imaged through virtual antennas exactly as
backprojection does (:func:`sarcli.formers.formation._positions`).

Polar grids
-----------
Around a sub-aperture centre ``c`` a ground point ``x`` has the differential slant range
``q = |c - x| - |c|`` and the direction cosine ``u = ((x - c)·e⊥)/|c - x|`` across the line from
c's nadir to the scene origin (``e⊥`` horizontal, perpendicular to it); both, and their inverse,
are evaluated without cancellation. A sub-image is stored demodulated,
``F(q, u) = I(x) e^{-i k_ref q}`` with ``k_ref = 4π α_c/c``, which leaves it band limited to
``|k_q| ≤ K_B/2`` in ``q`` (``K_B = 4π B/c``, B the bandwidth) and to ``|k_u| ≤ k_max d_max``
in ``u`` (``d_max`` the largest horizontal distance of a pulse from ``c``; a pulse at ``Δ⊥``
across is the tone ``k Δ⊥`` in u wherever it is on the grid, which lets the angular kernel be
deapodized like the range kernel). The grids sample these at ``Δq = π/(K_B/2) / os_range`` and
``Δu = π/(k_max d_max) / os_angle``.

Error model
-----------
Interpolating a band-limited signal whose spectrum fills ``1/β`` of the Nyquist band with a kernel
K has the mean-square relative error ``ε²(K, β) = ⟨|1 − Σ_n K(t − n) e^{−2πiν(t − n)}|²⟩`` over
fractions ``t`` and frequencies ``|ν| < 1/(2β)`` (:func:`interp_error`, flat spectrum). FFBP
interpolates once per pulse (the range profile, ``β`` = upsample) and twice (range, angle) per merge
stage and in the final stage. The angular spectrum of a sub-aperture of n pulses is n lines, not a
flat band (two pulses sit at the band edges), and the errors of the stages add coherently
(interpolation attenuates the band's edges alike every time), so
``ε ≈ ε_prof + Σ_stages (ε(K, os_range) + ε_n(K, β_angle))`` (:func:`predict_error`), plus the
error of treating the frequencies as equally spaced (:func:`frequency_error`). See docs/ffbp.md for
the check against the exact matched filter.

Deapodization
-------------
An interpolation with weights ``ψ(n − t)`` answers a frequency ν (cycles per sample) with a mean
``Ψ(ν)`` that does not depend on the fraction t, plus aliases that do (Poisson summation). Where
the frequency each data sample will be read at is known beforehand, ``Ψ`` can be divided out of the
data, as a NUFFT divides out its kernel, and only the aliases remain: with a 6-tap
exponential-of-semicircle kernel (:func:`sarcli.formers.ffbp_model.deapodized_kernel`) 7e-6 at
oversampling 2 and 5e-5 at 1.5 (:func:`~sarcli.formers.ffbp_model.deapodized_error`), against
2.3e-3 and 1.7e-2 for the best stencil without the division (the ``optimal`` minimax kernel). That
lets the grids be sampled coarser (1.5 instead of 2) at a smaller error. ffbp deapodizes three
interpolations:

- **range profiles**: bin ``j − j_c`` of an FFT of length L is exactly the frequency
  ``(j − j_c)/L``, so ``1/Ψ`` is a weight per frequency (``_ffbp_grids.deapodization``); kept where
  ``Ψ`` does not vanish at the band's edge (``upsample`` above ~1,
  :func:`~sarcli.formers.ffbp_model.deapodized_edge_error`). The profile upsampling is a multiple of
  ``os_range`` (:func:`~sarcli.formers.ffbp_model.default_upsample`): the profiles' aliases then land
  on their own tones on the polar grids instead of growing by ``(Ψ(ν')/Ψ(ν))^S``
  (:func:`~sarcli.formers.ffbp_model.profile_alias_error`);
- **polar grids in range (q)**: level l reads pulse p's component at wavenumber ``k_j`` at
  ``ν_q = (k_j ∂R_p/∂q − k_ref) Δq/2π``;
- **polar grids across (u)**: at ``ν_u = k_j ∂R_p/∂u Δu_l/2π`` (``∂R_p/∂u ≈ Δ⊥``, the pulse's offset
  across from the centre, wherever it is on the grid: why u, a direction cosine, is the grids'
  coordinate).

So ``Π_l Ψ(ν)`` over the levels a pulse passes is divided out of its data before the profiles' FFT
(``_ffbp_stage0._tone_weights``). Each pulse's ``∂R_p/∂q`` and ``∂R_p/∂u`` on every level's grid come
from its rays to the grown grid's edge and centre (``_ffbp_grids.pulse_rates``); their spread over a
grid (a climbing path, a near-field aperture) leaves a *mismatch*, ``rms_ν (d ln Ψ/dν)`` times the
rms over the pulses of the half-spread, in the predicted error. An axis is deapodized only where its
mismatch plus every level's aliases stays below the minimax stencils' error at the same
oversampling (``_ffbp_grids.decide_deapodization``; ``FfbpPlan.range_deapodized``,
``angle_deapodized``). The same tones say how far a pulse reaches past the band a grid was sampled
for (a receiver far from the transmitter, a wide baseline): past :data:`BAND_SLACK`, the grids are
sampled that much finer (``_ffbp_grids.band_excess``, ``FfbpPlan.band_scale``).

Planning
--------
:func:`plan_stages` needs no data: :func:`layout_stages` splits the pulses into sub-apertures
(:data:`DEFAULTS`' ``base`` and ``merge``), places each level's polar frame and merges while a merge
costs less than it saves in the final stage (:class:`StageLayout`: frames, then grids and operation
counts); :meth:`StageLayout.plan` then decides the deapodization and predicts the error
(:class:`FfbpPlan`). What does not depend on the oversampling (each level's frame geometry and pulse
tones) is kept per pulses, grid, base and merge (``_ffbp_grids.Apertures``), so a sweep of
oversamplings (``--method auto``'s, :mod:`sarcli.formers.planner`) computes it once per base; and
:meth:`StageLayout.error_floor` bounds the predicted error from below before the deapodization is
decided, so the sweep completes only the settings that can be its pick. ``os_range`` or ``os_angle``
not given: :data:`OS_RANGE_DEAPODIZED` (:data:`OS_ANGLE_DEAPODIZED`) is tried first and kept where
that axis is deapodized and errs no more than the minimax stencil at the default.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from ..core.geometry import C
from ..core.grid import Grid
from ..errors import SarcliInputError
from .ffbp_model import INTERPOLATORS, NTAPS as _NTAPS, angle_interp_error, frequency_error, interp_error
from .ffbp_model import optimal_kernel, predict_error
from ._ffbp_grids import _level, _split, apertures
from ._ffbp_grids import band_excess, deapodization as _deapodization, decide_deapodization
from .ffbp_model import deapodized_edge_error, deapodized_error, deapodized_inverse, deapodized_kernel, default_upsample

__all__ = ["ffbp", "ffbp_image", "optimal_kernel", "plan_stages", "layout_stages", "predict_error", "interp_error",
           "FfbpPlan", "StageLayout", "DEFAULTS"]

#: Default knobs (see docs/ffbp.md for the error-vs-time frontier behind them); ``upsample`` not
#: given is :func:`default_upsample` for ``optimal``, :data:`UPSAMPLE_ANALYTIC` for the others.
DEFAULTS = {"base": 16, "merge": 4, "os_range": 2.0, "os_angle": 2.0, "interp": "optimal"}
#: ``os_range`` tried first when it is not given (``interp='optimal'``): kept where the plan
#: deapodizes the range kernel and its range error is predicted no larger than at the default 2.
OS_RANGE_DEAPODIZED = 1.5
#: ``os_angle`` tried first when it is not given (``interp='optimal'``), on the same terms.
OS_ANGLE_DEAPODIZED = 1.5
#: How far (ratio) the pulses' tones may reach past the polar grids' nominal bands before the
#: grids are sampled finer to hold them (:func:`sarcli.formers._ffbp_grids.band_excess`).
BAND_SLACK = 1.02
#: Profile upsampling of the analytic kernels (only ``optimal``'s profiles are deapodized).
UPSAMPLE_ANALYTIC = 4.0
#: Storage of the polar sub-images: float32 halves their memory and traffic; its rounding (6e-8
#: relative) is far below any interpolation error the knobs allow. Arithmetic stays float64.
_STORE = np.float32
#: Pulses whose range profiles are held at once in stage 0.
_PROFILE_BLOCK = 64
#: Polar sub-images (bytes) formed at once: the last level's sub-images are formed and imaged in
#: groups whose subtrees fit this (:func:`_subtree_groups`), so memory does not grow with the pulses.
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


# ---------------------------------------------------------------------------------------------
# polar grids
# ---------------------------------------------------------------------------------------------
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
    #: and the range tones' offset; :func:`sarcli.formers._ffbp_grids.decide_deapodization`);
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


def plan_stages(antenna_position_m, freq_hz, grid: Grid, *, base=None, merge=None, os_range=None,
                os_angle=None, interp=None, upsample=None, final=None, receive_position_m=None) -> FfbpPlan:
    """The FFBP stages for a geometry (no data needed): levels, operation counts, predicted error
    (:func:`layout_stages`, then :meth:`StageLayout.plan`). ``os_range=None`` with ``optimal``
    kernels: :data:`OS_RANGE_DEAPODIZED`
    where the range kernel is deapodized and its range error (aliases plus frequency mismatch) is
    no larger than the minimax stencil's at the default, else the default; ``os_angle=None``
    likewise with :data:`OS_ANGLE_DEAPODIZED` and the angular kernel. ``upsample=None``:
    :func:`default_upsample` for ``optimal`` (deapodized profiles), :data:`UPSAMPLE_ANALYTIC` for
    the others.
    ``receive_position_m``: separate receive positions (``antenna_position_m`` then transmits)."""
    kw = dict(base=base, merge=merge, interp=interp, final=final, upsample=upsample,
              receive_position_m=receive_position_m)
    auto = interp in (None, "optimal")
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


class StageLayout:
    """The stages of a plan short of its error model (:func:`layout_stages`): the sub-apertures of
    every level and their polar frames, then, when first asked for, the polar grids (``levels``)
    and the operation counts (``ops``). :meth:`error_floor` bounds the plan's predicted error from
    below at little cost; :meth:`plan` completes the plan."""

    def __init__(self, knobs, frames, children, apertures, dq, kref, kmax, band_scale, freq_hz, pos, grid):
        self.knobs, self.frames, self.children, self.apertures = knobs, frames, children, apertures
        self.dq, self.kref, self.kmax, self.band_scale = dq, kref, kmax, band_scale
        self.freq_hz, self.pos, self.grid = freq_hz, pos, grid

    @functools.cached_property
    def levels(self) -> list:
        """Every level's polar grids, extended to hold the stencils of the levels after it and of
        the final stage (:func:`layout_stages`)."""
        frames, children, dq = self.frames, self.children, self.dq
        half = _NTAPS[INTERPOLATORS[self.knobs["interp"]]] // 2
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
            levels.append(_level(fr, dq, ext_q, ext_u, children[l]))
        return levels

    @functools.cached_property
    def ops(self) -> dict:
        """Operation counts of the stages (:func:`layout_stages`)."""
        levels, merge = self.levels, int(self.knobs["merge"])
        ntap = _NTAPS[INTERPOLATORS[self.knobs["interp"]]]
        n_pix = self.grid.nx * self.grid.ny
        P = self.pos.shape[0]
        ops = {"stage0": float(P) * levels[0].n_u * levels[0].n_q * ntap, "merge": 0.0,
               "final": float(n_pix) * levels[-1].n * ntap * ntap,
               "nodes": float(max(lv.n * lv.n_u * lv.n_q for lv in levels)),
               "stage0_nodes": float(levels[0].n) * levels[0].n_u * levels[0].n_q,
               "pairs": float(n_pix) * levels[-1].n}
        for lv in levels[1:]:
            ops["merge"] += float(lv.n) * lv.n_u * lv.n_q * merge * 2 * ntap
            ops["pairs"] += float(lv.n) * lv.n_u * lv.n_q * merge
        return ops

    @property
    def rates(self) -> list:
        """Every level's pulse tones (:meth:`sarcli.formers._ffbp_grids.Apertures.rates`)."""
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
        (:func:`sarcli.formers._ffbp_grids.decide_deapodization`), its error is at least the smaller
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
        a0, b0 = _subtree_groups(self)[0]
        ops["grid_bytes"] = pair * (b0 - a0) / levels[-1].n
        error = predict_error([(int(fr.count.max()), fr.beta) for fr in frames], interp=knobs["interp"],
                              os_range=knobs["os_range"], os_angle=knobs["os_angle"], upsample=knobs["upsample"],
                              **{name: deapodized[name] for name in ("profiles_deapodized", "range_deapodized",
                                                                      "range_mismatch", "angle_deapodized",
                                                                      "angle_mismatch") if name in deapodized})
        return FfbpPlan(levels, self.dq, self.kref, levels[-1].n, ops, dict(knobs),
                        error + self._frequency_error(frequency_err), band_scale=self.band_scale, **deapodized)


def layout_stages(antenna_position_m, freq_hz, grid: Grid, *, base=None, merge=None, os_range=None,
                  os_angle=None, interp=None, upsample=None, final=None, receive_position_m=None,
                  _band=None) -> StageLayout:
    """The stages of :func:`plan_stages` for given knobs (``None``: :data:`DEFAULTS`), without the
    error model (:class:`StageLayout`).

    Parameters as for :func:`ffbp`. ``ops`` holds the multiply-add counts of stage 0
    (pulse × node × taps), the merges (node × child × 2 taps: two 1-D passes) and the final stage
    (pixel × child × taps²), the stage-0 nodes and the (node or pixel, child) pairs of the merges
    and the final stage (each with its own coordinates and carrier), from which
    :mod:`sarcli.formers.planner` predicts the time; the completed plan adds ``grid_bytes``, the
    peak bytes of polar grids (two adjacent levels of one depth-first group).

    ``final``: merge until at most that many sub-images remain (default: while a merge costs less
    than it saves in the final stage).

    Level ℓ must be accurate wherever level ℓ+1's (or the final stage's) stencils reach, so its
    grid extends beyond the image by the stencil half-widths of every later level, in its own
    samples (range spacing is common; angular spacings shrink by ``merge`` per level).
    """
    knobs = {**DEFAULTS, **{name: v for name, v in dict(base=base, merge=merge, os_range=os_range, os_angle=os_angle,
                                               interp=interp, upsample=upsample).items() if v is not None}}
    if upsample is None:
        knobs["upsample"] = (default_upsample(float(knobs["os_range"])) if knobs["interp"] == "optimal"
                             else UPSAMPLE_ANALYTIC)
    base, merge = int(knobs["base"]), int(knobs["merge"])
    if base < 1 or merge < 2:
        raise SarcliInputError(f"ffbp needs base >= 1 and merge >= 2, got base={base}, merge={merge}")
    if not (knobs["os_range"] >= 1 and knobs["os_angle"] >= 1 and knobs["upsample"] >= 1):
        raise SarcliInputError("ffbp oversampling factors (os_range, os_angle, upsample) must be >= 1")
    if knobs["interp"] not in INTERPOLATORS:
        raise SarcliInputError(f"unknown interpolation {knobs['interp']!r}; choose one of {sorted(INTERPOLATORS)}")
    t = np.asarray(antenna_position_m, dtype=np.float64)
    rcv = t if receive_position_m is None else np.asarray(receive_position_m, dtype=np.float64)
    f = np.asarray(freq_hz, dtype=np.float64)
    fmin, fmax = float(f.min()), float(f.max())
    if not fmax > fmin:
        raise SarcliInputError("ffbp needs a bandwidth (more than one frequency)")
    kband = 4 * np.pi * (fmax - fmin) / C
    kmax = 4 * np.pi * fmax / C
    kref = 2 * np.pi * (fmax + fmin) / C
    bq, bu = _band or (1.0, 1.0)
    dq = np.pi / (kband / 2 * bq) / knobs["os_range"]
    half = _NTAPS[INTERPOLATORS[knobs["interp"]]] // 2   # a stencil reaches ntap/2 samples past its point
    n_pix = grid.nx * grid.ny
    margin = MARGIN_PIXELS * max(grid.dx, grid.dy)
    ap = apertures(t, rcv, grid, margin, base, merge)
    frames = [ap.frame(0, kmax, knobs["os_angle"], bu)]
    children = [None]
    while frames[-1].first.size > 1:   # merge while it costs less than it saves in the final stage
        n_cur = frames[-1].first.size
        nxt = ap.frame(len(frames), kmax, knobs["os_angle"], bu)
        lv = _level(nxt, dq, MERGE_TEST_EXTENSION * half, MERGE_TEST_EXTENSION * half)
        if final is not None:
            if n_cur <= int(final):
                break
        elif float(lv.n) * lv.n_u * lv.n_q * merge + float(n_pix) * lv.n >= float(n_pix) * n_cur:
            break
        children.append(ap.children[len(frames)])
        frames.append(nxt)
    # every pulse's tones on every level's grid: where they overflow the bands the grids were
    # sampled for (a receiver far from the transmitter, a wide baseline), sample that much finer
    n_lev = len(frames)
    excess = band_excess([ap.tone_reach(l, l == n_lev - 1) for l in range(n_lev)], frames, 4 * np.pi * fmin / C,
                         kmax, kref, knobs["os_angle"])
    if _band is None and max(excess) > BAND_SLACK:
        return layout_stages(antenna_position_m, freq_hz, grid, base=base, merge=merge, os_range=knobs["os_range"],
                             os_angle=knobs["os_angle"], interp=knobs["interp"], upsample=knobs["upsample"],
                             final=final,
                             receive_position_m=receive_position_m,
                             _band=tuple(max(e, 1.0) * BAND_SLACK for e in excess))
    return StageLayout({**knobs, "base": base, "merge": merge}, frames, children, ap, dq, kref, kmax, (bq, bu), f,
                       t if rcv is t else 0.5 * (t + rcv), grid)


# ---------------------------------------------------------------------------------------------
# range profiles
# ---------------------------------------------------------------------------------------------
def _descend(levels, a, b):
    """Index ranges ``[(lo, hi)]`` per level of the subtree below sub-images ``a .. b-1`` of the
    last level (the sub-apertures of every level are consecutive runs of their children)."""
    out = [(a, b)]
    for lv in levels[:0:-1]:
        pf, pc = lv.children
        a, b = int(pf[a]), int(pf[b - 1] + pc[b - 1])
        out.append((a, b))
    return out[::-1]


def _subtree_groups(plan):
    """Groups ``(a, b)`` of the last level's sub-images whose subtrees (every level's polar grids
    below them, float32) fit :data:`SUBTREE_BYTES` together; at least one sub-image a group.
    ``plan``: an :class:`FfbpPlan` or :class:`StageLayout` (its ``levels``)."""
    levels = plan.levels
    n_last = levels[-1].n
    per = sum(lv.nbytes for lv in levels) / n_last
    g = max(1, min(n_last, int(SUBTREE_BYTES // per)))
    return [(a, min(n_last, a + g)) for a in range(0, n_last, g)]


# ---------------------------------------------------------------------------------------------
# public function
# ---------------------------------------------------------------------------------------------
def ffbp(data, freq_hz, antenna_position_m, range_to_center_m, grid: Grid, weights=None, *, base=None,
         merge=None, os_range=None, os_angle=None, interp=None, upsample=None, final=None, nthreads=None,
         receive_position_m=None, return_plan=False):
    """Spherical matched-filter image by fast factorised backprojection (module docstring).

    Parameters
    ----------
    data : array_like, shape (P, M), complex
        Phase history (spherical model); pulses in flight order (neighbours are merged).
    freq_hz : array_like, shape (M,) or (P, M)
        Frequencies, equally spaced within each pulse.
    antenna_position_m : array_like, shape (P, 3)
        Antenna phase centres (transmit positions when ``receive_position_m`` is given).
    range_to_center_m : array_like, shape (P,)
    grid : Grid
    weights : array_like, shape (M,) or (P, M), optional
    base : int, default 16
        Pulses per base sub-aperture.
    merge : int, default 4
        Sub-apertures merged per stage.
    os_range, os_angle : float, optional
        Oversampling of the polar grids over the Nyquist rate in range and angle (not given: 1.5
        where that axis's kernel can be deapodized, else 2; :func:`plan_stages`).
    interp : {'linear', 'cubic', 'lanczos', 'optimal'}, default 'optimal'
        Interpolator of the range profiles and the polar grids (``optimal``: minimax 6-tap
        kernels designed for each grid's oversampling, :func:`optimal_kernel`, deapodized where
        the plan finds it pays: module docstring).
    upsample : float, optional
        Range-profile oversampling (the IFFT length is ``upsample·M``); default: ``os_range``
        (at least 1.5: :func:`default_upsample`) for ``optimal``, 4 for the analytic kernels.
    final : int, optional
        Merge until at most this many sub-images remain (default: as long as a merge pays).
    nthreads : int, optional
    receive_position_m : array_like, shape (P, 3), optional
        Separate receive positions ``r`` (range ``(|t − x| + |r − x|)/2 − r0``).
    return_plan : bool
        Also return the :class:`FfbpPlan` (stages, predicted error).

    Returns
    -------
    image : ndarray, shape (ny, nx), complex128
        ``(1/W) Σ w d e_pj(x)`` to within the predicted error (unit point peaks ≈ 1).
    """
    from . import _ffbp_kernels as kern
    from ._ffbp_stage0 import _pulse_geometry, _series_inputs, _tone_weights, pulse_table, stage0
    from .._native import using_threads
    from .backprojection import _PAD, _check_data, frequency_steps, profile_length, range_profiles

    d = _check_data(data)   # a phase history left on disk stays there: stage 0 reads it by blocks
    P, M = d.shape
    if M < 2:
        raise SarcliInputError("ffbp needs at least two frequencies per pulse; use method 'direct'")
    t = np.asarray(antenna_position_m, dtype=np.float64)
    r0 = np.asarray(range_to_center_m, dtype=np.float64)
    rcv = t if receive_position_m is None else np.asarray(receive_position_m, dtype=np.float64)
    if t.shape != (P, 3) or rcv.shape != (P, 3) or r0.shape != (P,):
        raise SarcliInputError(f"antenna positions {t.shape} / ranges {r0.shape} do not match {P} pulses")
    # one row when every pulse has the same frequencies: the checks cost O(M), not O(P M)
    f = np.asarray(freq_hz, dtype=np.float64)
    f = f[None, :] if f.ndim == 1 else f
    if f.shape not in ((1, M), (P, M)):
        raise SarcliInputError(f"frequencies have shape {np.shape(freq_hz)}, expected ({M},) or ({P}, {M})")
    dalpha = np.broadcast_to(frequency_steps(f, "ffbp"), (P,))
    if weights is None:
        w, total = None, float(P * M)
    else:
        w = np.broadcast_to(np.asarray(weights, dtype=np.float64), (P, M))
        total = float(w.sum())
        if not total > 0:
            raise SarcliInputError("window weights sum to zero")
    bistatic = receive_position_m is not None and not np.array_equal(t, rcv)
    plan = plan_stages(t, f, grid, base=base, merge=merge, os_range=os_range, os_angle=os_angle, interp=interp,
                       upsample=upsample, final=final, receive_position_m=rcv if bistatic else None)
    knobs = plan.knobs
    kind = INTERPOLATORS[knobs["interp"]]
    n_len = profile_length(M, knobs["upsample"])
    jc = M // 2
    bin_m = C / (2.0 * dalpha * n_len)
    inv_bin = 1.0 / bin_m
    kc = 4.0 * np.pi * (np.broadcast_to(f[:, 0], (P,)) + jc * dalpha) / C
    lev = plan.levels[0]
    dlt, series = _series_inputs(t, rcv, r0, lev, plan.dq, 4.0 * np.pi * float(f.max()) / C)
    pulses = pulse_table(_pulse_geometry(t, rcv, r0), dlt, inv_bin, kc)
    deapodize = plan.profiles_deapodized or plan.range_deapodized or plan.angle_deapodized
    # each interpolation's weight polynomials (profiles, range, angle): the deapodized kernel where
    # the plan says, else the minimax one for ``optimal``; the analytic kernels read none
    tab_p, tab_q, tab_t = (deapodized_kernel(float(knobs[name])) if on else
                           optimal_kernel(float(knobs[name])) if knobs["interp"] == "optimal" else None
                           for on, name in ((plan.profiles_deapodized, "upsample"), (plan.range_deapodized, "os_range"),
                                            (plan.angle_deapodized, "os_angle")))
    # the polar grids' deapodized kernels: 1/Ψ at each pulse's tones on every level (_tone_weights)
    tones = [(rates, off, deapodized_inverse(float(knobs[os]))) for on, rates, off, os in
             ((plan.range_deapodized, plan.range_rates, plan.range_offset, "os_range"),
              (plan.angle_deapodized, plan.angle_rates, 0.0, "os_angle")) if on]
    k_all = 4.0 * np.pi * f / C
    levels = plan.levels
    deap = _deapodization(f, plan, n_len) if deapodize else None
    img = None   # made at the first final stage (when only the last level is alive); parts add in place
    with using_threads(nthreads) as nthr:
        # depth first: the last level's sub-images in groups, each group's whole subtree (stage 0,
        # merges) formed, added to the image and freed, so memory does not grow with the pulses
        for a0, b0 in _subtree_groups(plan):
            rng = _descend(levels, a0, b0)
            lo, hi = rng[0]
            cur_re = np.empty((hi - lo, lev.n_u, lev.n_q), dtype=_STORE)
            cur_im = np.empty((hi - lo, lev.n_u, lev.n_q), dtype=_STORE)
            # stage 0 in blocks of sub-apertures (bounded profile memory)
            per = max(1, _PROFILE_BLOCK // int(lev.count.max()))
            for s0 in range(lo, hi, per):
                s1 = min(hi, s0 + per)
                p0, p1 = int(lev.first[s0]), int(lev.first[s1 - 1] + lev.count[s1 - 1])
                wb = None if w is None else w[p0:p1]
                if deapodize:   # the deapodized kernels' mean responses, divided out of the data
                    wb = deap if wb is None else wb * deap
                    if tones:   # per pulse: a [pulses, M] block of its own
                        wb = np.array(np.broadcast_to(wb, (p1 - p0, M)), order="C")
                    for rates, off, (h_psi, inv_psi) in tones:
                        _tone_weights(k_all if k_all.shape[0] == 1 else k_all[p0:p1], rates[:, p0:p1], off,
                                     1.0 / h_psi, inv_psi, wb)
                pre, pim = range_profiles(d[p0:p1], wb, total, n_len, nthr, dtype=np.complex64)
                stage0(pre, pim, lev.first[s0:s1] - p0, lev.count[s0:s1], np.ascontiguousarray(pulses[:, p0:p1]),
                       series[s0:s1], kern.frame(lev, s0, s1), tab_p, kind, bistatic, n_len // 2, n_len, _PAD,
                       plan.dq, plan.kref, cur_re[s0 - lo:s1 - lo], cur_im[s0 - lo:s1 - lo])
                del pre, pim
            for l in range(1, len(levels)):
                child, parent = levels[l - 1], levels[l]
                (c0, c1), (u0, u1) = rng[l - 1], rng[l]
                pf, pc = parent.children
                nxt_re = np.empty((u1 - u0, parent.n_u, parent.n_q), dtype=_STORE)
                nxt_im = np.empty((u1 - u0, parent.n_u, parent.n_q), dtype=_STORE)
                kern.merge(cur_re, cur_im, kern.frame(child, c0, c1), kern.frame(parent, u0, u1), pf[u0:u1] - c0,
                           pc[u0:u1], kind, tab_q, tab_t, plan.dq, plan.kref, nxt_re, nxt_im)
                cur_re, cur_im = nxt_re, nxt_im
                del nxt_re, nxt_im
            last = levels[-1]
            if img is None:
                img = np.zeros(grid.shape, dtype=np.complex128)
            kern.final(cur_re, cur_im, kern.frame(last, a0, b0), grid.x, grid.y, kind, tab_q, tab_t, plan.dq,
                       plan.kref, img)
            del cur_re, cur_im
    return (img, plan) if return_plan else img


def ffbp_image(data, freq_hz, antenna_position_m, range_to_center_m, grid, weights=None, **knobs):
    """:func:`ffbp` for :func:`sarcli.formers.formation.form_image`: the image and the settings
    to record (every knob, the stages and the predicted error). ``None`` knobs take :data:`DEFAULTS`."""
    knobs = {name: v for name, v in knobs.items() if v is not None}
    img, plan = ffbp(data, freq_hz, antenna_position_m, range_to_center_m, grid, weights, return_plan=True,
                     **knobs)
    params = {name: plan.knobs[name] for name in ("base", "merge", "os_range", "os_angle", "interp", "upsample")}
    params["ffbp_stages"] = [[int(lv.n), int(lv.n_u), int(lv.n_q)] for lv in plan.levels]
    params["predicted_error"] = plan.predicted_error
    return img, params
