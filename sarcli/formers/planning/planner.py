"""Choose the cheapest image former predicted to meet an accuracy: ``--method auto --tolerance``.

"Leave out what a given scene does not need." For a phase history, a grid and a tolerance TOL on the
relative error against the exact matched filter, :func:`candidates` lists every former with the
knobs its error model predicts to meet TOL, and :func:`recommend` picks the cheapest:

- far-field data: ``nufft`` with ``eps = TOL/10`` (its error is ~eps);
- spherical data: ``subimage`` (tile from the predicted curvature error,
  :mod:`sarcli.formers.subimage`), ``ffbp`` (knobs from :func:`sarcli.formers.ffbp.plan_stages`'s
  predicted error), ``backprojection`` (profile oversampling and interpolator from the same
  interpolation error model), and ``direct`` (exact, the slowest);
- an O(N²P) former (backprojection, direct) is never picked when a NUFFT former meets TOL.

Predicted times come from operation counts times per-operation constants
(:mod:`sarcli.formers.planning.calibration`: measured on this machine once ``sar plan`` has calibrated
it, else those of the reference machine shipped with the package); :func:`command_seconds` adds
what the whole command pays besides (start-up, reading, writing). Memory is the formers' largest
arrays.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import threading
from collections import OrderedDict
from dataclasses import dataclass, field, replace

import numpy as np

from ...core.grid import Grid
from ...errors import SarcliInputError
from ..options import OPTIONS, SubimageOptions
from .calibration import (DEFAULT_COSTS, best_of, command_costs, fft_cost, load_cost_model, save_cost_model,
                          touch_cost)
from .cost import (FFBP_PARTS, FFBP_TERMS, Samples, bp_constants, bp_seconds, direct_seconds, ffbp_counts, ffbp_seconds,
                   form_image_bytes, n_tiles, nufft_seconds, nufft_width, read_seconds, subimage_seconds, threads,
                   write_seconds)

__all__ = ["Candidate", "candidates", "recommend", "same_run", "ffbp_knobs", "command_seconds", "load_cost_model", "calibrate"]

#: Profile upsamplings tried for backprojection, smallest first (steps of 25% to 50%: the
#: interpolators' errors fall as 1/u³ (Keys) and 1/u⁴ (Lagrange), so each step divides them by 2 to 5).
_BP_UPSAMPLES = (2, 4, 6, 8, 10, 12, 16, 24, 32)
_NUFFT = ("nufft", "subimage")
#: A candidate "meets" TOL when its predicted error is at most TOL / SAFETY: the error models are
#: within 3x of measured, mostly above it, but measured ran up to 1.4x above prediction (ffbp,
#: base 32, os 2 on a 512² simulated circle), so auto keeps a factor 2 in hand.
SAFETY = 2.0


@dataclass
class Candidate:
    """One former with its knobs (resolved: what runs), predicted error, time (s) and memory
    (bytes); ``options``: the former's options that run it (:mod:`sarcli.formers.options`; by
    default those of ``knobs``), ``default``: whether they are the former's defaults (what
    ``--method`` runs with no knob)."""

    method: str
    knobs: dict
    predicted_error: float
    seconds: float
    memory: float
    notes: str = ""
    meets: bool = field(default=False)
    options: object = None
    default: bool = False

    def __post_init__(self):
        if self.options is None:
            self.options = OPTIONS[self.method].from_knobs(self.knobs)

    def flags(self) -> list:
        """The ``sar form-image`` flags that run this candidate."""
        return self.options.flags()

    def as_dict(self) -> dict:
        err = None if math.isnan(self.predicted_error) else self.predicted_error
        sec = None if math.isnan(self.seconds) else self.seconds
        return {"method": self.method, "knobs": self.knobs, "predicted_error": err, "predicted_s": sec,
                "memory_bytes": self.memory, "meets": self.meets, "default": self.default,
                "flags": self.flags()}


#: Candidate lists kept by :func:`candidates`, the most recently used last (a few collections
#: and grids: an image formed again, or by several formers, is planned once).
_CANDIDATE_CACHE: "OrderedDict[tuple, list]" = OrderedDict()
_CANDIDATE_CACHE_SIZE = 16
_CANDIDATE_LOCK = threading.Lock()


def _digest(*arrays) -> bytes:
    """A digest of arrays' shapes, types and bytes (``None`` as such): the cache key of the
    geometry a plan depends on."""
    h = hashlib.blake2b(digest_size=16)
    for a in arrays:
        if a is None:
            h.update(b"none;")
            continue
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape};".encode())
        h.update(a.data)
    return h.digest()


def candidates(ph, grid: Grid, tolerance: float, *, costs=None, nthreads=None, prune=False,
               methods=None) -> list:
    """Every former with knobs predicted to meet ``tolerance`` (and a few that do not, marked).

    "Meets" means a predicted error at most ``tolerance / SAFETY`` (:data:`SAFETY`). ``prune``:
    leave out candidates that cannot change :func:`recommend`'s pick (what it passes).
    ``methods``: only these formers (``direct`` is always listed).

    The list depends on the collection's geometry, not on its samples: it is kept (a few, most
    recently used) under a digest of the geometry, the grid, the arguments and the cost model, so
    forming the same scene again plans once; each call gets its own copies."""
    if not (0 < tolerance < 1):
        raise SarcliInputError(f"--tolerance must lie in (0, 1), got {tolerance}")
    c = load_cost_model() if costs is None else costs
    acq = ph.acquisition
    geo = acq.range_geometry() if ph.model == "spherical" else (None, None, None)
    from .._samples import is_lazy

    # the samples' dtype and whether they stay on disk set the candidates' memory
    key = (ph.model, tuple(ph.data.shape), str(np.dtype(ph.data.dtype)), is_lazy(ph.data), grid, float(tolerance),
           nthreads, bool(prune),
           None if methods is None else tuple(sorted(methods)), acq.is_bistatic if ph.model == "spherical" else None,
           json.dumps(c, sort_keys=True, default=repr), _digest(acq.frequency_hz, *geo))
    with _CANDIDATE_LOCK:   # images formed in threads (sar batch) share the cache
        hit = _CANDIDATE_CACHE.get(key)
        if hit is not None:
            _CANDIDATE_CACHE.move_to_end(key)
    if hit is None:
        hit = _candidates(ph, grid, tolerance, c, nthreads, prune, methods)
        with _CANDIDATE_LOCK:
            _CANDIDATE_CACHE[key] = hit
            while len(_CANDIDATE_CACHE) > _CANDIDATE_CACHE_SIZE:
                _CANDIDATE_CACHE.popitem(last=False)
    return [replace(x, knobs=dict(x.knobs)) for x in hit]


def _candidates(ph, grid, tolerance, c, nthreads, prune, methods) -> list:
    """:func:`candidates`, uncached (``c`` the cost model)."""
    from ..backprojection import TilingInputs
    from ..backprojection import DEFAULT_PRECISION
    from ..ffbp.model import frequency_error, interp_error
    from ..subimage import choose_tile, tile_sizes

    thr = threads(nthreads, c)
    acq = ph.acquisition
    P, M = ph.data.shape
    npix = float(grid.nx) * grid.ny
    smp = Samples.of(ph)
    out = [Candidate("direct", {}, 0.0, direct_seconds(P, M, npix, nthreads, c), form_image_bytes("direct", smp, grid))]
    target = tolerance / SAFETY
    eps = max(tolerance / 10, 1e-14)
    def wanted(name):
        return methods is None or name in methods

    if ph.model != "spherical":
        if wanted("nufft"):
            out.append(Candidate("nufft", {"eps": eps}, eps, nufft_seconds(c, P * M, grid.ny, grid.nx, eps, thr),
                                 form_image_bytes("nufft", smp, grid)))
    else:
        pos, rcv, _ = acq.range_geometry()
        rcv = rcv if acq.is_bistatic else None
        f = acq.frequency_hz
        e_freq = frequency_error(f, pos, grid)
        # ffbp: a small sweep of its knobs (first: with ``prune`` the slower formers are measured
        # against its pick)
        ff = []
        if wanted("ffbp"):
            e_ffbp = e_freq if rcv is None else frequency_error(f, 0.5 * (pos + rcv), grid)
            ff = _ffbp_sweep(pos, rcv, f, grid, target, e_ffbp, c, thr, keep_unmet=not prune,
                             samples=smp)
        best_ffbp = min((x.seconds for x in ff if x.predicted_error <= target), default=math.inf)
        # backprojection: the profile interpolation (and unequal frequency spacing) is its error;
        # with ``prune`` not looked at where even its shortest profiles are slower than ffbp's pick
        # the range model and tile width backprojection would choose at each upsampling
        tiled = functools.lru_cache(maxsize=None)(TilingInputs(f, pos, rcv, grid).tiling) \
            if wanted("backprojection") else None
        for interp in ("lagrange", "cubic", "lanczos", "linear") if wanted("backprojection") else ():
            def seconds(up):
                return bp_seconds(c, P, M, npix, interp, up, tiled(up, interp=interp).cost, thr)
            if prune and seconds(_BP_UPSAMPLES[0]) > best_ffbp:
                continue
            for up in _BP_UPSAMPLES:
                e = interp_error(interp, float(up)) + e_freq + tiled(up, interp=interp).error
                if e <= target or up == _BP_UPSAMPLES[-1]:
                    out.append(Candidate("backprojection", {"upsample": up, "interp": interp}, e, seconds(up),
                                         form_image_bytes("backprojection", smp, grid, upsample=up,
                                                          precision=DEFAULT_PRECISION)))
                    break
        out += ff
        # subimage NUFFT: with ``prune``, where ffbp's pick is the cheapest candidate that meets
        # the target, only tiles large enough to beat it are of use (and none if one tile cannot)
        def sub_seconds(tile):
            return subimage_seconds(c, P * M, n_tiles(grid, tile), eps, thr)
        met = [x for x in out if x.predicted_error <= target]
        min_tile = None
        if prune and best_ffbp <= min(x.seconds for x in met):
            min_tile = min((s for s in tile_sizes(grid) if sub_seconds(s) < best_ffbp), default=math.inf)
        if wanted("subimage") and min_tile != math.inf:
            tile, pred = choose_tile(pos, rcv, acq.range_to_center_m, f, grid, target, eps=eps, min_tile=min_tile)
            if tile is not None:
                out.append(Candidate("subimage", {"tile": int(tile), "tolerance": tolerance}, pred, sub_seconds(tile),
                                     form_image_bytes("subimage", smp, grid, threads=thr), f"{n_tiles(grid, tile)} tiles"))
    for cand in out:
        cand.meets = cand.predicted_error <= target
    return sorted(out, key=lambda x: (not x.meets, x.seconds))


#: ffbp's polar-grid oversamplings ``(os_range, os_angle)`` the planner tries, in order of cost (the
#: polar kernels are deapodized where the plan finds it pays), and its base sub-apertures.
FFBP_OVERSAMPLINGS = ((1.5, 1.5), (1.5, 2.0), (2.0, 2.0), (1.5, 2.5), (2.0, 2.5), (1.5, 3.0), (3.0, 3.0), (4.0, 4.0),
                      (6.0, 6.0))
FFBP_BASES = (8, 16, 32)
#: Oversampling pairs tried past the first at which some base meets the target: the costs grow with
#: the oversampling, so a few are enough, and auto's planning stays well below a small image's time.
FFBP_PAIRS_PAST_MET = 2
#: :meth:`sarcli.formers.ffbp.StageLayout.error_floor` is trusted to this relative margin (its sums
#: are taken in another order than the plan's).
_FLOOR_MARGIN = 1e-9


def _ffbp_sweep(pos, rcv, f, grid, target, e_freq, c, thr, *, keep_unmet, samples):
    """ffbp's candidates: the cheapest setting predicted to meet ``target`` among
    :data:`FFBP_BASES` × :data:`FFBP_OVERSAMPLINGS` (the pairs up to :data:`FFBP_PAIRS_PAST_MET`
    past the first at which one meets), and with ``keep_unmet`` the most accurate one that does
    not (ties: the earlier in the sweep's order).

    The same as planning every setting of those pairs fully, with less work. Every setting is laid
    out (:func:`sarcli.formers.ffbp.layout_stages`: its sub-apertures and polar frames), which bounds
    its error from below (:meth:`~sarcli.formers.ffbp.StageLayout.error_floor`); only where that
    floor meets the target are its grids sized (its time), and only where it may be the answer is
    its error model completed. The pair at which one first meets is found in order, the cheapest
    setting of each pair first; then the settings of the pairs tried are completed in order of
    time until one meets: that one is the cheapest. ``samples``: the collection's
    :class:`~sarcli.formers.planning.cost.Samples`."""
    from .. import ffbp as fb
    from ..backprojection import profile_length
    from ..ffbp.model import deapodized_error, default_upsample

    P, M = samples.n_pulses, samples.n_freq

    class Setting:
        def __init__(self, order, lay):
            self.order, self.lay = order, lay

        @functools.cached_property
        def seconds(self):
            return ffbp_seconds(c, self.lay.ops, P, profile_length(M, self.lay.knobs["upsample"]), thr)

        @functools.cached_property
        def rough_floor(self):   # the floor short of the angular kernel's error
            return self.lay.error_floor(e_freq, above=-math.inf) * (1 - _FLOOR_MARGIN)

        @functools.cached_property
        def floor(self):
            return self.lay.error_floor(e_freq) * (1 - _FLOOR_MARGIN)

        @functools.cached_property
        def plan(self):
            return self.lay.plan(e_freq)

        def may_meet(self):
            return self.rough_floor <= target and self.floor <= target

        def meets(self):
            return self.may_meet() and self.plan.predicted_error <= target

    settings, met_at = [], None
    for i, (os_r, os_a) in enumerate(FFBP_OVERSAMPLINGS):
        if met_at is not None and i > met_at + FFBP_PAIRS_PAST_MET:
            break
        # profiles: a multiple of os_range (their aliases then land on their own tones) whose
        # deapodized error is well inside the target
        up = default_upsample(os_r)
        while deapodized_error(up) > target / 8 and up < 16 * os_r:
            up *= 2
        pair = []
        for j, base in enumerate(FFBP_BASES):
            try:
                pair.append(Setting((i, j), fb.layout_stages(pos, f, grid, base=base, os_range=os_r, os_angle=os_a,
                                                               upsample=up, interp="optimal", receive_position_m=rcv)))
            except SarcliInputError:
                continue
        settings += pair
        if met_at is None and any(x.meets() for x in _by_time([x for x in pair if x.rough_floor <= target])):
            met_at = i
    best = next((x for x in _by_time([x for x in settings if x.rough_floor <= target]) if x.meets()), None)
    out = [] if best is None else [_ffbp_candidate(best.lay, best.plan, best.seconds, samples)]
    if keep_unmet:   # the most accurate that misses: in order of floor, until the floor passes it
        miss = None
        for x in sorted(settings, key=lambda x: (x.floor, x.order)):
            if miss is not None and (x.floor, x.order) > (miss.plan.predicted_error, miss.order):
                break
            e = x.plan.predicted_error
            if e > target and (miss is None or (e, x.order) < (miss.plan.predicted_error, miss.order)):
                miss = x
        if miss is not None:
            out.append(_ffbp_candidate(miss.lay, miss.plan, miss.seconds, samples))
    return out


def _by_time(settings) -> list:
    """``settings`` in order of time, ties in the sweep's order."""
    return sorted(settings, key=lambda x: (x.seconds, x.order))


def _ffbp_candidate(lay, plan, seconds, samples) -> Candidate:
    from .. import ffbp as fb

    knobs = plan.knobs
    return Candidate("ffbp", {"base": knobs["base"], "merge": fb.DEFAULTS["merge"], "os_range": knobs["os_range"],
                              "os_angle": knobs["os_angle"], "interp": "optimal", "upsample": knobs["upsample"]},
                     plan.predicted_error, seconds,
                     form_image_bytes("ffbp", samples, lay.grid, grid_bytes=plan.ops["grid_bytes"]),
                     f"{plan.n_stages} stages")


def same_run(a: Candidate, b: Candidate) -> bool:
    """Whether candidate ``b`` runs what ``a`` runs: the same former, every knob of ``b`` (but the
    tolerance its knobs were picked for) as ``a`` has it, and the same predicted error."""
    return (a.method == b.method and all(a.knobs.get(k) == v for k, v in b.knobs.items() if k != "tolerance")
            and math.isclose(a.predicted_error, b.predicted_error, rel_tol=1e-9, abs_tol=0.0))


def recommend(ph, grid: Grid, tolerance: float, *, nthreads=None, costs=None) -> Candidate:
    """The cheapest candidate predicted to meet ``tolerance``; O(N²P) formers only when no NUFFT
    former meets it. Raises :class:`SarcliInputError` for a tolerance outside (0, 1)."""
    cands = [x for x in candidates(ph, grid, tolerance, costs=costs, nthreads=nthreads, prune=True) if x.meets]
    if any(x.method in _NUFFT for x in cands):
        cands = [x for x in cands if x.method not in ("backprojection", "direct")]
    return min(cands, key=lambda x: x.seconds)   # direct always meets


def ffbp_knobs(ph, grid: Grid, tolerance: float, *, nthreads=None, costs=None) -> dict | None:
    """ffbp's knobs as ``auto`` would pick them at ``tolerance``: the cheapest ffbp predicted to meet
    it, else the most accurate one planned; None for far-field data (ffbp's defaults serve)."""
    if ph.model != "spherical":
        return None
    ff = [x for x in candidates(ph, grid, tolerance, costs=costs, nthreads=nthreads, methods=("ffbp",))
          if x.method == "ffbp"]
    if not ff:
        return None
    met = [x for x in ff if x.meets]
    return dict(min(met, key=lambda x: x.seconds).knobs if met else min(ff, key=lambda x: x.predicted_error).knobs)


def command_seconds(cand: Candidate, ph, grid: Grid, costs=None, *, auto=False, tolerance=None, load=None,
                    nthreads=None) -> float:
    """Predicted wall time of the whole ``sar form-image`` command for ``cand``: start-up (imports,
    kernel loads), reading the data, the formation, writing the image, and for ``auto`` the
    planning too, from the calibrated constants (:func:`calibrate`). ``tolerance``: the command's
    ``--tolerance`` (with the samples' type, the stored image's).

    On an idle machine, unless ``load`` (a :class:`sarcli._util.load.Load`) is given: then the
    formation, on its ``nthreads`` (default: the cost model's), and the rest, on one thread, are
    each stretched by what the other runnable threads take of the processors
    (:meth:`~sarcli._util.load.Load.slowdown`)."""
    from ...io.hdf5 import stored_image_dtype

    c = load_cost_model() if costs is None else costs
    P, M = ph.data.shape
    # the samples at their stored size; the image as `sar form-image` stores it
    image = stored_image_dtype(ph.data.dtype, tolerance=tolerance).itemsize
    io = read_seconds(c, np.dtype(ph.data.dtype).itemsize * P * M) + write_seconds(c, image * grid.nx * grid.ny)
    rest = c["startup"] + (c["planning"] if auto else 0.0) + io
    if load is None:
        return rest + cand.seconds
    return rest * load.slowdown(1) + cand.seconds * load.slowdown(threads(nthreads, c))


#: Least share of its default-ratio value each of ffbp's fitted constants keeps (every term costs
#: something; six settings do not always separate four terms).
FFBP_FLOOR = 0.1


def _fit_ffbp(rows, rhs, names=None) -> np.ndarray:
    """ffbp's constants ``names`` (default: all of :data:`FFBP_TERMS`) from operation counts
    ``rows`` [settings, terms] and measured seconds ``rhs``: non-negative least squares above a
    floor of :data:`FFBP_FLOOR` times the default constants scaled to the settings' time, so no
    constant is 0."""
    from scipy.optimize import nnls

    names = [name for name, _ in FFBP_TERMS] if names is None else names
    default = np.array([DEFAULT_COSTS[name] for name in names])
    floor = FFBP_FLOOR * default * float(np.sum(rhs)) / max(float(np.sum(rows @ default)), 1e-300)
    scale = np.maximum(np.max(rows, axis=0), 1e-300)
    return floor + nnls(rows / scale, np.maximum(rhs - rows @ floor, 0.0))[0] / scale


def calibrate(path=None, *, repeat: int = 3) -> dict:
    """Measure the constants on this machine and write them to ``path`` (default: this machine's
    file in the user's cache, :func:`sarcli.formers.planning.calibration.user_cost_model_path`; the shipped
    reference is :data:`~sarcli.formers.planning.calibration.COST_MODEL_PATH`); returns them.

    Small instances of every former (a few seconds in all); each constant is its measured time
    (best of ``repeat``) divided by its operation count, except ffbp's (:data:`FFBP_TERMS`):
    six settings with different shares of each term are formed, each part's processor seconds
    (``timings`` of :func:`sarcli.formers.ffbp.ffbp`, so that other jobs on the machine do not
    inflate them) fitted by non-negative least squares to its own counts (:data:`FFBP_PARTS`,
    :func:`_fit_ffbp`), and the first touch of fresh memory timed on arrays too large to be
    recycled; then the whole command's start-up, planning, reading and writing.
    """
    from ...core import geometry
    from .. import ffbp as fb
    from ..direct import direct_spherical
    from ..nufft import nufft_farfield
    from ...core.collection import Collection
    from ..subimage import subimage_nufft

    def best(fn):
        return best_of(fn, repeat)

    P, M, N = 256, 256, 256
    freq = 9.6e9 + 2e6 * np.arange(M)
    az = np.radians(np.linspace(-3, 3, P))
    a = geometry.antenna_positions_circle(az, np.radians(30), 10e3)
    r0 = np.linalg.norm(a, axis=1)
    rng = np.random.default_rng(0)
    d = rng.normal(size=(P, M)) + 1j * rng.normal(size=(P, M))
    grid = Grid(N, N, 0.25, 0.25)
    thr = 2
    c = {"threads": thr}
    c["bp_fft"], c["bp"] = bp_constants(best, d, freq, a, r0, grid, thr)
    small = Grid(32, 32, 0.5, 0.5)
    c["direct"] = best(lambda: direct_spherical(d, freq, a, r0, small)) * thr / (P * M * 32 * 32)
    # ffbp: settings whose shares of stage 0 (per pulse-node tap and per node), interpolation taps
    # and (node, child) pairs differ; non-negative least squares gives the four constants
    rows, parts = [], []
    for knobs in ({}, {"base": 8}, {"base": 32}, {"base": 4}, {"os_range": 2.0, "os_angle": 2.0},
                  {"base": 8, "os_range": 3.0, "os_angle": 3.0}):
        plan = fb.plan_stages(a, freq, grid, **knobs)
        runs = []
        for _ in range(repeat + 1):   # the first warms up
            runs.append({})
            fb.ffbp(d, Collection(freq, a, r0), grid, timings=runs[-1], **knobs)
        parts.append(min(runs[1:], key=lambda t: sum(t.values())))
        rows.append(ffbp_counts(plan.ops))
    rows = np.array(rows)
    names = [name for name, _ in FFBP_TERMS]
    for part, fitted in FFBP_PARTS.items():
        cols = [names.index(name) for name in fitted]
        rhs = np.array([t.get(part, 0.0) for t in parts])
        for name, v in zip(fitted, _fit_ffbp(rows[:, cols], rhs, list(fitted))):
            c[name] = float(v)
    c["ffbp_touch"] = touch_cost(repeat)
    c["bp_fft"] = fft_cost(repeat, thr)
    kx, ky = geometry.kspace_coordinates(freq, az, np.radians(30))
    w = nufft_width(1e-6)
    t = best(lambda: nufft_farfield(d, kx, ky, grid, eps=1e-6)) * thr
    n_fft = 4.0 * N * N
    c["nufft_fft"] = DEFAULT_COSTS["nufft_fft"]
    c["nufft_spread"] = max(1e-11, (t - c["nufft_fft"] * n_fft * math.log2(n_fft)) / (P * M * w * w))
    tile = 16
    t = best(lambda: subimage_nufft(d, Collection(freq, a, r0), grid, SubimageOptions(tile=tile, eps=1e-3))) * thr
    c["subimage_point"] = t / ((N // tile) ** 2 * P * M * nufft_width(1e-3) ** 2)
    c.update(command_costs(repeat))
    from ...core.acquisition import Acquisition
    from ...core.types import PhaseHistory

    ph = PhaseHistory(d, Acquisition(freq, az, np.full(P, np.radians(30)), grid, antenna_position_m=a,
                                     range_to_center_m=r0, model="spherical"))
    c["planning"] = best_of(lambda: recommend(ph, grid, 1e-3, costs=dict(DEFAULT_COSTS, **c)), repeat)
    save_cost_model(c, path)
    return c
