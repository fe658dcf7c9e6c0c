"""The six families of image former as :class:`~sarcli.formers.former.Former` objects: each one's
options dataclass and its plan (:mod:`sarcli.formers.former`).

Every plan takes its predicted seconds and bytes from the one model of its family in
:mod:`sarcli.formers.planning.cost` (constants: :func:`sarcli.formers.planning.calibration.load_cost_model`) and its
predicted error from the family's error model (:mod:`sarcli.formers.ffbp.model`,
:func:`sarcli.formers.subimage.choose_tile`; ``nufft``: its ``eps``; ``direct``: 0; ``pfa``:
none, nan).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np

from ..core import geometry
from ..core.collection import Collection
from ..errors import DefocusWarning, SarcliInputError
from .planning import cost
from .former import Former, Plan
from .options import (BackprojectionOptions, DirectOptions, FfbpOptions, NufftOptions, PfaOptions,
                      SubimageOptions)

__all__ = ["FORMERS", "VIRTUAL_RANGE_PER_M", "SPHERICAL_ADVICE", "range_positions", "collection", "warn_defocus",
           "backprojection_error"]

#: Virtual stand-off range per metre of grid half-diagonal used to backproject far-field data.
VIRTUAL_RANGE_PER_M = 5.0e7
#: The formers that model the spherical wavefront, as advice names them (auto picks among them).
SPHERICAL_ADVICE = "--method auto picks among ffbp, backprojection, subimage and direct"


# ---------------------------------------------------------------------------------------------
# geometry shared by the formers
# ---------------------------------------------------------------------------------------------
def warn_defocus(ph, grid, method: str) -> None:
    """Warn with the predicted phase error at the grid's corner when a far-field former images
    spherical data."""
    acq = ph.acquisition
    if ph.model != "spherical" or not acq.has_positions:
        return
    err = geometry.farfield_phase_error(acq.range_to_center_m, acq.frequency_hz.max(), grid.half_diagonal)
    if err > geometry.DEFOCUS_WARN_RAD:
        warnings.warn(f"far-field method '{method}' on spherical data: predicted phase error "
                      f"{err:.3g} rad at the grid corner ({grid.half_diagonal:.3g} m from the centre, "
                      f"r0 = {acq.range_to_center_m.min():.4g} m); use a spherical former ({SPHERICAL_ADVICE})",
                      DefocusWarning, stacklevel=4)


def range_positions(ph, grid):
    """``(transmit, receive or None, r0)`` for the range-model formers: the acquisition's own
    (:meth:`Acquisition.range_geometry`; receive None when monostatic) for spherical data, a
    monostatic circle at a virtual range of :data:`VIRTUAL_RANGE_PER_M` × the grid's half-diagonal
    for far-field data."""
    acq = ph.acquisition
    if ph.model == "spherical":
        t, q, r0 = acq.range_geometry()
        return t, (q if acq.is_bistatic else None), r0
    r_v = VIRTUAL_RANGE_PER_M * max(grid.half_diagonal, 1e-3)
    pos = geometry.antenna_positions_circle(acq.azimuth_rad, acq.elevation_rad, r_v)
    return pos, None, np.full(acq.n_pulses, r_v)


def collection(ph, grid, weights=None):
    """:func:`range_positions` with the frequencies and window ``weights`` as a
    :class:`~sarcli.core.collection.Collection` (receive positions only when bistatic)."""
    pos, rcv, r0 = range_positions(ph, grid)
    return Collection(ph.acquisition.frequency_hz, pos, r0, weights, rcv)


def _virtual(ph, r0) -> dict:
    return {} if ph.model == "spherical" else {"virtual_range_m": float(r0[0])}


def _plan(ph, grid, options, settings, *, knobs, run, estimate, memory, notes=""):
    return Plan(options.method, options, knobs, ph, grid, settings, run, estimate, memory, notes)


def _context(ph, grid):
    """``(samples, pixels)`` of a plan (:class:`~sarcli.formers.planning.cost.Samples`)."""
    return cost.Samples.of(ph), float(grid.nx) * grid.ny


def _constants(settings, costs):
    """``(cost constants, threads)`` a plan's seconds are predicted with, read when first needed."""
    from .planning.calibration import load_cost_model

    c = load_cost_model() if costs is None else costs
    return c, cost.threads(settings.nthreads, c)


# ---------------------------------------------------------------------------------------------
# plans
# ---------------------------------------------------------------------------------------------
def plan_direct(ph, grid, options, settings, costs=None) -> Plan:
    """The exact matched filter, far-field or spherical as the data are."""
    smp, npix = _context(ph, grid)

    def run(plan, data, w):
        from .direct import direct_farfield, direct_spherical

        acq = ph.acquisition
        if ph.model == "spherical":
            t, q, r0 = range_positions(ph, grid)
            return direct_spherical(data, acq.frequency_hz, t, r0, grid, w, receive_position_m=q), {}
        kx, ky = acq.kspace()
        return direct_farfield(data, kx, ky, grid, w), {}

    return _plan(ph, grid, options, settings, knobs={}, run=run,
                 estimate=lambda: (0.0, cost.direct_seconds(smp.n_pulses, smp.n_freq, npix, settings.nthreads,
                                                             _constants(settings, costs)[0])),
                 memory=lambda: cost.form_image_bytes("direct", smp, grid))


