"""Backprojection for any flight path (spherical model) and its exact adjoint, reprojection.

Backprojection evaluates the spherical matched filter (docs/conventions.md "Image formation", paper
eq. ``mf`` with the spherical ``e_pj``)

.. math::

    f(x) = \\frac{1}{W} \\sum_p \\sum_j w_{pj} d_{pj}
           \\exp\\big(+i \\tfrac{4\\pi \\alpha_{pj}}{c} \\Delta r_p(x)\\big),
    \\qquad \\Delta r_p(x) = |a_p - x| - r_{0p},\\quad W = \\sum_{pj} w_{pj},

fast: for equally spaced frequencies ``α_pj = α_ref,p + (j - j_c) Δα_p`` (``j_c = M // 2``,
``α_ref,p = α_p1 + j_c Δα_p``) the sum over j is

.. math::

    e^{+i 4\\pi \\alpha_{ref,p} \\Delta r / c} \\; g_p(\\Delta r), \\qquad
    g_p(\\Delta r) = \\sum_j w_{pj} d_{pj} \\, e^{+i 2\\pi (j - j_c) \\Delta\\alpha_p 2\\Delta r / c},

and ``g_p`` sampled at ``Δr_n = n c / (2 Δα_p L)``, ``n = -L/2 .. L/2 - 1``, is one unnormalised,
zero-padded inverse FFT of length ``L`` (the *range profile*; ``L ≥ upsample·M``, a fast FFT size).
Each pixel then interpolates ``g_p`` at its own differential range and multiplies by the carrier
``exp(+i 4π α_ref Δr / c)``: the IFFT removes every frequency but the reference one, which is
why that carrier (not ``α_1``'s, because the samples are centred on ``j_c``) must be put back.
``g_p`` is periodic in ``Δr`` with period ``c / (2 Δα_p)``; pixels outside the unambiguous window
``|Δr| < c / (4 Δα_p)`` are skipped for that pulse (they contribute zero).

The linear maps
---------------
``backproject`` is the linear map ``B: C^{P×M} → C^{ny×nx}``, ``B d = f`` above, *including*
the window weights and the factor ``1/W``. ``reproject`` is exactly ``Bᴴ`` (the same FFT size,
interpolation weights, carrier and skipped pixels, transposed), so
``⟨B d, f⟩ = ⟨d, Bᴴ f⟩`` to rounding. Without window weights (so ``W = P M``) the spherical forward
model ``A f = Σ_x f(x) exp(-i 4π α Δr(x) / c)`` and its adjoint are approximated by
``A ≈ W · reproject`` and ``Aᴴ ≈ W · backproject`` (both without weights and with the same
options), so ``AᴴA ≈ W² · backproject ∘ reproject``; with weights, ``reproject`` also carries the
factor ``w_pj / W``.

The frequencies enter through the least-squares line ``α_pj ≈ α_ref,p + (j - j_c) Δα_p``
(:func:`sarcli.core.sampling.frequency_line`); their deviations from it are the model's error floor (GOTCHA, whose
frequencies are rounded to float32: 2.4e-4 of the exact matched filter).

The kernels (``src/native/backprojection.cpp``, :mod:`._kernels`) take the differential range
of each tile of up to 128 pixels along a row (of the image, or of its transpose when that puts the
rows across the look direction: :mod:`._rows`) in float64 at the tile's centre, without
cancellation (``Δr = (|x|² - 2 a·x) / (|a - x| + |a|) + (|a| - r0)``), and inside the tile either
a quadratic in the pixel's offset or, near the radar where the quadratic's tiles would narrow, that
quadratic plus the rest of the range's Taylor series to the ninth power in float32 (the series model); :func:`._kernels.tiling` picks the
cheaper within the same error bound. Profile
positions and interpolation weights are float32, the carrier phase float64 reduced modulo 2π and
its sine and cosine a float32 polynomial (error 4e-7). ``precision`` sets the profiles and the
accumulation: ``'float64'`` keeps both in float64, so that :func:`reproject` is the adjoint to
float64 rounding; ``'float32'`` stores and sums in float32 (1e-7 of float64; faster).

Defaults: cubic Lagrange interpolation with 12× oversampled profiles (measured: 2.6e-5 relative
error vs the exact matched filter on the test scene, 1.3e-4 at 8×, where Keys cubic errs 3.5e-5
at 16× and 8.1e-5 at 12×; unit-point peaks within 1e-4 of 1). Linear interpolation needs
``upsample=8`` for 1e-2 (6e-3) and 32 for peaks within 1e-3.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..._native import using_threads
from ...errors import SarcliInputError
from ..._util.progress import progress
from ._kernels import kernels
from ._setup import INTERPOLATORS, PAD, ProfileWork, Setup, check_data, profile_length, profiles

__all__ = ["backproject", "reproject", "pulse_contractions", "profile_length", "INTERPOLATORS", "DEFAULT_UPSAMPLE", "DEFAULT_PRECISION",
           "DEFAULT_INTERP", "MAP_PRECISION", "MAP_UPSAMPLE", "Knobs", "MAP_KNOBS", "FORM_KNOBS", "knobs_of"]

#: Default profile oversampling and interpolation: relative error 2.6e-5 vs the exact matched
#: filter and unit-point peaks 1 ± 1e-4 (measured: see tests/test_backprojection.py); Keys cubic
#: at 16 errs more (3.5e-5) at the same cost a pixel (docs/performance.md).
DEFAULT_UPSAMPLE = 12
DEFAULT_INTERP = "lagrange"
#: Precision of an image formed by backprojection (``form_image``, ``sar form-image``): the tiles'
#: ranges are float64 either way, so float32 profiles and sums err no more than float64 at the
#: interpolation's own error (measured at the default interpolation: GOTCHA 800² 3.44e-4 both, a
#: 740 km orbit 5.4e-5 both) and run faster (docs/performance.md). :func:`backproject` and
#: :func:`reproject` themselves, the linear map and its exact adjoint, default to float64.
DEFAULT_PRECISION = "float32"
#: Precision of the linear maps themselves (:func:`backproject`, :func:`reproject`,
#: :func:`pulse_contractions` and the prepared :class:`~sarcli.formers.backprojection.Backprojector`)
#: when no options are given: float64, so that :func:`reproject` is the adjoint to float64 rounding.
MAP_PRECISION = "float64"
#: Profile oversampling of the linear maps themselves when no options are given: 16, finer than an
#: image's, because the iterative methods that apply them (the regulariser's exact pair, autofocus)
#: take their error for noise in the data (measured: the automatic λ of a 16 x 16-sample spherical
#: scene is 2.1 times larger at 12 than at 16, and its image less accurate than the matched filter's).
MAP_UPSAMPLE = 16


class Knobs(NamedTuple):
    """The knobs the maps read of their ``options``, as
    :class:`~sarcli.formers.options.BackprojectionOptions` carries them: for the modules that the
    options themselves import (the cost model), which cannot import the options back."""

    upsample: float
    interp: str
    precision: str


#: The maps' knobs when no options are given (float64: the adjoint pair).
MAP_KNOBS = Knobs(MAP_UPSAMPLE, DEFAULT_INTERP, MAP_PRECISION)
#: The knobs of an image formed by backprojection (those of ``BackprojectionOptions()``).
FORM_KNOBS = Knobs(DEFAULT_UPSAMPLE, DEFAULT_INTERP, DEFAULT_PRECISION)


def knobs_of(options) -> Knobs:
    """``(upsample, interp, precision)`` of a :class:`~sarcli.formers.options.BackprojectionOptions`
    (or a :class:`Knobs`); None: :data:`MAP_KNOBS` (16, 'lagrange', 'float64')."""
    if options is None:
        return MAP_KNOBS
    return Knobs(options.upsample, options.interp, options.precision)



# ---------------------------------------------------------------------------------------------
# public functions
# ---------------------------------------------------------------------------------------------
def backproject(data, collection, grid, options=None, *, nthreads=None) -> np.ndarray:
    """Spherical matched-filter image by fast backprojection (paper eq. ``mf``, spherical ``e_pj``).

    Parameters
    ----------
    data : array_like, shape (P, M), complex
        Phase history ``d[p, j]`` (spherical model, docs/conventions.md).
    collection : Collection
        The collection (:class:`sarcli.core.collection.Collection`): frequencies (shape (M,) or
        (P, M), equally spaced within each pulse, else use method ``direct``), antenna phase centres
        ``a_p`` (P, 3; any flight path), reference ranges ``r0_p`` (P,), window weights ``w_pj``
        (default 1) and, optionally, separate receive positions ``q_p`` (P, 3): then the antenna
        positions are the transmit positions ``t_p`` and ``Δr = (|t_p - x| + |q_p - x|)/2 - r0_p``
        (moving platform or bistatic).
    grid : Grid
        Image grid in the plane z = 0.
    options : BackprojectionOptions, optional
        The knobs (:class:`sarcli.formers.options.BackprojectionOptions`): ``upsample``, the
        profile oversampling (the IFFT length is ``upsample·M`` rounded up to a fast size);
        ``interp``, the range-profile interpolation ('linear', Keys 'cubic' (a = -1/2), cubic
        'lagrange' (the same 4 taps, exact for cubics) or normalised 'lanczos'-3); ``precision``, of the range profiles and the accumulation
        ('float64' or 'float32'; geometry is float64 per tile, interpolation weights and carrier
        float32 in both; module docstring). None: :data:`MAP_KNOBS` (16, 'lagrange', float64).
    nthreads : int, optional
        Threads of the kernel (default: ``sarcli._native.threads()``).

    Returns
    -------
    image : ndarray, shape (ny, nx), complex128
        ``(1/W) Σ w d e_pj(x)``, so a unit point scatterer peaks at 1. Pixels outside a pulse's
        unambiguous window ``|Δr| < c/(4Δα)`` receive nothing from that pulse.

    Raises
    ------
    SarcliInputError
        Unequally spaced frequencies, fewer than two frequencies, mismatched shapes, bad options.

    Notes
    -----
    This is the linear map ``B`` of the module docstring; :func:`reproject` is ``Bᴴ``.

    Examples
    --------
    >>> import numpy as np
    >>> from sarcli.core import geometry
    >>> from sarcli.core.collection import Collection
    >>> from sarcli.core.grid import Grid
    >>> freq = 9.8e9 + 5e6 * np.arange(64)
    >>> az = np.radians(np.linspace(-1.5, 1.5, 32))
    >>> a = geometry.antenna_positions_circle(az, np.radians(30), 10e3)
    >>> r0 = np.linalg.norm(a, axis=1)
    >>> psi = geometry.signal_phase(freq, az, np.radians(30), [[1.0, 2.0, 0.0]], model="spherical",
    ...                             antenna_position_m=a, range_to_center_m=r0)
    >>> img = backproject(np.exp(-1j * psi[..., 0]), Collection(freq, a, r0), Grid(40, 40, 0.25, 0.25))
    >>> row, col = np.unravel_index(np.argmax(abs(img)), img.shape)
    >>> int(row), int(col), float(round(abs(img[row, col]), 3))   # x = 1 m, y = 2 m
    (28, 24, 1.0)
    """
    d = check_data(data)
    st = Setup(d.shape, collection, grid, *knobs_of(options))
    cdt = np.complex64 if st.dtype == np.float32 else np.complex128
    out_re = np.zeros(st.kernel_shape)
    out_im = np.zeros(st.kernel_shape)
    kern = kernels()
    work = ProfileWork(st.block, st.m, st.n_len, cdt)   # one set of block buffers for every block
    with using_threads(nthreads):
        blocks = st.blocks()
        for sl in progress(blocks, total=len(blocks), desc="backprojection", unit="pulse block"):
            # w d / W on FFT slots (j - j_c) mod L, unnormalised IFFT, fftshift: profile index
            # q holds Δr = (q - L/2) c / (2 Δα L); periodic copies pad both ends
            prof = profiles(work.samples(d, sl), None if st.weights is None else st.weights[sl],
                            st.total_weight, st.n_len, cdt, work)
            # real and imaginary parts interleaved: [B, n_len + 2 pad, 2]
            kern.bp_tiles(prof.view(st.dtype).reshape(prof.shape + (2,)), *st.kernel_args(sl),
                          st.cache_block, out_re, out_im)
    return st.image(out_re, out_im)


def pulse_contractions(data, g, collection, grid, options=None, *, nthreads=None) -> np.ndarray:
    """``v_p = Σ_s g_s (B_p d_p)_s``: each pulse's backprojection (:func:`backproject` of that pulse
    alone, same normalisation) contracted with an image-shaped ``g``, shape (P,), complex128.

    The same numbers as ``np.sum(np.conj(reproject(np.conj(g), ...)) * data, axis=1)`` (the
    per-pulse derivative of an image functional whose gradient is ``g``), computed by gathering
    from each pulse's profile as the forward kernel does rather than scattering onto it.
    Arguments as for :func:`backproject`; ``g`` has the grid's shape.
    """
    d = check_data(data)
    gg = np.asarray(g)
    if gg.shape != grid.shape:
        raise SarcliInputError(f"g shape {gg.shape} does not match the grid {grid.shape}")
    st = Setup(d.shape, collection, grid, *knobs_of(options))
    cdt = np.complex64 if st.dtype == np.float32 else np.complex128
    gre, gim = st.kernel_input(gg)
    out = np.empty(st.n_pulses, dtype=np.complex128)
    kern = kernels()
    work = ProfileWork(st.block, st.m, st.n_len, cdt)
    with using_threads(nthreads):
        for sl in st.blocks():
            prof = profiles(work.samples(d, sl), None if st.weights is None else st.weights[sl],
                            st.total_weight, st.n_len, cdt, work)
            acc = np.empty((sl.stop - sl.start, 2))
            kern.bp_contract(prof.view(st.dtype).reshape(prof.shape + (2,)), gre, gim,
                             *st.kernel_args(sl), st.cache_block, acc)
            out[sl] = acc[:, 0] + 1j * acc[:, 1]
    return out


def reproject(image, collection, grid, options=None, *, nthreads=None) -> np.ndarray:
    """Exact adjoint of :func:`backproject`: image → phase history, shape (P, M).

    Parameters
    ----------
    image : array_like, shape (ny, nx), complex
        Image on ``grid``.
    collection, grid
        As for :func:`backproject` (the number of pulses P is taken from the antenna positions,
        M from the frequencies).
    options, nthreads
        As for :func:`backproject`; use the same options to get its exact adjoint.

    Returns
    -------
    data : ndarray, shape (P, M), complex128
        ``Bᴴ f``: for every pulse, the conjugate-carrier image scattered onto the range profile
        with the transposed interpolation, then the forward FFT, the frequency slots and the
        factor ``w_pj / W``. Thus ``⟨backproject(d), f⟩ = ⟨d, reproject(f)⟩`` and, with
        no weights, ``W · reproject`` (``W = P M``) approximates the spherical forward
        model ``d = Σ_x f(x) exp(-i 4π α Δr(x) / c)``.
    """
    f = np.asarray(image)
    if f.shape != grid.shape:
        raise SarcliInputError(f"image shape {f.shape} does not match the grid {grid.shape}")
    a = np.asarray(collection.antenna_position_m)
    fr = np.asarray(collection.frequency_hz)
    if a.ndim != 2:
        raise SarcliInputError(f"antenna positions must be (P, 3), got {a.shape}")
    st = Setup((a.shape[0], fr.shape[-1]), collection, grid, *knobs_of(options))
    fre, fim = st.kernel_input(f)
    n_padded = st.n_len + 2 * PAD
    out = np.empty((st.n_pulses, st.m), dtype=np.complex128)
    kern = kernels()
    with using_threads(nthreads):
        for sl in st.blocks():
            nb = sl.stop - sl.start
            hri = np.zeros((nb, n_padded, 2), dtype=st.dtype)
            kern.rp_tiles(fre, fim, *st.kernel_args(sl), hri)
            out[sl] = st.samples_from_profiles(hri)
    if st.weights is not None:
        out *= st.weights
    return out
