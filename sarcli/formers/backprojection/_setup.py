"""Backprojection's setup, shared by the one-shot maps (:mod:`.backprojection`), the prepared
backprojector (:mod:`._prepared`) and ffbp's range profiles: the validated inputs, the
per-pulse constants in the working precision, the FFT layout, the range profiles and the
orientation of the kernels' rows (:mod:`._rows`). The model and its formulas are in
:mod:`.backprojection`'s docstring.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..._native import threads
from ...core.geometry import C, bistatic_differential_range
from ...core.grid import Grid
from ...core.sampling import INTERPOLATORS as ALL_INTERPOLATORS, PROFILE_INTERPOLATORS, equally_spaced, frequency_line
from ...errors import AliasingWarning, SarcliInputError
from ..._native.layout import BpGeo
from ._kernels import GEO_ROWS, SERIES, min_range, model_tolerance, next_fast_len
from ._rows import (CACHE_FRACTION, Orientation, copy_oriented, l2_cache_bytes, orient, row_cosines, row_reach_bins,
                    row_steps, transposed_grid)
from .._samples import is_lazy

__all__ = ["INTERPOLATORS", "PAD", "BLOCK", "profile_length", "ProfileWork", "profiles", "range_profiles", "TilingInputs", "tiling_for", "Setup",
           "check_data"]

#: Interpolation kernels for the range profiles and their codes in the compiled kernels.
INTERPOLATORS = {name: ALL_INTERPOLATORS[name].code for name in PROFILE_INTERPOLATORS}
#: Profile padding on each side (periodic copies), enough for the 6-tap Lanczos-3 stencil.
PAD = 3
_PRECISIONS = {"float64": np.float64, "float32": np.float32}
#: Most pulses range-compressed and backprojected together (bounds the profile memory).
BLOCK = 128
#: Profile bytes one pass over the image works through: :data:`CACHE_FRACTION` of a core's L2.
_CACHE_BYTES = int(CACHE_FRACTION * l2_cache_bytes())


def profile_length(n_frequencies: int, upsample: float) -> int:
    """Range-profile (IFFT) length ``L``: ``upsample·M`` rounded up to an even fast FFT size."""
    half = int(math.ceil(float(upsample) * int(n_frequencies) / 2.0))
    return 2 * next_fast_len(max(half, 1))


class ProfileWork:
    """Reusable buffers of :func:`profiles` for blocks of up to ``rows`` pulses of ``m`` samples.

    One former call makes one and hands it to every block, so that the FFT's input and output, the
    profiles and (for samples left on disk) the block read from the file are allocated once, not
    once per block: a block's arrays are megabytes, and arrays that size freed and allocated again
    go back to the operating system each time (page faults on every first touch).

    Parameters
    ----------
    rows : int
        Most pulses per block.
    m : int
        Samples per pulse.
    n_len : int
        Profile (FFT) length ``L``.
    dtype : numpy dtype
        Complex dtype of the profiles.
    """

    def __init__(self, rows, m, n_len, dtype):
        self.rows, self.m, self.n_len, self.dtype = int(rows), int(m), int(n_len), np.dtype(dtype)
        # the samples' slots of every pulse, transformed in place; the zero padding between the
        # slots is restored before each block (the transform overwrites it)
        self.spectrum = np.zeros((self.rows, self.n_len), dtype=self.dtype)
        self.out = np.empty((self.rows, self.n_len + 2 * PAD), dtype=self.dtype)
        self.idx = (np.arange(self.n_len + 2 * PAD) - PAD - self.n_len // 2) % self.n_len
        self.padded = True
        self._samples = None
        self._parts = None

    def fits(self, rows, m, n_len, dtype) -> bool:
        """True when blocks of ``rows`` pulses of this shape and dtype fit these buffers."""
        return rows <= self.rows and m == self.m and n_len == self.n_len and np.dtype(dtype) == self.dtype

    def samples(self, data, sl):
        """Pulses ``sl`` of ``data``: a view of an in-memory array, or, for samples left on disk, read
        into one buffer kept for every block (:meth:`sarcli.io.pulses.PulseSource.read_into`)."""
        read_into = getattr(data, "read_into", None)
        if read_into is None:
            return data[sl]
        n = sl.stop - sl.start
        if self._samples is None or self._samples.dtype != data.dtype or self._samples.shape[0] < n:
            self._samples = np.empty((max(n, self.rows), self.m), dtype=data.dtype)
        return read_into(sl, self._samples[:n])

    def parts(self, n):
        """Two float arrays [n, L + 2 pad] for the real and imaginary parts (:func:`range_profiles`)."""
        if self._parts is None:
            real = self.out.real.dtype
            self._parts = (np.empty((self.rows, self.n_len + 2 * PAD), real),
                           np.empty((self.rows, self.n_len + 2 * PAD), real))
        return self._parts[0][:n], self._parts[1][:n]


def profiles(data, weights, total_weight, n_len, dtype, work=None):
    """Range profiles [B, n_len + 2·pad] of ``dtype`` (complex): :func:`range_profiles` unsplit.

    ``data`` may be complex64 or complex128; each sample is cast once, as it goes onto its FFT
    slot, and the block's FFTs are one call. ``work`` (a :class:`ProfileWork`) supplies the buffers, and the result
    is a view of ``work.out`` that the next call overwrites; without it, fresh buffers are made.
    """
    b, m = data.shape
    if work is None or not work.fits(b, m, n_len, dtype):
        work = ProfileWork(b, m, n_len, dtype)
    if weights is not None:
        weights = np.broadcast_to(weights, (b, m))   # (M,) or (1, M) weights serve every pulse
    jc = m // 2
    spec = work.spectrum[:b]
    if not work.padded:
        spec[:, m - jc:n_len - jc] = 0
    # numpy's inverse FFT divides by L ("backward"); the samples are multiplied by L / W so the
    # profile is the unnormalised sum over W (norm="forward" hands numpy an integer factor that
    # its FFT casts through buffers allocated on every call)
    scale = float(n_len) / float(total_weight)
    # slots (j - j_c) mod L: samples j >= j_c open the spectrum, samples j < j_c close it
    for src, dst in ((slice(jc, m), spec[:, :m - jc]), (slice(0, jc), spec[:, n_len - jc:])):
        if weights is None:
            np.multiply(data[:, src], scale, out=dst)
        else:
            np.multiply(data[:, src], weights[:, src], out=dst)
            dst *= scale
    # one call for the block: the FFT's plan is built on every call (megabytes for long profiles),
    # so calls on a few rows at a time cost more than the transforms
    sig, clobbered = _ifft_rows(spec)
    work.padded = not clobbered
    out = work.out[:b]
    np.take(sig, work.idx, axis=1, out=out, mode="wrap")   # mode "raise" would buffer the output
    return out


#: numpy's FFT writes into a given array from numpy 2.0 on (``out=``).
_FFT_OUT = np.lib.NumpyVersion(np.__version__) >= "2.0.0"
#: Samples of a block from which its inverse FFTs run on the kernel threads (scipy's FFT, the same
#: pocketfft as numpy's: the same bits); smaller blocks keep numpy's one thread, and the command
#: does not pay scipy.fft's import (0.13 s here, more than such a command's transforms).
THREADED_FFT_SAMPLES = 1 << 21


def _ifft_rows(spec):
    """The inverse FFT of every row of ``spec`` and whether ``spec``'s contents changed (the result
    written into it, or the input used as scratch): a large block's rows, being independent
    transforms, split across the calling thread's kernel threads (:func:`sarcli._native.threads`)."""
    n = threads()
    if n > 1 and spec.size >= THREADED_FFT_SAMPLES:
        import scipy.fft

        # overwrite_x lets scipy use the input as scratch even where it returns another array: the
        # spectrum's zero padding is gone either way
        return scipy.fft.ifft(spec, axis=1, overwrite_x=True, workers=n), True
    if _FFT_OUT:
        return np.fft.ifft(spec, axis=1, out=spec), True
    return np.fft.ifft(spec, axis=1), False