def _nufft_seconds(smp, grid, eps, settings, costs) -> float:
    c, thr = _constants(settings, costs)
    return cost.nufft_seconds(c, smp.n_pulses * smp.n_freq, grid.ny, grid.nx, eps, thr)


def plan_nufft(ph, grid, options, settings, costs=None) -> Plan:
    """One type-1 NUFFT at ``options.eps`` (far-field data; spherical data: a warning)."""
    smp, npix = _context(ph, grid)

    def run(plan, data, w):
        from .nufft import nufft_farfield

        warn_defocus(ph, grid, "nufft")
        kx, ky = ph.acquisition.kspace()
        return nufft_farfield(data, kx, ky, grid, w, eps=options.eps, nthreads=settings.nthreads), {"eps": options.eps}

    return _plan(ph, grid, options, settings, knobs=options.knobs(), run=run,
                 estimate=lambda: (options.eps, _nufft_seconds(smp, grid, options.eps, settings, costs)),
                 memory=lambda: cost.form_image_bytes("nufft", smp, grid))


def plan_pfa(ph, grid, options, settings, costs=None) -> Plan:
    """Gridding onto a Cartesian k-grid, then an FFT (no error or time model: nan)."""
    smp = cost.Samples.of(ph)

    def run(plan, data, w):
        from .pfa import pfa_image, regrid_polar

        warn_defocus(ph, grid, "pfa")
        kx, ky = ph.acquisition.kspace()
        kg = regrid_polar(data, kx, ky, w, pixel_m=(grid.dx, grid.dy), shape=grid.shape, center_m=(grid.cx, grid.cy),
                          options=options)
        return pfa_image(kg, grid), options.knobs()

    return _plan(ph, grid, options, settings, knobs=options.knobs(), run=run,
                 estimate=lambda: (math.nan, math.nan),
                 memory=lambda: cost.form_image_bytes("pfa", smp, grid, acq=ph.acquisition,
                                                      oversample=options.oversample))


def backprojection_error(ph, grid, interp: str, upsample: float, tiling) -> float:
    """Backprojection's predicted error: the profile interpolation's, the frequencies' departure
    from a line, and the range model's per tile (``tiling``, :func:`sarcli.formers.backprojection._setup.tiling_for`)."""
    from .ffbp.model import frequency_error, interp_error

    pos, _, _ = range_positions(ph, grid)
    return interp_error(interp, float(upsample)) + frequency_error(ph.acquisition.frequency_hz, pos, grid) + tiling.error


def plan_backprojection(ph, grid, options, settings, costs=None) -> Plan:
    """Range profiles interpolated per pixel and pulse; :attr:`Plan.prepare` makes the
    :class:`~sarcli.formers.backprojection.Backprojector` for many images of the same samples."""
    smp, npix = _context(ph, grid)
    up, it = options.upsample, options.interp

    def run(plan, data, w):
        from .backprojection import backproject

        col = collection(ph, grid, w)
        img = backproject(data, col, grid, options, nthreads=settings.nthreads)
        return img, {**options.knobs(), **_virtual(ph, col.range_to_center_m)}

    def estimate():
        from .backprojection import tiling_for

        pos, rcv, _ = range_positions(ph, grid)
        tiling = tiling_for(ph.acquisition.frequency_hz, pos, rcv, grid, up, options.precision, it)
        c, thr = _constants(settings, costs)
        return (backprojection_error(ph, grid, it, up, tiling),
                cost.bp_seconds(c, smp.n_pulses, smp.n_freq, npix, it, up, tiling.cost, thr))

    def prepare(data=None):
        from .backprojection import Backprojector

        col = collection(ph, grid, settings.weights(ph.data.shape)).with_(frequency_hz=ph.acquisition.frequencies_2d)
        d = ph.data if data is None else data
        return Backprojector(d, col, grid, options, nthreads=settings.nthreads)

    plan = _plan(ph, grid, options, settings, knobs=options.knobs(), run=run, estimate=estimate,
                 memory=lambda: cost.form_image_bytes("backprojection", smp, grid, upsample=up,
                                                      precision=options.precision))
    plan.prepare = prepare
    return plan


