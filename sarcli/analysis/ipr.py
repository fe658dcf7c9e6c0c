"""Impulse-response measurement of point targets: width, sidelobe ratios, peak position.

A point target's impulse response (IPR) is measured the way SAR image-quality tools do it:
find the peak near the target, interpolate a neighbourhood by FFT zero-padding (band-limited
interpolation of the *complex* image after shifting its spectral centre to zero, because SAR
images are band-pass), and take two cuts through the peak, along the range direction ``ξ_θc``
(θc = centre look azimuth) and along cross-range (``ξ_θc`` turned by +90°). On each cut:

- ``irw_m``: the -3 dB impulse-response width (half-power width of ``|f|``);
- ``pslr_db``: peak sidelobe ratio, ``20 log10(max sidelobe / peak)``, sidelobes being the cut
  outside the main lobe (between the first nulls) and within the sidelobe extent;
- ``islr_db``: integrated sidelobe ratio, ``10 log10(sidelobe energy / main-lobe energy)`` on the
  1-D cut, sidelobes within ``±sidelobe_extent_cells`` resolution cells of the peak.

The predicted values live in :mod:`sarcli.analysis.psf`; :mod:`sarcli.analysis.quality` puts the
two side by side. All outputs are plain JSON types.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy import ndimage

from ..core.windows import IRW_FACTOR_UNIFORM, irw_factor, window_1d
from ..errors import SarcliInputError

__all__ = ["profile_metrics", "measure_ipr", "center_azimuth", "window_textbook", "ISLR_DEFINITION"]

#: Largest neighbourhood (pixels a side) and interpolated patch (samples a side) measure_ipr uses.
MAX_PATCH = 257
MAX_FINE = 2056

#: How the ISLR is defined here (printed with every result).
ISLR_DEFINITION = ("1-D ISLR on each cut: energy of |f|^2 outside the main lobe (first nulls) "
                   "and within +/- sidelobe_extent_cells resolution cells of the peak, over the "
                   "main-lobe energy")


def center_azimuth(azimuth_rad) -> float:
    """Centre look azimuth θc (rad): the direction of the mean of the unit vectors ``ξ_θ``."""
    az = np.asarray(azimuth_rad, dtype=np.float64)
    return float(np.angle(np.mean(np.exp(1j * az))))


def level_crossing(s, amp, i_from, i_to, level):
    """Position where ``amp`` first drops below ``level`` walking from ``i_from`` towards ``i_to``."""
    step = 1 if i_to > i_from else -1
    i = i_from
    while i != i_to and amp[i + step] >= level:
        i += step
    if i == i_to:
        return None
    a0, a1 = amp[i], amp[i + step]
    frac = (a0 - level) / (a0 - a1) if a0 != a1 else 0.0
    return float(s[i] + frac * (s[i + step] - s[i]))


def _first_null(amp, i0, step):
    """Index of the first local minimum of ``amp`` walking from the peak ``i0`` by ``step``."""
    i = i0
    n = amp.size
    while 0 <= i + step < n and amp[i + step] <= amp[i]:
        i += step
    return i


def profile_metrics(s, amplitude, *, sidelobe_extent=None, peak_near=None) -> dict:
    """IRW, PSLR and ISLR of a 1-D impulse-response cut.

    Parameters
    ----------
    s : array_like, shape (n,)
        Uniformly spaced positions along the cut (m), increasing.
    amplitude : array_like, shape (n,)
        ``|f|`` along the cut (magnitude, not power); its maximum is taken as the peak.
    sidelobe_extent : float, optional
        Half-length (m) around the peak within which sidelobes count for PSLR and ISLR
        (default: the whole cut).
    peak_near : float, optional
        Take as the peak the local maximum reached by climbing from the sample nearest this
        position instead of the cut's maximum (a brighter neighbour on the cut is then a
        sidelobe, not the peak).

    Returns
    -------
    dict
        ``peak`` (amplitude), ``peak_position`` (m along the cut, parabolic refinement), ``irw_m`` (-3 dB width),
        ``first_nulls_m`` (positions of the first minima either side), ``pslr_db``, ``islr_db``
        (None where the cut holds no sidelobe), ``sidelobe_extent_m``.

    Notes
    -----
    The -3 dB crossings are interpolated linearly between samples; sample the cut finely
    (tens of samples per resolution cell) for sub-percent accuracy.
    """
    s = np.asarray(s, dtype=np.float64)
    amp = np.abs(np.asarray(amplitude))
    if s.ndim != 1 or s.shape != amp.shape or s.size < 5:
        raise SarcliInputError("a cut needs matching 1-D positions and amplitudes (at least 5 samples)")
    if peak_near is None:
        i0 = int(np.argmax(amp))
    else:
        i0 = int(np.argmin(np.abs(s - float(peak_near))))
        while True:
            nb = [j for j in (i0 - 1, i0 + 1) if 0 <= j < amp.size and amp[j] > amp[i0]]
            if not nb:
                break
            i0 = max(nb, key=lambda j: amp[j])
    peak = float(amp[i0])
    ds = float(s[1] - s[0])
    pos = float(s[i0])
    if 0 < i0 < amp.size - 1:
        a, b, c = amp[i0 - 1], amp[i0], amp[i0 + 1]
        den = a - 2 * b + c
        if den < 0:
            pos = float(s[i0] + 0.5 * (a - c) / den * ds)
    level = peak / math.sqrt(2.0)
    left = level_crossing(s, amp, i0, 0, level)
    right = level_crossing(s, amp, i0, amp.size - 1, level)
    irw = None if left is None or right is None else right - left
    nl = _first_null(amp, i0, -1)
    nr = _first_null(amp, i0, +1)
    extent = np.inf if sidelobe_extent is None else float(sidelobe_extent)
    inside = np.abs(s - s[i0]) <= extent
    side = inside.copy()
    side[nl:nr + 1] = False
    main = amp[nl:nr + 1]
    pslr = islr = None
    if np.any(side) and peak > 0:
        pslr = float(20 * np.log10(max(np.max(amp[side]), 1e-300) / peak))
        islr = float(10 * np.log10(max(np.sum(amp[side] ** 2), 1e-300) / np.sum(main ** 2)))
    return {
        "peak": peak,
        "peak_position": pos,
        "irw_m": None if irw is None else float(irw),
        "first_nulls_m": [float(s[nl]), float(s[nr])],
        "pslr_db": pslr,
        "islr_db": islr,
        "sidelobe_extent_m": None if sidelobe_extent is None else float(sidelobe_extent),
    }


# --------------------------------------------------------------------------------------------
# measurement on an image
# --------------------------------------------------------------------------------------------
def _spectral_centre_bin(power_1d) -> int:
    """Circular centroid (in bins) of a 1-D power spectrum."""
    n = power_1d.size
    z = np.sum(power_1d * np.exp(2j * np.pi * np.arange(n) / n))
    return int(np.rint(np.angle(z) * n / (2 * np.pi))) % n


def upsample_patch(patch: np.ndarray, oversample: int) -> np.ndarray:
    """Band-limited (FFT zero-padding) interpolation of a complex band-pass patch.

    The spectrum is first rolled so its circular centroid sits at zero frequency (an exact
    demodulation on the patch), then zero-padded ``oversample`` times in each axis. Samples at
    the original positions keep their magnitude (the demodulation changes phases only).
    """
    ny, nx = patch.shape
    spec = np.fft.fft2(patch)
    power = np.abs(spec) ** 2
    ky = _spectral_centre_bin(power.sum(axis=1))
    kx = _spectral_centre_bin(power.sum(axis=0))
    spec = np.roll(spec, (-ky, -kx), axis=(0, 1))
    spec = np.fft.fftshift(spec)
    my, mx = ny * oversample, nx * oversample
    big = np.zeros((my, mx), dtype=np.complex128)
    oy, ox = my // 2 - ny // 2, mx // 2 - nx // 2
    big[oy:oy + ny, ox:ox + nx] = spec
    return np.fft.ifft2(np.fft.ifftshift(big)) * (oversample * oversample)


def measure_ipr(image, x_m, y_m, at=None, *, range_direction_rad=0.0, resolution_m=None,
                oversample=8, search_radius_m=None, sidelobe_extent_cells=10.0) -> dict:
    """Measure the impulse response of the point target nearest ``at`` in a complex image.

    Parameters
    ----------
    image : array_like, shape (ny, nx), complex
        The image, indexed ``[row=y, col=x]``.
    x_m, y_m : array_like
        Increasing, uniformly spaced pixel-centre coordinates (m).
    at : (float, float), optional
        Expected target position (m); the peak is searched within ``search_radius_m`` of it.
        Default: the brightest pixel of the image.
    range_direction_rad : float
        Azimuth θc of the range direction ``ξ_θc`` (the centre look azimuth); cross-range is
        ``θc + π/2``.
    resolution_m : (float, float), optional
        Range and cross-range resolution cells ρ (m); set the search radius, the patch size and
        the sidelobe extent. Default: estimated from a first measurement as ``IRW / IRW_FACTOR_UNIFORM`` (0.886).
    oversample : int
        FFT zero-padding factor of the band-limited interpolation (lowered, not below 2, to keep
        the interpolated patch within ``MAX_FINE`` samples a side; the result says which).
    search_radius_m : float, optional
        Default: 3 resolution cells (at least 1.5 pixels).
    sidelobe_extent_cells : float
        Sidelobes within this many resolution cells of the peak count for PSLR and ISLR.

    Returns
    -------
    dict
        ``x_m``, ``y_m`` (measured peak), ``requested_at_m``, ``peak_position_error_m`` (None
        without ``at``), ``peak_magnitude``, ``peak_magnitude_db``, ``range`` and
        ``cross_range`` (each the output of :func:`profile_metrics`), ``range_direction_deg``,
        ``oversample``, ``patch_truncated`` (the neighbourhood hit the image border),
        ``islr_definition``.
    """
    img, x, y, oversample = _checked(image, x_m, y_m, oversample)
    dx, dy = float(x[1] - x[0]), float(y[1] - y[0])
    if resolution_m is None:
        first = measure_ipr(img, x, y, at, range_direction_rad=range_direction_rad,
                            resolution_m=(4 * max(dx, dy),) * 2, oversample=oversample,
                            search_radius_m=search_radius_m, sidelobe_extent_cells=2.0)
        irws = [first[d]["irw_m"] or 2 * max(dx, dy) for d in ("range", "cross_range")]
        resolution_m = tuple(w / IRW_FACTOR_UNIFORM for w in irws)
    rho = tuple(float(r) for r in resolution_m)
    r0, c0 = _coarse_peak(img, x, y, at, rho, search_radius_m)
    p = _Patch(img, r0, c0, (sidelobe_extent_cells + 2.0) * max(rho), oversample, dx, dy)
    prow, pcol = p.peak()
    px = x[p.clo] + pcol * p.fdx
    py = y[p.rlo] + prow * p.fdy
    # cuts through the peak (cubic spline on the complex fine image)
    re = ndimage.spline_filter(p.fine.real, order=3)
    im = ndimage.spline_filter(p.fine.imag, order=3)
    cuts = {name: p.cut(re, im, (prow, pcol), theta, r, sidelobe_extent_cells)
            for name, theta, r in (("range", range_direction_rad, rho[0]),
                                   ("cross_range", range_direction_rad + np.pi / 2, rho[1]))}
    peak = max(cuts["range"]["peak"], cuts["cross_range"]["peak"])
    err = None if at is None else float(math.hypot(px - float(at[0]), py - float(at[1])))
    return {
        "x_m": float(px),
        "y_m": float(py),
        "requested_at_m": None if at is None else [float(at[0]), float(at[1])],
        "peak_position_error_m": err,
        "peak_magnitude": float(peak),
        "peak_magnitude_db": float(20 * np.log10(peak)) if peak > 0 else None,
        "range": cuts["range"],
        "cross_range": cuts["cross_range"],
        "range_direction_deg": float(np.degrees(range_direction_rad)),
        "oversample": p.oversample,
        "sidelobe_extent_cells": float(sidelobe_extent_cells),
        "patch_truncated": p.truncated,
        "islr_definition": ISLR_DEFINITION,
    }


def _checked(image, x_m, y_m, oversample):
    """:func:`measure_ipr`'s inputs as arrays, or an input error that names what is wrong."""
    img = np.asarray(image)
    if img.ndim != 2:
        raise SarcliInputError(f"the image must be a 2-D array, got shape {img.shape}")
    img = img.astype(np.complex128, copy=False)
    x = np.asarray(x_m, dtype=np.float64)
    y = np.asarray(y_m, dtype=np.float64)
    ny, nx = img.shape
    if x.size != nx or y.size != ny or nx < 4 or ny < 4:
        raise SarcliInputError(f"image of shape {img.shape} needs x_m ({x.size}) and y_m ({y.size}) "
                               "to match, and at least 4 x 4 pixels")
    oversample = int(oversample)
    if oversample < 1:
        raise SarcliInputError(f"oversample must be a positive integer, got {oversample}")
    return img, x, y, oversample


