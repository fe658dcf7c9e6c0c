"""Cost of image formation before it starts: knob ranges, memory and time estimates.

The command line checks every size-driving knob here before anything is allocated
(:func:`check_form_image`, :func:`check_regularize`); beyond the memory limit
(:func:`sarcli._util.resources.memory_limit`, ``sar --max-memory``) the run is refused with the
estimate and the limit. The estimates are upper-bound models of each former's working arrays
(bytes), not measurements; the time warning of the exact ``direct`` former takes the spherical
sum's rate from the planner's cost model of this machine and the far field's from
:data:`DIRECT_RATE`.
"""

from __future__ import annotations

import math
import os
import warnings

import numpy as np

from .._util.resources import check_memory
from ..core import sampling
from ..errors import SarcliInputError, SarcliWarning

__all__ = ["UPSAMPLE_RANGE", "OVERSAMPLE_RANGE", "WIDTH_RANGE", "EPS_RANGE", "check_knobs",
           "form_image_bytes", "direct_seconds", "bp_seconds", "bp_units", "bp_constants", "check_form_image", "regularize_bytes", "check_regularize",
           "DIRECT_WARN_S"]

#: backprojection range-profile upsampling (1: no upsampling; 64 reaches 1e-5 peak accuracy)
UPSAMPLE_RANGE = (1.0, 64.0)
#: PFA k-grid oversampling (the kernel design needs >= 1.25)
OVERSAMPLE_RANGE = (1.25, 16.0)
#: PFA Kaiser-Bessel kernel width in cells
WIDTH_RANGE = (2, 16)
#: NUFFT requested accuracy (FINUFFT's reachable range in float64)
EPS_RANGE = (1e-15, 1e-1)
#: sample x pixel terms per second of ``direct`` per core, far field (BLAS products): a
#: conservative rate, used only to warn before a long run; the spherical sum's rate is the
#: planner's calibrated constant
DIRECT_RATE = {"farfield": 8e8}
#: estimated ``direct`` run time (s) beyond which a faster method is suggested first
DIRECT_WARN_S = 30.0
_C16 = 16


def check_knobs(*, upsample=None, oversample=None, width=None, eps=None) -> None:
    """Refuse a former knob outside its range (:data:`UPSAMPLE_RANGE` and friends)."""
    for name, value, (lo, hi) in (("upsample", upsample, UPSAMPLE_RANGE), ("oversample", oversample, OVERSAMPLE_RANGE),
                                  ("width", width, WIDTH_RANGE), ("eps", eps, EPS_RANGE)):
        if value is None:
            continue
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise SarcliInputError(f"{name} must be a number in [{lo:g}, {hi:g}], got {str(value)[:40]!r}") from None
        if not (np.isfinite(v) and lo <= v <= hi):
            raise SarcliInputError(f"{name} must be in [{lo:g}, {hi:g}], got {v:g}")


def _kgrid_cells(acq, grid, oversample) -> float:
    """Cells of the PFA k-grid: the bounding box of the k-space samples at the grid's k spacing."""
    from ..core.geometry import kspace_coordinates

    f = np.asarray(acq.frequency_hz, dtype=np.float64)
    fr = f if f.ndim == 1 else f.ravel()
    ends = np.array([fr.min(), fr.max()])
    kx, ky = kspace_coordinates(ends, acq.azimuth_rad, acq.elevation_rad)
    dkx = 2 * np.pi / (oversample * grid.nx * grid.dx)
    dky = 2 * np.pi / (oversample * grid.ny * grid.dy)
    return (np.ptp(kx) / dkx + 1) * (np.ptp(ky) / dky + 1)


def form_image_bytes(method, n_pulses, n_freq, grid, *, model="farfield", acq=None, oversample=2.0,
                     upsample=8.0, precision="float64", streamed=False, itemsize=_C16) -> float:
    """Upper-bound estimate of the peak working memory (bytes) of :func:`form_image`.

    ``streamed``: the samples are left on disk (a :class:`sarcli.io.pulses.PulseSource`); the formers
    that read them by blocks of pulses (backprojection, ffbp, the spherical matched filter) then
    hold one block, not the collection. ``itemsize``: bytes per stored sample (8 for complex64,
    16 for complex128); the weighted copy the formers work on is complex128.
    """
    pm = float(n_pulses) * float(n_freq)
    npix = float(grid.nx) * float(grid.ny)
    if streamed and (method in ("backprojection", "ffbp") or method == "direct" and model == "spherical"):
        from ._bp_setup import BLOCK

        pm = min(float(n_pulses), float(BLOCK)) * float(n_freq)  # one block of pulses
    base = pm * (itemsize + _C16) + 2 * npix * _C16  # data + weighted copy, image + accumulator
    if method == "direct":
        return base + (npix * 24 if model == "spherical" else 0) + 96 * 2**20
    if method == "nufft":
        return base + 4 * npix * _C16 + pm * 48
    if method == "pfa":
        cells = _kgrid_cells(acq, grid, oversample) if acq is not None else oversample**2 * npix
        return base + 3 * cells * _C16
    if method == "backprojection":
        from ._bp_setup import BLOCK, profile_length

        length = float(profile_length(int(n_freq), float(upsample))) if upsample <= 1e6 else upsample * n_freq
        item = 8 if precision == "float32" else 16
        return base + 5 * min(BLOCK, n_pulses) * length * item + npix * item
    return base + 4 * npix * _C16 + pm * 48  # other formers: NUFFT-like


