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
exponential-of-semicircle kernel (:func:`sarcli.formers.ffbp.model.deapodized_kernel`) 7e-6 at
oversampling 2 and 5e-5 at 1.5 (:func:`~sarcli.formers.ffbp.model.deapodized_error`), against
2.3e-3 and 1.7e-2 for the best stencil without the division (the ``optimal`` minimax kernel). That
lets the grids be sampled coarser (1.5 instead of 2) at a smaller error. ffbp deapodizes three
interpolations:

- **range profiles**: bin ``j − j_c`` of an FFT of length L is exactly the frequency
  ``(j − j_c)/L``, so ``1/Ψ`` is a weight per frequency (``_grids.deapodization``); kept where
  ``Ψ`` does not vanish at the band's edge (``upsample`` above ~1,
  :func:`~sarcli.formers.ffbp.model.deapodized_edge_error`). The profile upsampling is a multiple of
  ``os_range`` (:func:`~sarcli.formers.ffbp.model.default_upsample`): the profiles' aliases then land
  on their own tones on the polar grids instead of growing by ``(Ψ(ν')/Ψ(ν))^S``
  (:func:`~sarcli.formers.ffbp.model.profile_alias_error`);
- **polar grids in range (q)**: level l reads pulse p's component at wavenumber ``k_j`` at
  ``ν_q = (k_j ∂R_p/∂q − k_ref) Δq/2π``;
- **polar grids across (u)**: at ``ν_u = k_j ∂R_p/∂u Δu_l/2π`` (``∂R_p/∂u ≈ Δ⊥``, the pulse's offset
  across from the centre, wherever it is on the grid: why u, a direction cosine, is the grids'
  coordinate).

So ``Π_l Ψ(ν)`` over the levels a pulse passes is divided out of its data before the profiles' FFT
(``_stage0.tone_weights``). Each pulse's ``∂R_p/∂q`` and ``∂R_p/∂u`` on every level's grid come
from its rays to the grown grid's edge and centre (``_grids.pulse_rates``); their spread over a
grid (a climbing path, a near-field aperture) leaves a *mismatch*, ``rms_ν (d ln Ψ/dν)`` times the
rms over the pulses of the half-spread, in the predicted error. An axis is deapodized only where its
mismatch plus every level's aliases stays below the minimax stencils' error at the same
oversampling (``_grids.decide_deapodization``; ``FfbpPlan.range_deapodized``,
``angle_deapodized``). The same tones say how far a pulse reaches past the band a grid was sampled
for (a receiver far from the transmitter, a wide baseline): past :data:`BAND_SLACK`, the grids are
sampled that much finer (``_grids.band_excess``, ``FfbpPlan.band_scale``).

Planning
--------
:func:`plan_stages` (in ``._plan``) needs no data: :func:`layout_stages` splits the pulses
into sub-apertures (:data:`DEFAULTS`' ``base`` and ``merge``), places each level's polar frame and
merges while a merge costs less than it saves in the final stage (:class:`StageLayout`: frames,
then grids and operation counts); :meth:`StageLayout.plan` then decides the deapodization and
predicts the error (:class:`FfbpPlan`). What does not depend on the oversampling (each level's
frame geometry and pulse tones) is kept per pulses, grid, base and merge
(``_grids.Apertures``), so a sweep of oversamplings (``--method auto``'s,
:mod:`sarcli.formers.planning.planner`) computes it once per base; and :meth:`StageLayout.error_floor`
bounds the predicted error from below before the deapodization is decided, so the sweep completes
only the settings that can be its pick. ``os_range`` or ``os_angle`` not given:
:data:`OS_RANGE_DEAPODIZED` (:data:`OS_ANGLE_DEAPODIZED`) is tried first and kept where
that axis is deapodized and errs no more than the minimax stencil at the default.
"""
from __future__ import annotations

import warnings

import numpy as np

from ...core.geometry import C
from ...core.sampling import equally_spaced, range_wavenumbers
from ...core.grid import Grid
from ...errors import SarcliInputError, SarcliWarning
from ..._util.progress import progress
from .model import INTERPOLATORS, interp_error, optimal_kernel, predict_error
from .model import deapodized_inverse, deapodized_kernel
from ._grids import deapodization, ground_reach
from ._kernels import Interp
from ._plan import (BAND_SLACK, DEFAULTS, OS_ANGLE_DEAPODIZED, OS_RANGE_DEAPODIZED, SUBTREE_BYTES, UPSAMPLE_ANALYTIC,
                    FfbpPlan, StageLayout, layout_stages, plan_stages, subtree_groups)

__all__ = ["ffbp", "ffbp_image", "optimal_kernel", "FINAL_COLUMNS", "plan_stages", "layout_stages", "predict_error", "interp_error",
           "FfbpPlan", "StageLayout", "DEFAULTS", "BAND_SLACK", "OS_RANGE_DEAPODIZED", "OS_ANGLE_DEAPODIZED",
           "UPSAMPLE_ANALYTIC", "SUBTREE_BYTES"]

#: Storage of the polar sub-images: float32 halves their memory and traffic; its rounding (6e-8
#: relative) is far below any interpolation error the knobs allow. Arithmetic stays float64.
_STORE = np.float32
#: Pulses whose range profiles are held at once in stage 0.
_PROFILE_BLOCK = 64
#: Pixel columns the final stage forms at once (into a band of its own, then added to the image):
#: a row of a narrow band reads few rows of the polar grids, which then stay in the caches and
#: the TLB; a row across a wide image reads thousands, a page each (docs/performance.md).
FINAL_COLUMNS = 256


# ---------------------------------------------------------------------------------------------
# range profiles
# ---------------------------------------------------------------------------------------------
def _subtree_groups(plan):
    """The depth-first groups of the last level's sub-images
    (:func:`sarcli.formers.ffbp._plan.subtree_groups`) whose subtrees fit :data:`SUBTREE_BYTES`."""
    return subtree_groups(plan, SUBTREE_BYTES)


def _descend(levels, a, b):
    """Index ranges ``[(lo, hi)]`` per level of the subtree below sub-images ``a .. b-1`` of the
    last level (the sub-apertures of every level are consecutive runs of their children)."""
    out = [(a, b)]
    for lv in levels[:0:-1]:
        pf, pc = lv.children
        a, b = int(pf[a]), int(pf[b - 1] + pc[b - 1])
        out.append((a, b))
    return out[::-1]


# ---------------------------------------------------------------------------------------------
# public function
# ---------------------------------------------------------------------------------------------
def ffbp(data, collection, grid: Grid, *, nthreads=None, return_plan=False, plan=None, timings=None, **knobs):
    """Spherical matched-filter image by fast factorised backprojection (module docstring).

    Parameters
    ----------
    data : array_like, shape (P, M), complex
        Phase history (spherical model); pulses in flight order (neighbours are merged).
    collection : Collection
        The collection (:class:`sarcli.core.collection.Collection`): frequencies (M,) or (P, M),
        equally spaced within each pulse; antenna phase centres (P, 3; transmit positions when
        receive positions are given); reference ranges (P,); window weights (M,) or (P, M); and
        optionally separate receive positions ``r`` (range ``(|t − x| + |r − x|)/2 − r0``).
    grid : Grid
    nthreads : int, optional
    return_plan : bool
        Also return the :class:`FfbpPlan` (stages, predicted error).
    plan : FfbpPlan, optional
        The stages, made before by :func:`plan_stages` for these positions, frequencies, grid and
        knobs (``knobs`` are then not used).
    **knobs
        The stages' knobs (:func:`plan_stages`), each optional:
    base : int, default 16
        Pulses per base sub-aperture.
    merge : int, default 4
        Sub-apertures merged per stage.
    os_range, os_angle : float, optional
        Oversampling of the polar grids over the Nyquist rate in range and angle (not given: 1.5
        where that axis's kernel can be deapodized, else 2; :func:`plan_stages`).
    interp : {'linear', 'cubic', 'lanczos', 'lagrange', 'optimal'}, default 'optimal'
        Interpolator of the range profiles and the polar grids (``optimal``: minimax 6-tap
        kernels designed for each grid's oversampling, :func:`optimal_kernel`, deapodized where
        the plan finds it pays: module docstring).
    upsample : float, optional
        Range-profile oversampling (the IFFT length is ``upsample·M``); default: ``os_range``
        (at least 1.5: :func:`default_upsample`) for ``optimal``, 4 for the analytic kernels.
    final : int, optional
        Merge until at most this many sub-images remain (default: as long as a merge pays).
    timings : dict, optional
        Processor seconds (all threads, :func:`time.process_time`) of each part added to it under
        ``profiles`` (reading and the FFTs), ``tones``, ``stage0``, ``merge`` and ``final``: what
        the planner's calibration measures (:func:`sarcli.formers.planning.planner.calibrate`).

    Returns
    -------
    image : ndarray, shape (ny, nx), complex128
        ``(1/W) Σ w d e_pj(x)`` to within the predicted error (unit point peaks ≈ 1).
    """
    from ..._native import using_threads

    inp = _Inputs(data, collection)
    if plan is None:
        plan = plan_stages(inp.t, inp.f, grid, receive_position_m=inp.rcv if inp.bistatic else None, **knobs)
    reach = ground_reach(plan.levels)
    if reach > 1.0:
        warnings.warn(f"ffbp: this near the radar the polar grids reach |u| = {reach:.3g} > 1, past the ground, "
                      f"where ffbp's error model does not hold; form this image by backprojection",
                      SarcliWarning, stacklevel=2)
    run = _Pass(inp, plan, _Clock(timings))
    img = None   # made at the first final stage (when only the last level is alive); parts add in place
    # the pulses through stage 0 (each group's merges and final stage follow its own pulses)
    bar = progress(total=inp.P, desc="ffbp", unit="pulse")
    with bar, using_threads(nthreads) as nthr:
        # depth first: the last level's sub-images in groups, each group's whole subtree (stage 0,
        # merges) formed, added to the image and freed, so memory does not grow with the pulses
        for a0, b0 in _subtree_groups(plan):
            cur_re, cur_im = run.subtree(_descend(plan.levels, a0, b0), nthr, bar)
            if img is None:
                img = np.zeros(grid.shape, dtype=np.complex128)
            run.final(cur_re, cur_im, a0, b0, grid, img)
            run.clock("final")
            del cur_re, cur_im
    return (img, plan) if return_plan else img


class _Inputs:
    """:func:`ffbp`'s inputs checked: the samples (left on disk where they are: stage 0 reads them
    by blocks), positions, frequencies (one row when every pulse has the same: the checks cost
    O(M), not O(P M)), their line per pulse and the window."""

    def __init__(self, data, collection):
        from ..backprojection import check_data

        freq_hz, weights, receive_position_m = collection.frequency_hz, collection.weights, collection.receive_position_m
        self.d = d = check_data(data)
        self.P, self.M = P, M = d.shape
        if M < 2:
            raise SarcliInputError("ffbp needs at least two frequencies per pulse; use method 'direct'")
        self.t = t = np.asarray(collection.antenna_position_m, dtype=np.float64)
        self.r0 = r0 = np.asarray(collection.range_to_center_m, dtype=np.float64)
        self.rcv = rcv = t if receive_position_m is None else np.asarray(receive_position_m, dtype=np.float64)
        if t.shape != (P, 3) or rcv.shape != (P, 3) or r0.shape != (P,):
            raise SarcliInputError(f"antenna positions {t.shape} / ranges {r0.shape} do not match {P} pulses")
        f = np.asarray(freq_hz, dtype=np.float64)
        self.f = f = f[None, :] if f.ndim == 1 else f
        if f.shape not in ((1, M), (P, M)):
            raise SarcliInputError(f"frequencies have shape {np.shape(freq_hz)}, expected ({M},) or ({P}, {M})")
        alpha_ref, dalpha = equally_spaced(f, "ffbp")
        self.alpha_ref, self.dalpha = np.broadcast_to(alpha_ref, (P,)), np.broadcast_to(dalpha, (P,))
        if weights is None:
            self.w, self.total = None, float(P * M)
        else:
            self.w = np.broadcast_to(np.asarray(weights, dtype=np.float64), (P, M))
            self.total = float(self.w.sum())
            if not self.total > 0:
                raise SarcliInputError("window weights sum to zero")
        self.bistatic = receive_position_m is not None and not np.array_equal(t, rcv)


class _Pass:
    """One run of a plan over checked inputs: stage 0's pulse tables, each interpolation's kernel
    and the deapodization, made once; :meth:`subtree` (stage 0 by blocks, then the merges) and
    :meth:`final` form one depth-first group after another."""

    def __init__(self, inp: _Inputs, plan, clock=None):
        from ._stage0 import pulse_geometry, pulse_table, series_inputs
        from ..backprojection import profile_length

        self.inp, self.plan = inp, plan
        self.clock = _Clock(None) if clock is None else clock
        self.band = None   # the final stage's band of columns
        knobs = plan.knobs
        self.kind = INTERPOLATORS[knobs["interp"]]
        self.n_len = n_len = profile_length(inp.M, knobs["upsample"])
        bin_m = C / (2.0 * inp.dalpha * n_len)
        inv_bin = 1.0 / bin_m
        kc = range_wavenumbers(inp.alpha_ref)
        lev = plan.levels[0]
        dlt, self.series = series_inputs(inp.t, inp.rcv, inp.r0, lev, plan.dq, 4.0 * np.pi * float(inp.f.max()) / C)
        self.pulses = pulse_table(pulse_geometry(inp.t, inp.rcv, inp.r0), dlt, inv_bin, kc)
        self.deapodize = plan.profiles_deapodized or plan.range_deapodized or plan.angle_deapodized
        # each interpolation's weight polynomials (profiles, range, angle): the deapodized kernel where
        # the plan says, else the minimax one for ``optimal``; the analytic kernels read none
        self.tab_p, tab_q, tab_t = (
            deapodized_kernel(float(knobs[name])) if on else
            optimal_kernel(float(knobs[name])) if knobs["interp"] == "optimal" else None
            for on, name in ((plan.profiles_deapodized, "upsample"), (plan.range_deapodized, "os_range"),
                             (plan.angle_deapodized, "os_angle")))
        self.interp = Interp(self.kind, tab_q, tab_t, plan.dq, plan.kref)   # the polar grids'
        # the polar grids' deapodized kernels: 1/Ψ at each pulse's tones on every level (tone_weights)
        self.tones = [(rates, off, deapodized_inverse(float(knobs[os]))) for on, rates, off, os in
                      ((plan.range_deapodized, plan.range_rates, plan.range_offset, "os_range"),
                       (plan.angle_deapodized, plan.angle_rates, 0.0, "os_angle")) if on]
        self.k_all = range_wavenumbers(inp.f)
        self.deap = deapodization(inp.f, plan, n_len) if self.deapodize else None
        self.work = None   # the profiles' buffers, made at the first block

    def _block_weights(self, p0, p1):
        """The weights of pulses ``p0 .. p1-1``: the window's, divided by the deapodized kernels'
        mean responses where the plan deapodizes (per pulse where it deapodizes the polar grids)."""
        from ._stage0 import tone_weights

        w, M = self.inp.w, self.inp.M
        wb = None if w is None else w[p0:p1]
        if self.deapodize:
            wb = self.deap if wb is None else wb * self.deap
            if self.tones:   # per pulse: a [pulses, M] block of its own
                wb = np.array(np.broadcast_to(wb, (p1 - p0, M)), order="C")
            k_all = self.k_all
            self.clock("profiles")
            for rates, off, (h_psi, inv_psi) in self.tones:
                tone_weights(k_all if k_all.shape[0] == 1 else k_all[p0:p1], rates[:, p0:p1], off,
                             1.0 / h_psi, inv_psi, wb)
            self.clock("tones")
        return wb

    def stage0(self, lo, hi, nthr, bar):
        """Stage 0 of sub-apertures ``lo .. hi-1`` in blocks of sub-apertures (bounded profile
        memory): their polar sub-images ``(real, imaginary)``."""
        from ._kernels import frame
        from ._stage0 import Stage0Settings, stage0
        from ..backprojection import PAD, ProfileWork, range_profiles

        inp, plan, lev, n_len = self.inp, self.plan, self.plan.levels[0], self.n_len
        settings = Stage0Settings(self.kind, inp.bistatic, n_len // 2, n_len, PAD, plan.dq, plan.kref)
        cur_re = np.empty((hi - lo, lev.n_u, lev.n_q), dtype=_STORE)
        cur_im = np.empty((hi - lo, lev.n_u, lev.n_q), dtype=_STORE)
        per = max(1, _PROFILE_BLOCK // int(lev.count.max()))
        if self.work is None:   # one set of block buffers for every block (ProfileWork)
            self.work = ProfileWork(per * int(lev.count.max()), inp.M, n_len, np.complex64)
        for s0 in range(lo, hi, per):
            s1 = min(hi, s0 + per)
            p0, p1 = int(lev.first[s0]), int(lev.first[s1 - 1] + lev.count[s1 - 1])
            pre, pim = range_profiles(self.work.samples(inp.d, slice(p0, p1)), self._block_weights(p0, p1),
                                      inp.total, n_len, nthr, dtype=np.complex64, work=self.work)
            self.clock("profiles")
            stage0((pre, pim), (lev.first[s0:s1] - p0, lev.count[s0:s1]), np.ascontiguousarray(self.pulses[:, p0:p1]),
                   self.series[s0:s1], frame(lev, s0, s1), self.tab_p, settings,
                   (cur_re[s0 - lo:s1 - lo], cur_im[s0 - lo:s1 - lo]), lev.row_table(s0, s1))
            del pre, pim
            self.clock("stage0")
            bar.update(p1 - p0)
        return cur_re, cur_im

    def subtree(self, rng, nthr, bar):
        """Stage 0 of the subtree ``rng`` (:func:`_descend`) and its merges level by level: the last
        level's sub-images ``(real, imaginary)``. Each level's grids are freed once its parents are
        formed (only a child level and its parents are held at once): no caller holds stage 0's
        grids, the largest level, through the merges."""
        from ._kernels import frame, merge as merge_stage

        cur_re, cur_im = self.stage0(*rng[0], nthr, bar)
        levels = self.plan.levels
        for l in range(1, len(levels)):
            child, parent = levels[l - 1], levels[l]
            (c0, c1), (u0, u1) = rng[l - 1], rng[l]
            pf, pc = parent.children
            nxt_re = np.empty((u1 - u0, parent.n_u, parent.n_q), dtype=_STORE)
            nxt_im = np.empty((u1 - u0, parent.n_u, parent.n_q), dtype=_STORE)
            merge_stage((cur_re, cur_im), frame(child, c0, c1), frame(parent, u0, u1), (pf[u0:u1] - c0, pc[u0:u1]),
                        self.interp, (nxt_re, nxt_im), parent.row_table(u0, u1))
            cur_re, cur_im = nxt_re, nxt_im
            del nxt_re, nxt_im
            self.clock("merge")
        return cur_re, cur_im

    def final(self, cur_re, cur_im, a0, b0, grid, img):
        """The last level's sub-images ``a0 .. b0-1`` interpolated onto ``grid``, added to ``img``,
        by bands of :data:`FINAL_COLUMNS` columns."""
        from ._kernels import final as final_stage, frame

        plan = self.plan
        fr = frame(plan.levels[-1], a0, b0)
        for c0 in range(0, grid.nx, FINAL_COLUMNS):
            c1 = min(grid.nx, c0 + FINAL_COLUMNS)
            if self.band is None or self.band.shape[1] != c1 - c0:
                self.band = np.empty((grid.ny, c1 - c0), dtype=np.complex128)
            self.band.fill(0.0)
            final_stage((cur_re, cur_im), fr, grid.x[c0:c1], grid.y, self.interp, self.band)
            img[:, c0:c1] += self.band


class _Clock:
    """Processor seconds since the last call added to ``timings[part]`` (nothing without a dict)."""

    def __init__(self, timings):
        import time

        self.timings, self.now = timings, time.process_time
        self.last = self.now() if timings is not None else 0.0

    def __call__(self, part):
        if self.timings is not None:
            t = self.now()
            self.timings[part] = self.timings.get(part, 0.0) + t - self.last
            self.last = t


def ffbp_image(data, collection, grid, **knobs):
    """:func:`ffbp` for :func:`sarcli.formers.formation.form_image`: the image and the settings
    to record (every knob, the stages and the predicted error). ``None`` knobs take :data:`DEFAULTS`;
    ``plan``: the stages made before (:func:`ffbp`)."""
    knobs = {name: v for name, v in knobs.items() if v is not None}
    img, plan = ffbp(data, collection, grid, return_plan=True, **knobs)
    params = {name: plan.knobs[name] for name in ("base", "merge", "os_range", "os_angle", "interp", "upsample")}
    params["ffbp_stages"] = [[int(lv.n), int(lv.n_u), int(lv.n_q)] for lv in plan.levels]
    params["predicted_error"] = plan.predicted_error
    return img, params