def _coarse_peak(img, x, y, at, rho, search_radius_m):
    """Row and column of the brightest pixel (within the search radius of ``at`` when given)."""
    mag = np.abs(img)
    if at is None:
        return np.unravel_index(int(np.argmax(mag)), mag.shape)
    dx, dy = float(x[1] - x[0]), float(y[1] - y[0])
    ax, ay = float(at[0]), float(at[1])
    radius = 3 * max(rho) if search_radius_m is None else float(search_radius_m)
    radius = max(radius, 1.5 * max(dx, dy))
    near = ((x[None, :] - ax) ** 2 + (y[:, None] - ay) ** 2) <= radius ** 2
    if not np.any(near):
        raise SarcliInputError(f"target ({ax:g}, {ay:g}) m is not within {radius:g} m of the image "
                               f"(x {x[0]:g}..{x[-1]:g}, y {y[0]:g}..{y[-1]:g} m)")
    masked = np.where(near, mag, -1.0)
    return np.unravel_index(int(np.argmax(masked)), mag.shape)


class _Patch:
    """The neighbourhood of the coarse peak ``(r0, c0)`` within ``half`` metres, interpolated
    band-limited (:func:`upsample_patch`): at most :data:`MAX_PATCH` pixels a side before and
    :data:`MAX_FINE` after interpolation (the oversampling drops to 2 before the patch shrinks)."""

    def __init__(self, img, r0, c0, half, oversample, dx, dy):
        ny, nx = img.shape
        hx = min(int(math.ceil(half / dx)), MAX_PATCH // 2)
        hy = min(int(math.ceil(half / dy)), MAX_PATCH // 2)
        self.half = min(half, hx * dx, hy * dy)
        self.oversample = max(min(oversample, MAX_FINE // (2 * max(hx, hy) + 1)), 2)
        self.rlo, rhi = max(0, r0 - hy), min(ny, r0 + hy + 1)
        self.clo, chi = max(0, c0 - hx), min(nx, c0 + hx + 1)
        self.truncated = bool(self.rlo > r0 - hy or rhi < r0 + hy + 1 or self.clo > c0 - hx or chi < c0 + hx + 1)
        self.shape = (rhi - self.rlo, chi - self.clo)
        self.fine = upsample_patch(img[self.rlo:rhi, self.clo:chi], self.oversample)
        self.fdx, self.fdy = dx / self.oversample, dy / self.oversample
        self.coarse = (r0 - self.rlo) * self.oversample, (c0 - self.clo) * self.oversample

    def peak(self):
        """The fine peak near the coarse one, refined by a parabola in each axis (fine row, col)."""
        fine, w = self.fine, self.oversample
        fr, fc = self.coarse
        win = np.abs(fine[max(0, fr - w):fr + w + 1, max(0, fc - w):fc + w + 1])
        pr, pc = np.unravel_index(int(np.argmax(win)), win.shape)
        pr += max(0, fr - w)
        pc += max(0, fc - w)
        fmag = np.abs(fine)
        sub = []
        for axis, idx, n in ((0, pr, fine.shape[0]), (1, pc, fine.shape[1])):
            if 0 < idx < n - 1:
                line = fmag[idx - 1:idx + 2, pc] if axis == 0 else fmag[pr, idx - 1:idx + 2]
                den = line[0] - 2 * line[1] + line[2]
                sub.append(0.5 * (line[0] - line[2]) / den if den < 0 else 0.0)
            else:
                sub.append(0.0)
        return pr + sub[0], pc + sub[1]

    def cut(self, re, im, at, theta, r, extent_cells) -> dict:
        """:func:`profile_metrics` of the cut through fine ``at`` (row, col) along azimuth
        ``theta`` (resolution cell ``r``), on the spline coefficients ``re``, ``im`` of the fine
        image."""
        prow, pcol = at
        ds = min(self.fdx, self.fdy)
        u = np.array([math.cos(theta), math.sin(theta)])
        # stay inside the measured patch (beyond it the FFT interpolant wraps around)
        room = [self.half]
        for pos, step, n, comp in ((pcol, self.fdx, self.shape[1], abs(u[0])),
                                   (prow, self.fdy, self.shape[0], abs(u[1]))):
            if comp > 1e-12:
                room.append(min(pos, (n - 1) * self.oversample - pos) * step / comp)
        length = max(min((extent_cells + 1.0) * r, *room), 4 * ds)
        s = np.arange(-length, length + ds / 2, ds)
        col = pcol + s * u[0] / self.fdx
        row = prow + s * u[1] / self.fdy
        vals = (ndimage.map_coordinates(re, [row, col], order=3, mode="nearest", prefilter=False)
                + 1j * ndimage.map_coordinates(im, [row, col], order=3, mode="nearest", prefilter=False))
        out = profile_metrics(s, np.abs(vals), sidelobe_extent=min(extent_cells * r, length), peak_near=0.0)
        out["resolution_m"] = r
        return out


@functools.lru_cache(maxsize=32)
def window_textbook(kind="none", *, nbar=4, sll_db=-35.0, n=2048, pad=64):
    """Continuous-limit 1-D figures of a window: ``(IRW / ρ, PSLR dB, ISLR dB)``.

    The IRW factor is :func:`sarcli.core.windows.irw_factor`'s. The window (:func:`sarcli.core.windows.window_1d`, ``n`` samples) is transformed with ``pad``-fold
    zero padding; widths are in bins (1 bin = the resolution ρ of an unweighted aperture of the
    same length). ISLR counts every sidelobe (infinite extent). Uniform gives 0.886, -13.26 dB,
    -9.68 dB; Hamming 1.30, -42.7 dB; Hann 1.44, -31.5 dB (Harris, Proc. IEEE 66, 1978, Table 1).
    """
    if kind in (None, "none", "uniform", "rect"):
        w = np.ones(n)
    else:
        try:
            w = window_1d(n, kind, nbar=nbar, sll_db=sll_db)
        except ValueError as exc:
            raise SarcliInputError(str(exc)) from None
    spec = np.abs(np.fft.fftshift(np.fft.fft(w, n * pad)))
    s = (np.arange(spec.size) - spec.size // 2) / pad  # in bins
    met = profile_metrics(s, spec)
    return irw_factor(kind, nbar=nbar, sll_db=sll_db, n=n, pad=pad), float(met["pslr_db"]), float(met["islr_db"])