def direct_seconds(n_pulses, n_freq, n_pixels, model="farfield", nthreads=None) -> float:
    """Estimated run time (s) of the exact ``direct`` former: spherical from the planner's cost
    model of this machine (:mod:`sarcli.formers.calibration`), far field from :data:`DIRECT_RATE`."""
    cores = nthreads or os.cpu_count() or 1
    terms = float(n_pulses) * n_freq * n_pixels
    if model == "farfield":
        return terms / (DIRECT_RATE["farfield"] * cores)
    from .calibration import load_cost_model

    return terms * load_cost_model()["direct"] / cores      # seconds per term on one core


def bp_seconds(c, n_pulses, n_freq, n_pixels, interp, upsample, tile_cost, nthreads) -> float:
    """Predicted seconds of backprojection: ``c["bp"]`` per pixel-pulse of 4-tap interpolation at unit
    tile cost, scaled by the interpolator's taps and the tiling's relative cost
    (:attr:`sarcli.formers._bp_kernels.Tiling.cost`), plus the range profiles' FFTs."""
    from .backprojection import profile_length

    L = profile_length(n_freq, upsample)
    taps = sampling.INTERPOLATORS[interp].taps
    return (c["bp"] * n_pulses * n_pixels * taps / 4 * tile_cost + c["bp_fft"] * n_pulses * L * math.log2(L)) / nthreads


def bp_units(data, freq_hz, antenna_position_m, grid) -> float:
    """What ``c["bp"]`` is per: the pixel-pulses of backprojection's default on this collection
    times its tiling's relative cost (:func:`bp_seconds` without the FFTs, at unit cost)."""
    from ._bp_setup import tiling_for
    from .backprojection import DEFAULT_UPSAMPLE

    cost = tiling_for(freq_hz, antenna_position_m, None, grid, DEFAULT_UPSAMPLE).cost
    return float(np.shape(data)[0]) * grid.nx * grid.ny * cost


def bp_constants(best, d, freq, a, r0, grid, thr):
    """``(c["bp_fft"], c["bp"])`` from ``best`` (best seconds of a call) on ``thr`` threads, both
    seconds x threads like every constant: the range profiles' FFTs (numpy's, one thread, so that
    ``thr`` threads are charged their time) per ``L log2 L`` and pulse, and the rest of
    backprojection's default per :func:`bp_units`."""
    from ._bp_setup import profiles
    from .backprojection import DEFAULT_PRECISION, DEFAULT_UPSAMPLE, backproject, profile_length

    P, M = d.shape
    L = profile_length(M, DEFAULT_UPSAMPLE)
    fft = best(lambda: profiles(d, None, float(P * M), L, np.complex64)) * thr / (P * L * math.log2(L))
    total = best(lambda: backproject(d, freq, a, r0, grid, precision=DEFAULT_PRECISION)) * thr
    return fft, max(total - fft * P * L * math.log2(L), 0.0) / bp_units(d, freq, a, grid)