def range_profiles(data, weights, total_weight, n_len, nthreads, dtype=np.complex128, work=None):
    """Range profiles of pulses ``data`` [B, M] for backprojection and ffbp: real and imaginary parts
    [B, n_len + 2·pad], C-contiguous.

    ``w d / W`` go on the FFT slots ``(j - j_c) mod L`` (``j_c = M // 2``), an unnormalised inverse
    FFT of length ``L = n_len`` follows, and fftshift: profile index ``q`` holds the differential
    range ``Δr = (q - L/2) c / (2 Δα L)``. Periodic copies of ``pad`` samples at both ends let a
    stencil run past either end; the shift and the padding are one gather, ``(j - pad - L//2) mod L``.
    With ``work`` (:class:`ProfileWork`) both parts are views of its buffers, overwritten by the next call.
    """
    prof = profiles(data, weights, total_weight, n_len, dtype, work)
    if work is None or not work.fits(data.shape[0], data.shape[1], n_len, dtype):
        return np.ascontiguousarray(prof.real), np.ascontiguousarray(prof.imag)
    re, im = work.parts(prof.shape[0])
    np.copyto(re, prof.real)
    np.copyto(im, prof.imag)
    return re, im


class TilingInputs:
    """What :func:`._kernels.tiling` and :func:`orient` need of a collection, computed once for several
    upsamplings: the smallest antenna-to-grid range, the largest carrier wavenumber and frequency
    step, the range steps along rows and columns (:func:`row_steps`), the largest direction cosines
    along them (:func:`row_cosines`) and the pulses. :class:`Setup` orients through one too, so the
    planner prices the tiling the former runs."""

    def __init__(self, freq_hz, antenna_position_m, receive_position_m, grid):
        f = np.asarray(freq_hz, dtype=np.float64)
        f = f[None, :] if f.ndim == 1 else f
        alpha_ref, dalpha = frequency_line(f, f.shape[-1] // 2)
        a = np.asarray(antenna_position_m, dtype=np.float64)
        b = a if receive_position_m is None else np.asarray(receive_position_m, dtype=np.float64)
        self._fill(f.shape[-1], alpha_ref, dalpha, a, b, grid)

    @classmethod
    def of_geometry(cls, m, alpha_ref, dalpha, a, b, grid) -> "TilingInputs":
        """From what :class:`Setup` has computed: ``m`` frequencies, the frequency line's reference and
        step (per pulse or one), transmit and receive positions ``a``, ``b`` [P, 3] and the grid."""
        inputs = cls.__new__(cls)
        inputs._fill(m, alpha_ref, dalpha, a, b, grid)
        return inputs

    def _fill(self, m, alpha_ref, dalpha, a, b, grid):
        self.m, self.grid = int(m), grid
        self.r_min = min(min_range(a, grid), min_range(b, grid))
        self.cosines = row_cosines(a, b, grid)
        self.steps = row_steps(a, b, grid)
        self.n_pulses = a.shape[0]
        self.kc_max = float(np.max(np.abs(4.0 * np.pi * np.asarray(alpha_ref) / C)))
        self.dalpha_max = float(np.max(np.abs(dalpha)))

    def orientation(self, upsample, precision="float32", interp="cubic") -> Orientation:
        """The orientation and tiling :class:`Setup` chooses at profile oversampling ``upsample``,
        ``precision`` (of the profiles: 'float32' or 'float64') and interpolator ``interp`` (the range
        model's tolerance: :func:`._kernels.model_tolerance`)."""
        n_len = profile_length(self.m, upsample)
        return orient(self.grid, self.r_min, self.kc_max, 2.0 * self.dalpha_max * n_len / C, self.steps,
                      self.n_pulses, sample_bytes=_sample_bytes(precision),
                      cosines=self.cosines, tolerance=model_tolerance(interp, upsample))

    def tiling(self, upsample, precision="float32", interp="cubic"):
        """The tiling :class:`Setup` chooses at profile oversampling ``upsample``, ``precision`` and
        ``interp`` (on the rows of :meth:`orientation`)."""
        return self.orientation(upsample, precision, interp).tiling


def tiling_for(freq_hz, antenna_position_m, receive_position_m, grid, upsample, precision="float32", interp="cubic"):
    """The tiling :class:`Setup` chooses for these frequencies, positions, grid, ``upsample``,
    ``precision`` and ``interp`` (:func:`._kernels.tiling` on the rows of :func:`orient`;
    ``receive_position_m`` None when monostatic), without the checks."""
    return TilingInputs(freq_hz, antenna_position_m, receive_position_m, grid).tiling(upsample, precision, interp)


def _sample_bytes(precision) -> int:
    """Bytes of a profile sample (re and im) in ``precision``; an unknown one is refused by :class:`Setup`."""
    return 2 * np.dtype(_PRECISIONS.get(precision, np.float32)).itemsize


class Setup:
    """Validated inputs, per-pulse constants (in the working precision) and the FFT layout."""

    def __init__(self, shape, collection, grid, upsample, interp, precision):
        n_pulses, m = shape
        freq_hz, weights, rcv = collection.frequency_hz, collection.weights, collection.receive_position_m
        if interp not in INTERPOLATORS:
            raise SarcliInputError(f"unknown interpolation {interp!r}; choose one of {sorted(INTERPOLATORS)}")
        if precision not in _PRECISIONS:
            raise SarcliInputError(f"unknown precision {precision!r}; choose 'float64' or 'float32'")
        if not (np.isfinite(upsample) and upsample >= 1):
            raise SarcliInputError(f"upsample must be a number >= 1, got {upsample!r}")
        if not isinstance(grid, Grid):
            raise SarcliInputError(f"grid must be a sarcli.core.grid.Grid, got {type(grid).__name__}")
        if m < 2:
            raise SarcliInputError("backprojection needs at least two frequencies per pulse; "
                                   "use method 'direct'")
        f = np.asarray(freq_hz, dtype=np.float64)
        # one row when every pulse has the same frequencies: the checks below then cost O(M), not O(P M)
        f = f[None, :] if f.ndim == 1 else f
        if f.shape not in ((1, m), (n_pulses, m)):
            raise SarcliInputError(f"frequencies have shape {np.shape(freq_hz)}, expected ({m},) "
                                   f"or ({n_pulses}, {m}) to match the data")
        a = np.asarray(collection.antenna_position_m, dtype=np.float64)
        r0 = np.asarray(collection.range_to_center_m, dtype=np.float64)
        if a.shape != (n_pulses, 3) or r0.shape != (n_pulses,):
            raise SarcliInputError(f"antenna positions {a.shape} / ranges {r0.shape} do not match "
                                   f"{n_pulses} pulses (expected ({n_pulses}, 3) and ({n_pulses},))")
        b = a if rcv is None else np.asarray(rcv, dtype=np.float64)
        if b.shape != a.shape:
            raise SarcliInputError(f"receive positions {b.shape} do not match the transmit positions {a.shape}")
        self.bistatic = not np.array_equal(a, b)
        equally_spaced(f, "backprojection")
        if weights is None:
            w = None
            self.total_weight = float(n_pulses * m)
        else:
            w = np.broadcast_to(np.asarray(weights, dtype=np.float64), (n_pulses, m))
            if np.any(w < 0) or not np.all(np.isfinite(w)):
                raise SarcliInputError("window weights must be finite and non-negative")
            self.total_weight = float(w.sum())
            if self.total_weight <= 0:
                raise SarcliInputError("window weights sum to zero")
        self.weights = w
        self.n_pulses, self.m = n_pulses, m
        self.n_len = profile_length(m, upsample)
        self.jc = m // 2
        self.slots = (np.arange(m) - self.jc) % self.n_len  # FFT slot of frequency j
        self.kind = INTERPOLATORS[interp]
        self.dtype = _PRECISIONS[precision]
        dt = self.dtype
        alpha_ref, dalpha = frequency_line(f, self.jc)
        alpha_ref = np.broadcast_to(alpha_ref, (n_pulses,))
        dalpha = np.broadcast_to(dalpha, (n_pulses,))
        bin_m = C / (2.0 * dalpha * self.n_len)   # signed for decreasing frequencies
        na = np.linalg.norm(a, axis=1)
        nb = np.linalg.norm(b, axis=1)
        # per-pulse geometry in float64, the rows sarcli._native.layout.BpGeo names
        g = self.geo = np.empty((GEO_ROWS, n_pulses))
        g[BpGeo.TWO_AX], g[BpGeo.TWO_AY], g[BpGeo.A2], g[BpGeo.NA] = 2.0 * a[:, 0], 2.0 * a[:, 1], na * na, na
        g[BpGeo.TWO_BX], g[BpGeo.TWO_BY], g[BpGeo.B2], g[BpGeo.NB] = 2.0 * b[:, 0], 2.0 * b[:, 1], nb * nb, nb
        # (|a| + |b|)/2 - r0: exactly |a| - r0 when a = b
        g[BpGeo.OFFSET] = (0.5 * (na + nb) if self.bistatic else na) - r0
        g[BpGeo.INV_BIN] = 1.0 / bin_m
        g[BpGeo.KC] = 4.0 * np.pi * alpha_ref / C
        #: the orientation of the kernels' rows and their tiling (:func:`orient`), as the planner prices it
        self.orientation = TilingInputs.of_geometry(m, alpha_ref, dalpha, a, b, grid).orientation(upsample, precision,
                                                                                                  interp)
        self.transposed = self.orientation.transposed
        kgrid = transposed_grid(grid) if self.transposed else grid
        if self.transposed:   # kernel x is the image's y: the antennas' x and y swap with the grid's
            g[[BpGeo.TWO_AX, BpGeo.TWO_AY]] = g[[BpGeo.TWO_AY, BpGeo.TWO_AX]]
            g[[BpGeo.TWO_BX, BpGeo.TWO_BY]] = g[[BpGeo.TWO_BY, BpGeo.TWO_BX]]
        self.x = np.ascontiguousarray(kgrid.x, dtype=np.float64)
        self.y = np.ascontiguousarray(kgrid.y, dtype=np.float64)
        #: the image's shape and the kernels' (its transpose when :attr:`transposed`)
        self.shape, self.kernel_shape = grid.shape, kgrid.shape
        #: the range model and tile width (:func:`._kernels.tiling`)
        self.tiling = self.orientation.tiling
        self.model, self.width = self.tiling.model, self.tiling.width
        self._check_window(a, b, r0, grid, np.abs(bin_m) * self.n_len / 2.0)
        # pulses per pass over the image inside a kernel call: the parts of their profiles that a
        # row reads stay in cache from one row to the next; at least 8: one AVX-512 vector of the
        # kernels' float64 pulse loop over a tile's anchors. Each pass adds every tile's
        # accumulators into the (float64) image once, so the fewer passes the better: rows across
        # the look direction read a few bins of each profile, and many pulses share the cache
        row_bytes = (self.n_len + 2 * PAD) * 2 * np.dtype(dt).itemsize
        reach = row_reach_bins(kgrid, self.orientation.c_max, float(np.max(np.abs(g[BpGeo.INV_BIN]))),
                               ALL_INTERPOLATORS[interp].taps)
        touched = min(row_bytes, int(math.ceil(reach)) * 2 * np.dtype(dt).itemsize)
        self.cache_block = max(8, _CACHE_BYTES // max(touched, 1))
        # pulses whose profiles live at once: at most BLOCK, and no more bytes than the phase
        # history and the image hold (complex128), so few long pulses onto a small image stay
        # within a few times the data and the image
        budget = 16 * (n_pulses * m + grid.nx * grid.ny)
        self.block = int(min(BLOCK, max(4, budget // row_bytes)))

    @staticmethod
    def _check_window(a, b, r0, grid, half_window):
        """Warn when the grid's corners leave some pulse's unambiguous window ``|Δr| < c/(4Δα)``.

        ``|a - x|`` is convex in x, so its maximum over the rectangle is at a corner; the corners
        are also where the minimum lies unless an antenna is right above the grid.
        """
        xs = [grid.x[0] - grid.dx / 2, grid.x[-1] + grid.dx / 2]
        ys = [grid.y[0] - grid.dy / 2, grid.y[-1] + grid.dy / 2]
        corners = np.array([[x, y, 0.0] for x in xs for y in ys])
        excess = np.abs(bistatic_differential_range(a, b, r0, corners)) / half_window[:, None]
        if np.max(excess) >= 1.0:
            worst = int(np.argmax(np.max(excess, axis=1)))
            warnings.warn(
                f"the grid reaches {np.max(excess):.3g} times the unambiguous range window "
                f"|Δr| < c/(4Δα) = {half_window[worst]:.4g} m (pulse {worst}); backprojection leaves "
                f"pixels outside it out of those pulses", AliasingWarning, stacklevel=4)

    def image_view(self, arr):
        """An array of the kernels' shape as an array of the image's (a transposed view when
        :attr:`transposed`)."""
        return arr.T if self.transposed else arr

    def image(self, out_re, out_im):
        """The complex128 image from the kernels' real and imaginary parts (the one copy, transposing
        when :attr:`transposed`)."""
        img = np.empty(self.shape, dtype=np.complex128)
        copy_oriented(img.real, out_re, self.transposed)
        copy_oriented(img.imag, out_im, self.transposed)
        return img

    def kernel_input(self, f):
        """Real and imaginary parts of an image-shaped ``f``, C-contiguous in the working precision
        and the kernels' orientation (zeros for the imaginary part of real ``f``)."""
        f = np.asarray(f)
        re = np.empty(self.kernel_shape, dtype=self.dtype)
        copy_oriented(re, f.real, self.transposed)
        im = np.zeros_like(re)
        if np.iscomplexobj(f):
            copy_oriented(im, f.imag, self.transposed)
        return re, im

    def kernel_args(self, sl):
        """Geometry and options of the kernels for the pulses in slice ``sl``."""
        return (self.x, self.y, np.ascontiguousarray(self.geo[:, sl]), self.n_len, PAD, self.kind,
                self.bistatic, self.width, self.model == SERIES)

    def samples_from_profiles(self, hri):
        """The adjoint of the range profiles: padded profiles ``hri`` (pulses, ``n_len + 2 PAD``, 2;
        re and im) back to samples (pulses, frequencies), divided by the total weight."""
        h = hri.astype(np.float64).view(np.complex128)[..., 0]
        # transpose of the periodic padding: fold the copies back onto their sources
        g = h[:, PAD:PAD + self.n_len].copy()
        g[:, self.n_len - PAD:] += h[:, :PAD]
        g[:, :PAD] += h[:, PAD + self.n_len:]
        # transpose of fftshift and of the unnormalised inverse FFT (= unnormalised forward FFT)
        g = np.fft.fft(np.fft.ifftshift(g, axes=1), axis=1, norm="backward")
        return g[:, self.slots] / self.total_weight

    def blocks(self):
        """Slices of at most ``self.block`` pulses: profiles live one block at a time."""
        return [slice(b, min(b + self.block, self.n_pulses)) for b in range(0, self.n_pulses, self.block)]


def check_data(data):
    # a phase history left on disk (sarcli.io.pulses.PulseArray) stays there: blocks are read below
    d = data if is_lazy(data) else np.asarray(data)
    if d.ndim != 2 or d.shape[0] * d.shape[1] == 0:
        raise SarcliInputError(f"phase history must be a non-empty [P, M] array, got shape {d.shape}")
    return d
