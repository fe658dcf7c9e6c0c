"""Cost of image formation before it starts: knob ranges, memory and time estimates.

One home for the models of every former's cost: its peak working memory
(:func:`form_image_bytes`, one model per family) and its seconds (:func:`direct_seconds`,
:func:`nufft_seconds`, :func:`bp_seconds`, :func:`ffbp_seconds`, :func:`subimage_seconds`:
operation counts times the per-operation constants of :mod:`sarcli.formers.planning.calibration`). A
former's plan (:mod:`sarcli.formers.former`) reads them, and through it
:func:`sarcli.formers.formation.form_image` (which refuses a plan beyond the memory limit,
:func:`sarcli._util.resources.memory_limit`, ``sar --max-memory``, and warns before a long
``direct``), the planner and ``sar plan``. The memory estimates are upper-bound models of each
former's working arrays (bytes), not measurements.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np


from ..._util.resources import check_memory
from ...core import sampling
from ...errors import SarcliInputError, SarcliWarning

__all__ = ["UPSAMPLE_RANGE", "OVERSAMPLE_RANGE", "WIDTH_RANGE", "EPS_RANGE", "NUFFT_EPS", "check_knobs", "Samples", "threads",
           "form_image_bytes", "kgrid_bytes", "direct_seconds", "nufft_width", "nufft_seconds", "n_tiles",
           "subimage_seconds", "bp_seconds", "bp_units", "bp_constants", "FFBP_TERMS", "FFBP_PARTS", "ffbp_counts", "ffbp_seconds",
           "regularize_bytes", "check_regularize", "DIRECT_WARN_S", "write_seconds", "read_seconds"]

#: backprojection range-profile upsampling (1: no upsampling; 64 reaches 1e-5 peak accuracy)
UPSAMPLE_RANGE = (1.0, 64.0)
#: PFA k-grid oversampling (the kernel design needs >= 1.25)
OVERSAMPLE_RANGE = (1.25, 16.0)
#: PFA Kaiser-Bessel kernel width in cells
WIDTH_RANGE = (2, 16)
#: NUFFT requested accuracy (FINUFFT's reachable range in float64)
EPS_RANGE = (1e-15, 1e-1)
#: The default NUFFT accuracy of every far-field operator and former (relative error ~eps against
#: the exact sum): the nufft former, its operator pair, the Toeplitz Gram and the regulariser.
NUFFT_EPS = 1e-9
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


@dataclass(frozen=True)
class Samples:
    """What the memory models need of a collection: its shape, the bytes of one stored sample (8
    for complex64, 16 for complex128), whether the samples stay on disk (a
    :class:`sarcli.io.pulses.PulseSource`: a former that reads them by blocks of pulses then holds
    one block) and the data model."""

    n_pulses: int
    n_freq: int
    itemsize: int = _C16
    streamed: bool = False
    model: str = "farfield"

    @classmethod
    def of(cls, ph) -> "Samples":
        from .._samples import is_lazy

        p, m = ph.data.shape
        return cls(int(p), int(m), int(np.dtype(ph.data.dtype).itemsize), bool(is_lazy(ph.data)),
                   getattr(ph, "model", None) or ph.acquisition.model)

    def by_blocks(self, method: str) -> bool:
        """Whether ``method`` reads the samples by blocks of pulses (backprojection, ffbp, the
        spherical matched filter)."""
        return method in ("backprojection", "ffbp") or (method == "direct" and self.model == "spherical")

    def rows(self, method: str) -> float:
        """Pulses ``method`` holds at once: one block of them when the samples stay on disk and it
        reads by blocks, else all."""
        from ..backprojection import BLOCK

        if self.streamed and self.by_blocks(method):
            return float(min(self.n_pulses, BLOCK))
        return float(self.n_pulses)

    def held(self, method: str) -> float:
        """Bytes of samples ``method`` holds at their stored size."""
        return self.rows(method) * self.n_freq * self.itemsize


def threads(nthreads, costs) -> int:
    """Threads a time is predicted for: ``nthreads``, else those the cost model was measured on."""
    return max(1, int(nthreads or costs.get("threads", 2)))


def kgrid_bytes(acq, grid, oversample) -> float:
    """Bytes of the PFA k-grid: the bounding box of the k-space samples at the grid's k spacing
    (``acq`` None: ``oversample²`` times the pixels), complex128."""
    if acq is None:
        return oversample**2 * float(grid.nx) * grid.ny * _C16
    from ...core.geometry import kspace_coordinates

    f = np.asarray(acq.frequency_hz, dtype=np.float64)
    fr = f if f.ndim == 1 else f.ravel()
    ends = np.array([fr.min(), fr.max()])
    kx, ky = kspace_coordinates(ends, acq.azimuth_rad, acq.elevation_rad)
    dkx = 2 * np.pi / (oversample * grid.nx * grid.dx)
    dky = 2 * np.pi / (oversample * grid.ny * grid.dy)
    return (np.ptp(kx) / dkx + 1) * (np.ptp(ky) / dky + 1) * _C16


def form_image_bytes(method, samples: Samples, grid, *, acq=None, oversample=2.0, upsample=16.0,
                     precision="float64", grid_bytes=0.0, threads=1) -> float:
    """Upper-bound estimate of the peak working memory (bytes) of one former, the one memory
    model of each family.

    ``samples``: the collection (:class:`Samples`). Every former holds its samples
    (:meth:`Samples.held`); most also a complex128 weighted copy of them and the image with an
    accumulator. ``acq``, ``oversample``: the PFA k-grid's size (:func:`kgrid_bytes`);
    ``upsample``, ``precision``: backprojection's profiles; ``grid_bytes``: ffbp's polar grids
    (its plan's ``ops['grid_bytes']``); ``threads``: subimage's tiles formed at once.
    """
    held = samples.held(method)
    pm = samples.rows(method) * samples.n_freq
    npix = float(grid.nx) * float(grid.ny)
    base = held + pm * _C16 + 2 * npix * _C16  # data + weighted copy, image + accumulator
    if method == "direct":
        return base + (npix * 24 if samples.model == "spherical" else 0) + 96 * 2**20
    if method == "pfa":
        return base + 3 * kgrid_bytes(acq, grid, oversample)
    if method == "backprojection":
        from ..backprojection import BLOCK, profile_length

        length = float(profile_length(int(samples.n_freq), float(upsample))) if upsample <= 1e6 \
            else upsample * samples.n_freq
        item = 8 if precision == "float32" else 16
        return base + 5 * min(BLOCK, samples.n_pulses) * length * item + npix * item
    if method == "ffbp":   # the samples by blocks, the polar grids of two adjacent levels, the image
        return held + grid_bytes + _C16 * npix
    if method == "subimage" and samples.model == "spherical":   # per tile at once: the phased samples
        return held + _C16 * ((4 * threads - 1) * pm + 2 * npix)
    return base + 4 * npix * _C16 + pm * 48  # nufft (and subimage's one tile of far-field data)


def direct_seconds(n_pulses, n_freq, n_pixels, nthreads=None, costs=None) -> float:
    """Predicted seconds of the exact ``direct`` former: one calibrated constant per sample x
    pixel term (:mod:`sarcli.formers.planning.calibration`), far-field and spherical alike."""
    from .calibration import load_cost_model

    c = load_cost_model() if costs is None else costs
    return float(n_pulses) * n_freq * n_pixels * c["direct"] / threads(nthreads, c)


def write_seconds(c, nbytes) -> float:
    """Predicted seconds of writing a file of ``nbytes`` (an image, as ``sar form-image`` stores it):
    ``c["write_per_byte"]`` for its first :data:`~sarcli.formers.planning.calibration.WRITE_BYTES`,
    ``c["write_per_byte_large"]`` for the rest (a file's first bytes find memory freed a moment
    before, the rest memory the host backs anew: :func:`~sarcli.formers.planning.calibration.write_costs`)."""
    from .calibration import WRITE_BYTES

    first = min(float(nbytes), float(WRITE_BYTES))
    return c["write_per_byte"] * first + c.get("write_per_byte_large", c["write_per_byte"]) * (float(nbytes) - first)


def read_seconds(c, nbytes) -> float:
    """Predicted seconds of reading ``nbytes`` of samples from a file (``c["read_per_byte"]``)."""
    return c["read_per_byte"] * float(nbytes)


def nufft_width(eps: float) -> int:
    """FINUFFT's kernel width (cells) at accuracy ``eps``."""
    return int(min(16, max(2, math.ceil(-math.log10(eps)) + 1)))


def nufft_seconds(c, n_samples, ny, nx, eps, threads=1) -> float:
    """Predicted seconds of one type-1 NUFFT: spreading ``n_samples`` with a ``w²`` kernel and the
    FFT of the twice-oversampled grid."""
    w = nufft_width(eps)
    n_fft = 4.0 * nx * ny
    return (c["nufft_spread"] * n_samples * w * w + c["nufft_fft"] * n_fft * math.log2(max(n_fft, 2))) / threads


def n_tiles(grid, tile) -> int:
    """Tiles of side ``tile`` covering ``grid``."""
    return math.ceil(grid.nx / tile) * math.ceil(grid.ny / tile)


def subimage_seconds(c, n_samples, tiles, eps, threads=1) -> float:
    """Predicted seconds of the sub-image NUFFT: ``tiles`` NUFFTs of every sample."""
    return tiles * c["subimage_point"] * n_samples * nufft_width(eps) ** 2 / threads


#: ffbp's per-operation constants and the plan counts (``FfbpPlan.ops``) they multiply.
FFBP_TERMS = (("ffbp_stage0", ("stage0",)), ("ffbp_node0", ("stage0_nodes",)), ("ffbp_mac", ("merge",)),
              ("ffbp_pair", ("merge_pairs",)), ("ffbp_final", ("final_pairs",)), ("ffbp_tone", ("tones",)),
              ("ffbp_touch", ("fresh_bytes",)))
#: The part of ffbp (:func:`sarcli.formers.ffbp.ffbp`'s ``timings``) each constant is fitted to.
FFBP_PARTS = {"stage0": ("ffbp_stage0", "ffbp_node0"), "merge": ("ffbp_mac", "ffbp_pair"),
              "final": ("ffbp_final",), "tones": ("ffbp_tone",)}


def ffbp_counts(ops) -> list:
    """The operation counts of an ffbp plan that :data:`FFBP_TERMS`' constants multiply."""
    return [sum(ops.get(k, 0.0) for k in keys) for _, keys in FFBP_TERMS]


def ffbp_seconds(c, ops, n_pulses, profile_len, threads=1) -> float:
    """Predicted ffbp time: the plan's operation counts times the calibrated constants, plus the
    range profiles' FFTs."""
    work = sum(c.get(name, 0.0) * n for (name, _), n in zip(FFBP_TERMS, ffbp_counts(ops)))
    return (work + c["bp_fft"] * n_pulses * profile_len * math.log2(profile_len)) / threads


def bp_seconds(c, n_pulses, n_freq, n_pixels, interp, upsample, tile_cost, nthreads) -> float:
    """Predicted seconds of backprojection: ``c["bp"]`` per pixel-pulse of 4-tap interpolation at unit
    tile cost, scaled by the interpolator's taps and the tiling's relative cost
    (:attr:`sarcli.formers.backprojection._kernels.Tiling.cost`), plus the range profiles' FFTs."""
    from ..backprojection import profile_length

    L = profile_length(n_freq, upsample)
    taps = sampling.INTERPOLATORS[interp].taps
    return (c["bp"] * n_pulses * n_pixels * taps / 4 * tile_cost + c["bp_fft"] * n_pulses * L * math.log2(L)) / nthreads


def bp_units(data, freq_hz, antenna_position_m, grid) -> float:
    """What ``c["bp"]`` is per: the pixel-pulses of backprojection's default on this collection
    times its tiling's relative cost (:func:`bp_seconds` without the FFTs, at unit cost)."""
    from ..backprojection import DEFAULT_INTERP, DEFAULT_UPSAMPLE, tiling_for

    cost = tiling_for(freq_hz, antenna_position_m, None, grid, DEFAULT_UPSAMPLE, interp=DEFAULT_INTERP).cost
    return float(np.shape(data)[0]) * grid.nx * grid.ny * cost


def bp_constants(best, d, freq, a, r0, grid, thr):
    """``(c["bp_fft"], c["bp"])`` from ``best`` (best seconds of a call) on ``thr`` threads, both
    seconds x threads like every constant: the range profiles' FFTs (numpy's, one thread, so that
    ``thr`` threads are charged their time) per ``L log2 L`` and pulse, and the rest of
    backprojection's default per :func:`bp_units`."""
    from ...core.collection import Collection
    from ..backprojection import profiles
    from ..backprojection import DEFAULT_UPSAMPLE, FORM_KNOBS, backproject, profile_length

    P, M = d.shape
    L = profile_length(M, DEFAULT_UPSAMPLE)
    fft = best(lambda: profiles(d, None, float(P * M), L, np.complex64)) * thr / (P * L * math.log2(L))
    total = best(lambda: backproject(d, Collection(freq, a, r0), grid, FORM_KNOBS)) * thr
    return fft, max(total - fft * P * L * math.log2(L), 0.0) / bp_units(d, freq, a, grid)


#: Bytes per pixel of :func:`regularize_bytes`' terms: one ADMM solver's images and splits (about
#: 36 complex128 images' worth alive at once, the allocator's slack included), the warped
#: operator's tables per sub-aperture (kernel weights, indices, phases, work arrays) and the
#: sub-aperture runs alive at once (the chooser's measurement holds a count and four times it; a
#: solve the count and the λ path's half). Fitted to the peaks measured (the docstring's).
_ADMM_PX, _WARPED_RUN_PX, _CHOOSER_RUNS, _SOLVE_RUNS = 36 * _C16, 125, 10, 3


def regularize_bytes(n_pulses, n_freq, grid, operator="auto", itemsize=_C16, *, auto: bool = True) -> float:
    """Estimate of the peak working memory (bytes) of :func:`sarcli.regularize`.

    ``itemsize``: bytes per stored sample (8 for complex64, 16 for complex128); the residuals,
    and a copy of stored samples narrower than complex128, are complex128. ``auto``: λ chosen on
    a path (two solvers side by side and the path's solutions kept) rather than given. The peak is
    the larger of the operator's set-up (the warped operator's sub-aperture chooser) and the solve.
    Measured (``/usr/bin/time``'s peak, less the 0.08 GB of the interpreter and the imports):
    GOTCHA 800², warped, 1.05 GB with ``auto`` (estimate 1.10) and 0.78 GB with a fixed λ (0.80);
    566² of 256 × 512 samples 0.60 GB (0.56).
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
        t = 2 * iters * direct_seconds(p, m, grid.nx * grid.ny, nthreads)
        if t > DIRECT_WARN_S:
            warnings.warn(f"regularize with the spherical operator: {iters} iterations x 2 exact sums on "
                          f"{grid.nx} x {grid.ny} pixels, estimated {t:.3g} s; operator auto or warped is far faster",
                          SarcliWarning, stacklevel=2)
