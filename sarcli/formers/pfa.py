"""Polar format algorithm (PFA): grid the polar k-space samples onto a Cartesian k-grid, then FFT.

What is implemented (the convolutional-gridding form of PFA, Jackson et al. 1991; compared with
other regridders by Andersson et al., the paper's ``\\cite{Andersson}``):

1. :func:`regrid_polar` multiplies the windowed samples ``c_s = w_s d_s`` by ``exp(i k_s·c0)``
   (``c0`` the design centre of the image, float64 phase) and *spreads* them with a separable
   kernel ``φ`` onto a Cartesian k-grid that covers only the bounding box of the sample support
   (plus the kernel half-width): ``G[m] = Σ_s ρ_s c_s exp(i k_s·c0) φ((k_m - k_s)/Δk)``.
   The grid starts at ``k0`` (absolute rad/m; the support is shifted to baseband, its centre
   ``kc`` remembered) with spacing ``Δk = 2π / (n_fft h)``, so the FFT lands exactly on the
   requested pixel size ``h`` over a field of view ``n_fft h >= oversample × extent``.
2. :func:`pfa_image` applies the inverse FFT, the baseband phase ramp ``exp(i k0·x')``, divides
   by the kernel's Fourier transform (deapodisation) and by ``W``, and crops the requested grid.

Kernels: ``'kaiser'`` (Kaiser–Bessel ``I0(β sqrt(1 - (2u/w)²))``, width ``w`` cells, β after
Beatty et al. 2005 for the oversampling) and ``'linear'`` (scattered-linear: the tent kernel of
width 2, i.e. bilinear spreading, deapodised by sinc²).

Density compensation ``ρ_s``: the matched filter (eq. ``mf``) is a plain sum over the samples, so
the polar sampling density is already the weighting it asks for, and ``density='none'``
(``ρ_s = 1``, the default) reproduces eq. ``mf``. ``density='area'`` weights each sample by its
polar cell area ``|k| δk δθ`` (normalised to mean 1), which turns the result into the inverse
Fourier *integral* over the annular support, the textbook PFA image with a flat spectral weight.

Wide apertures: the bounding-box grid (and the keystone picture behind PFA) assumes a narrow
annular sector away from the k origin. :func:`check_aperture` *warns* (``SarcliWarning``, with the
aperture in degrees) when the aperture exceeds 90° or the support box contains ``k = 0``; the
result stays correct (gridding does not rely on the keystone approximation) but the k-grid grows,
and a k-grid beyond ``MAX_KGRID_CELLS`` raises :class:`SarcliInputError` suggesting the NUFFT
former instead.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..core import geometry
from ..core.types import KGrid
from ..errors import SarcliInputError, SarcliWarning
from .._util.progress import progress
from ._samples import check_kspace, weighted_samples
from .options import PfaOptions

__all__ = ["regrid_polar", "pfa_image", "check_aperture", "PFA_KERNELS", "MAX_KGRID_CELLS"]

PFA_KERNELS = ("kaiser", "linear")
#: largest k-grid (cells) regrid_polar builds (2**25 cells = 512 MiB of complex128)
MAX_KGRID_CELLS = 1 << 25
#: columns (then rows) inverse-transformed at once by pfa_image (bounds its work arrays)
_FFT_BLOCK = 256
#: samples spread by one compiled call (one step of the progress bar)
_SPREAD_CHUNK = 1 << 20


def check_aperture(kx, ky) -> float:
    """Total aperture (deg) of the samples; warn where PFA's narrow-sector picture fails.

    Warns with :class:`SarcliWarning` (stating the aperture) when the aperture exceeds 90° or
    the bounding box of the support contains the k origin.
    """
    kx = np.asarray(kx, dtype=np.float64)
    ky = np.asarray(ky, dtype=np.float64)
    az = np.arctan2(ky.sum(axis=1), kx.sum(axis=1))
    aperture = float(np.degrees(geometry.total_aperture(az)))
    box_has_origin = kx.min() <= 0 <= kx.max() and ky.min() <= 0 <= ky.max()
    if aperture > 90.0 or box_has_origin:
        warnings.warn(
            f"PFA on a {aperture:.1f}° aperture"
            + (" whose k-space bounding box contains k = 0" if box_has_origin else "")
            + ": the bounding-box k-grid is large and the keystone picture fails; "
            "the NUFFT former is the better choice", SarcliWarning, stacklevel=3)
    return aperture


def _kaiser_beta(width: int, oversample: float) -> float:
    """Beatty et al. (2005) shape parameter of a Kaiser–Bessel kernel of ``width`` cells."""
    s = float(oversample)
    return float(np.pi * np.sqrt(max((width / s) ** 2 * (s - 0.5) ** 2 - 0.8, 1e-12)))


def _next_fast_len(n: int) -> int:
    """The smallest 11-smooth integer >= ``n``: a length the FFT factors into radices 2 to 11
    (the complex ``scipy.fft.next_fast_len``)."""
    m = max(1, int(n))
    while True:
        r = m
        for p in (2, 3, 5, 7, 11):
            while r % p == 0:
                r //= p
        if r == 1:
            return m
        m += 1


def _kernel_ft(nu, kernel: str, width: int, beta: float):
    """Fourier transform ``∫ φ(u) exp(2πi u ν) du`` of the kernel at ν cycles per grid cell."""
    nu = np.asarray(nu, dtype=np.float64)
    if kernel == "linear":
        return np.sinc(nu) ** 2
    z2 = beta**2 - (np.pi * width * nu) ** 2
    z = np.sqrt(np.abs(z2))
    with np.errstate(invalid="ignore", divide="ignore"):
        val = np.where(z2 > 0, np.sinh(z) / z, np.sin(z) / z)
    return width * np.where(z < 1e-8, 1.0, val)


def _area_density(kx, ky):
    """Polar cell area ``|k| δk δθ`` per sample, normalised to mean 1 (``density='area'``)."""
    k = np.hypot(kx, ky)
    theta = np.unwrap(np.arctan2(ky, kx), axis=0)
    dk = np.abs(np.gradient(k, axis=1)) if k.shape[1] > 1 else np.ones_like(k)
    dth = np.abs(np.gradient(theta, axis=0)) if k.shape[0] > 1 else np.ones_like(k)
    area = k * dk * dth
    return area / area.mean()


def regrid_polar(data, kx, ky, weights=None, *, pixel_m, shape, center_m=(0.0, 0.0), options=None,
                 density="none") -> KGrid:
    """Grid polar k-space samples onto a Cartesian k-grid covering only their support.

    Parameters
    ----------
    data : array_like, shape (P, M)
        Phase history.
    kx, ky : array_like, shape (P, M)
        k-space coordinates (rad/m).
    weights : array_like, shape (P, M), optional
        Window weights.
    pixel_m : float or (float, float)
        Pixel size (dx, dy) of the image the k-grid is designed for (sets Δk).
    shape : (int, int)
        Image shape (ny, nx) it is designed for; the FFT covers ``oversample`` times its extent.
    center_m : (float, float)
        Design centre of the image; the data are phase-referred to it.
    options : PfaOptions, optional
        The knobs (:class:`sarcli.formers.options.PfaOptions`, default its defaults): ``kernel``,
        the gridding kernel ('kaiser' or 'linear', see the module notes); ``oversample``, the
        field-of-view oversampling σ of the FFT (>= 1.25; larger σ, smaller error); ``width``, the
        Kaiser–Bessel width in grid cells (2..16; ignored by 'linear', width 2).
    density : {'none', 'area'}
        Density compensation; ``'none'`` reproduces the matched filter (eq. ``mf``).

    Returns
    -------
    KGrid
    """
    opts = PfaOptions() if options is None else options
    kernel, oversample, width = opts.kernel, opts.oversample, opts.width
    if kernel not in PFA_KERNELS:
        raise SarcliInputError(f"unknown PFA kernel {kernel!r}; choose one of {', '.join(PFA_KERNELS)}")
    if density not in ("none", "area"):
        raise SarcliInputError(f"unknown density compensation {density!r}; choose 'none' or 'area'")
    oversample = float(oversample)
    if not oversample >= 1.25:
        raise SarcliInputError(f"PFA oversample must be at least 1.25, got {oversample}")
    width = 2 if kernel == "linear" else int(width)
    if not 2 <= width <= 16:
        raise SarcliInputError(f"PFA kernel width must be 2..16 cells, got {width}")
    wd, _ = weighted_samples(data, weights)
    kx, ky = check_kspace(wd.shape, kx, ky)
    w = np.ones(wd.shape) if weights is None else np.asarray(weights, dtype=np.float64)
    if density == "area":
        rho = _area_density(kx, ky)
        wd = wd * rho
        w = w * rho
    total = float(w.sum())
    aperture = check_aperture(kx, ky)
    dx, dy = (pixel_m, pixel_m) if np.isscalar(pixel_m) else pixel_m
    dx, dy = float(dx), float(dy)
    ny, nx = (int(v) for v in shape)
    cx, cy = (float(v) for v in center_m)
    beta = _kaiser_beta(width, oversample) if kernel == "kaiser" else 0.0
    kxf, kyf = kx.ravel(), ky.ravel()
    c = wd.ravel() * np.exp(1j * (kxf * cx + kyf * cy))
    kc = (0.5 * (kxf.min() + kxf.max()), 0.5 * (kyf.min() + kyf.max()))
    axes = []
    for kf, n, h in ((kxf, nx, dx), (kyf, ny, dy)):
        n_fft = _next_fast_len(int(np.ceil(oversample * n)))
        dk = 2.0 * np.pi / (n_fft * h)
        k0 = kf.min() - (width / 2.0 + 1.0) * dk
        nk = int(np.ceil((kf.max() - kf.min()) / dk)) + width + 3
        axes.append((n_fft, dk, k0, nk))
    (nfx, dkx, kx0, nkx), (nfy, dky, ky0, nky) = axes
    if nkx * nky > MAX_KGRID_CELLS:
        raise SarcliInputError(
            f"the PFA k-grid would need {nky} x {nkx} cells for a {aperture:.1f}° aperture "
            f"(limit {MAX_KGRID_CELLS}); use the NUFFT former or a coarser pixel")
    from .._native import load

    spread = load("pfa").spread
    samples = np.zeros((nky, nkx), dtype=np.complex128)
    starts = range(0, c.size, _SPREAD_CHUNK)
    for s in progress(starts, total=len(starts), desc="PFA gridding", unit="chunk"):
        sl = slice(s, s + _SPREAD_CHUNK)
        spread(samples, (kxf[sl] - kx0) / dkx, (kyf[sl] - ky0) / dky, np.ascontiguousarray(c[sl]),
               kernel, width, beta)
    parameters = {"kernel": kernel, "width": width, "beta": beta, "oversample": oversample,
                  "density": density, "pixel_m": [dx, dy], "shape": [ny, nx],
                  "center_m": [cx, cy], "n_fft": [nfy, nfx], "aperture_deg": aperture}
    return KGrid(samples, float(kx0), float(ky0), float(dkx), float(dky), kc, total, parameters)


def _fold(a, n, axis):
    """Sum ``a`` along ``axis`` modulo ``n`` (periodic wrap of a k-grid longer than the FFT)."""
    m = a.shape[axis]
    if m == n:
        return a
    if m < n:
        pad = [(0, 0)] * a.ndim
        pad[axis] = (0, n - m)
        return np.pad(a, pad)
    reps = -(-m // n)
    pad = [(0, 0)] * a.ndim
    pad[axis] = (0, reps * n - m)
    b = np.pad(a, pad)
    new_shape = list(b.shape)
    new_shape[axis:axis + 1] = [reps, n]
    return b.reshape(new_shape).sum(axis=axis)


def _axis_plan(coords, c0, h, n_fft, k0, dk, kernel, width, beta, label):
    """Integer lattice offsets, sub-pixel shift and deapodisation for one image axis."""
    rel = coords - c0
    shift = float(rel[len(rel) // 2] - np.round(rel[len(rel) // 2] / h) * h)
    idx = np.round((rel - shift) / h).astype(np.int64)
    if np.any(np.abs(idx) > n_fft // 2 - 1):
        raise SarcliInputError(
            f"the requested grid reaches {np.max(np.abs(rel)):.3g} m from the k-grid's design centre "
            f"in {label}, beyond its field of view of ±{n_fft * h / 2:.3g} m; regrid for this grid")
    xs = idx * h + shift
    deapod = _kernel_ft(xs / (n_fft * h), kernel, width, beta)
    ramp = np.exp(1j * k0 * (idx * h))
    return idx % n_fft, shift, ramp / deapod


def pfa_image(kgrid: KGrid, grid) -> np.ndarray:
    """Image from a :class:`KGrid`: inverse FFT, baseband ramp, deapodisation, crop (PFA step 2).

    Parameters
    ----------
    kgrid : KGrid
        From :func:`regrid_polar` or :func:`sarcli.io.read_kgrid`.
    grid : sarcli.core.grid.Grid
        Output grid. Its pixel size must be the k-grid's design pixel; its centre may be anywhere
        within the FFT field of view (sub-pixel offsets are exact phase shifts). Accuracy is
        designed for the design window (``shape`` around ``center_m``).

    Returns
    -------
    image : ndarray, shape (ny, nx), complex128
        Normalised as eq. ``mf`` (peak 1 for a unit point).
    """
    p = kgrid.parameters
    dx, dy = (float(v) for v in p["pixel_m"])
    cx0, cy0 = (float(v) for v in p["center_m"])
    nfy, nfx = (int(v) for v in p["n_fft"])
    kernel, width, beta = p["kernel"], int(p["width"]), float(p.get("beta", 0.0))
    if not (np.isclose(grid.dx, dx, rtol=1e-9) and np.isclose(grid.dy, dy, rtol=1e-9)):
        raise SarcliInputError(
            f"the k-grid was made for {dx:g} x {dy:g} m pixels, the grid asks for "
            f"{grid.dx:g} x {grid.dy:g} m; regrid with the grid's pixel size")
    col, sx, fac_x = _axis_plan(grid.x, cx0, dx, nfx, kgrid.kx0, kgrid.dkx, kernel, width, beta, "x")
    row, sy, fac_y = _axis_plan(grid.y, cy0, dy, nfy, kgrid.ky0, kgrid.dky, kernel, width, beta, "y")
    g = kgrid.samples
    nky, nkx = g.shape
    if sx != 0.0 or sy != 0.0:
        kxs = kgrid.kx0 + kgrid.dkx * np.arange(nkx)
        kys = kgrid.ky0 + kgrid.dky * np.arange(nky)
        g = g * np.exp(1j * kys * sy)[:, None] * np.exp(1j * kxs * sx)[None, :]
    # The 2-D inverse FFT, separably and in blocks, keeping only the requested rows and columns:
    # the full nfy x nfx field (oversample² x the image, twice with its work array) never exists.
    half = np.empty((row.size, nkx), dtype=np.complex128)        # y transformed, rows cropped
    for c0 in range(0, nkx, _FFT_BLOCK):
        blk = _fold(g[:, c0:c0 + _FFT_BLOCK], nfy, 0)
        half[:, c0:c0 + blk.shape[1]] = np.fft.ifft(blk, axis=0)[row]
    image = np.empty((row.size, col.size), dtype=np.complex128)
    for r0 in range(0, row.size, _FFT_BLOCK):
        blk = _fold(half[r0:r0 + _FFT_BLOCK], nfx, 1)
        image[r0:r0 + blk.shape[0]] = np.fft.ifft(blk, axis=1)[:, col]
    image *= (nfy * nfx) * fac_y[:, None] * fac_x[None, :] / kgrid.weights_sum
    return image