def check_form_image(src, method, grid, *, oversample=2.0, upsample=None, eps=None, width=None,
                     precision="float64", nthreads=None) -> None:
    """Refuse (memory) or warn (``direct`` time) before :func:`form_image` allocates anything.

    ``src`` is a :class:`PhaseHistory` (or a k-grid, checked by its size only).
    """
    check_knobs(upsample=upsample, oversample=oversample if method == "pfa" else None,
                width=width if method == "pfa" else None, eps=eps if method == "nufft" else None)
    data = getattr(src, "data", None)
    if data is None:  # a k-grid: the image and the FFT of the grid
        shape = getattr(src, "samples", np.zeros((0, 0))).shape
        check_memory(3 * float(np.prod(shape)) * _C16 + 2.0 * grid.nx * grid.ny * _C16,
                     f"pfa of a {shape[1]} x {shape[0]} k-grid onto {grid.nx} x {grid.ny} pixels")
        return
    from ._samples import is_lazy

    p, m = data.shape
    acq = src.acquisition
    model = getattr(src, "model", None) or acq.model
    if upsample is None and method == "backprojection":
        from .backprojection import DEFAULT_UPSAMPLE as upsample
    est = form_image_bytes(method, p, m, grid, model=model, acq=acq, oversample=oversample,
                           upsample=8.0 if upsample is None else upsample, precision=precision,
                           streamed=is_lazy(data), itemsize=np.dtype(data.dtype).itemsize)
    check_memory(est, f"{method} on {grid.nx} x {grid.ny} pixels from {p} x {m} samples")
    if method == "direct":
        t = direct_seconds(p, m, grid.nx * grid.ny, model, nthreads)
        if t > DIRECT_WARN_S:
            if model == "farfield":
                faster = "method nufft (default eps 1e-9: relative error ~1e-9 against direct)"
            else:
                faster = "method backprojection (default knobs: relative error ~3e-4 against direct)"
            warnings.warn(f"direct on {grid.nx} x {grid.ny} pixels from {p} x {m} samples ({model}): "
                          f"estimated {t:.3g} s; {faster} takes a small fraction of that", SarcliWarning,
                          stacklevel=2)


#: Bytes per pixel of :func:`regularize_bytes`' terms: one ADMM solver's images and splits (about
#: 24 complex128 images alive at once), the warped operator's tables per sub-aperture (kernel
#: weights, indices, phases, work arrays) and the sub-aperture runs alive at once (the chooser's
#: measurement holds a count and four times it; a solve the count and the λ path's half).
_ADMM_PX, _WARPED_RUN_PX, _CHOOSER_RUNS, _SOLVE_RUNS = 24 * _C16, 80, 10, 3


def regularize_bytes(n_pulses, n_freq, grid, operator="auto", itemsize=_C16, *, auto: bool = True) -> float:
    """Estimate of the peak working memory (bytes) of :func:`sarcli.regularize`.

    ``itemsize``: bytes per stored sample (8 for complex64, 16 for complex128); the residuals,
    and a copy of stored samples narrower than complex128, are complex128. ``auto``: λ chosen on
    a path (two solvers side by side and the path's solutions kept) rather than given. The peak is
    the larger of the operator's set-up (the warped operator's sub-aperture chooser) and the solve.
    Measured (``/usr/bin/time``, less the interpreter's 0.15 GB): GOTCHA 800², warped, 0.90 GB
    with ``auto`` (estimate 0.79) and 0.67 GB with a fixed λ (0.52); 566² of 256 × 512 samples
    0.50 GB (0.39).
    """
    pm = float(n_pulses) * float(n_freq)
    npix = float(grid.nx) * float(grid.ny)
    samples = pm * (itemsize + (_C16 if itemsize < _C16 else 0) + 2 * _C16)   # data (and a copy), residuals
    solve = _ADMM_PX * (2 if auto else 1) + (12 * _C16 if auto else 0)       # solvers, the path's solutions
    if operator in ("toeplitz", "nufft"):
        ops, setup = 8 * _C16, 0.0
    elif operator == "spherical":
        ops, setup = 24.0, 0.0
    else:  # auto or warped: the warped operator, the costlier in memory
        ops, setup = _SOLVE_RUNS * _WARPED_RUN_PX, _CHOOSER_RUNS * _WARPED_RUN_PX
    return samples + npix * max(setup, ops + solve)


def check_regularize(ph, grid, *, iters, operator="auto", nthreads=None, auto: bool = True) -> None:
    """Refuse a regularised reconstruction whose memory exceeds the limit; warn when the spherical
    operator (two exact sums per iteration) would run for long."""
    p, m = ph.data.shape
    check_memory(regularize_bytes(p, m, grid, operator, np.dtype(ph.data.dtype).itemsize, auto=auto),
                 f"regularize on {grid.nx} x {grid.ny} pixels from "
                                                         f"{p} x {m} samples")
    if operator == "spherical":
        t = 2 * iters * direct_seconds(p, m, grid.nx * grid.ny, "spherical", nthreads)
        if t > DIRECT_WARN_S:
            warnings.warn(f"regularize with the spherical operator: {iters} iterations x 2 exact sums on "
                          f"{grid.nx} x {grid.ny} pixels, estimated {t:.3g} s; operator auto or warped is far faster",
                          SarcliWarning, stacklevel=2)