def plan_ffbp(ph, grid, options, settings, costs=None) -> Plan:
    """ffbp's stages for these data and grid (:func:`sarcli.formers.ffbp.plan_stages`), with the
    knobs the planner picks at ``options.tolerance`` when none is given (spherical data)."""
    from .backprojection import profile_length
    from .ffbp import plan_stages

    smp, npix = _context(ph, grid)
    knobs = {n: v for n, v in options.knobs().items() if n != "tolerance" and v is not None}
    extra = {}
    if options.picked() and ph.model == "spherical":
        from .planning.planner import ffbp_knobs

        picked = ffbp_knobs(ph, grid, options.tolerance, nthreads=settings.nthreads, costs=costs)
        if picked is not None:
            knobs = {n: picked[n] for n in ("base", "merge", "os_range", "os_angle", "upsample", "interp")}
            extra["knobs_for_tolerance"] = options.tolerance
    pos, rcv, r0 = range_positions(ph, grid)
    acq = ph.acquisition
    f = np.asarray(acq.frequency_hz, dtype=np.float64)
    bistatic = rcv is not None and not np.array_equal(pos, rcv)   # as ffbp decides it
    stages = plan_stages(pos, f[None, :] if f.ndim == 1 else f, grid, receive_position_m=rcv if bistatic else None,
                         **knobs)

    def run(plan, data, w):
        from .ffbp import ffbp_image

        img, params = ffbp_image(data, Collection(acq.frequency_hz, pos, r0, w, rcv), grid,
                                 nthreads=settings.nthreads, plan=stages, **knobs)
        return img, {**extra, **params, **_virtual(ph, r0)}

    def estimate():
        c, thr = _constants(settings, costs)
        length = profile_length(smp.n_freq, stages.knobs["upsample"])
        return stages.predicted_error, cost.ffbp_seconds(c, stages.ops, smp.n_pulses, length, thr)

    return _plan(ph, grid, options, settings, knobs=dict(stages.knobs), run=run, estimate=estimate,
                 memory=lambda: cost.form_image_bytes("ffbp", smp, grid, grid_bytes=stages.ops["grid_bytes"]),
                 notes=f"{stages.n_stages} stages")


def plan_subimage(ph, grid, options, settings, costs=None) -> Plan:
    """Spherical data: the tile given or the largest predicted to meet ``options.tolerance``
    (:func:`sarcli.formers.subimage.choose_tile`); far-field data: one tile, nufft at ``eps``."""
    smp, npix = _context(ph, grid)
    acq = ph.acquisition
    if ph.model != "spherical":   # one tile is exact
        eps = cost.NUFFT_EPS if options.eps is None else options.eps
        nufft = plan_nufft(ph, grid, NufftOptions(eps=eps), settings, costs)

        def run_one(plan, data, w):
            img, _ = nufft.run(nufft, data, w)
            return img, {"tile": max(grid.nx, grid.ny), "eps": eps, "predicted_error": eps, "n_tiles": 1}

        return _plan(ph, grid, options, settings, knobs={"tile": max(grid.nx, grid.ny), "eps": eps},
                     run=run_one, estimate=nufft.estimate, memory=nufft.memory, notes="1 tile")
    from .subimage import choose_tile, predict_tile_error

    pos, rcv, r0 = range_positions(ph, grid)
    f = np.broadcast_to(np.asarray(acq.frequency_hz, float), ph.data.shape)
    eps = options.tolerance / 10 if options.eps is None else float(options.eps)
    tile = options.tile
    if tile is None:
        tile, pred = choose_tile(pos, rcv, r0, f, grid, options.tolerance, eps=options.eps)
        if tile is None:
            raise SarcliInputError(f"no sub-image size meets tolerance {options.tolerance:g} here (smallest tile: "
                                   f"predicted {pred:.3g}); use ffbp or backprojection")
    tile = int(tile)
    n_tiles = cost.n_tiles(grid, tile)

    def run(plan, data, w):
        from .subimage import subimage_nufft

        return subimage_nufft(data, Collection(acq.frequency_hz, pos, r0, w, rcv), grid, replace(options, tile=tile),
                              nthreads=settings.nthreads, return_info=True)

    def estimate():
        c, thr = _constants(settings, costs)
        return (predict_tile_error(pos, rcv, r0, f, grid, tile, eps=eps),
                cost.subimage_seconds(c, smp.n_pulses * smp.n_freq, n_tiles, eps, thr))

    return _plan(ph, grid, options, settings, knobs={"tile": tile, "eps": eps}, run=run, estimate=estimate,
                 memory=lambda: cost.form_image_bytes("subimage", smp, grid, threads=_constants(settings, costs)[1]),
                 notes=f"{n_tiles} tiles")


#: Every family, by method name.
FORMERS = {f.method: f for f in (
    Former("direct", DirectOptions, plan_direct),
    Former("nufft", NufftOptions, plan_nufft),
    Former("pfa", PfaOptions, plan_pfa),
    Former("backprojection", BackprojectionOptions, plan_backprojection),
    Former("ffbp", FfbpOptions, plan_ffbp),
    Former("subimage", SubimageOptions, plan_subimage),
)}
