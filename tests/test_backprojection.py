"""Backprojection vs the exact spherical matched filter, and reprojection as its exact adjoint.

The reference is a brute-force sum of docs/conventions.md's spherical matched filter
``(1/W) Σ_pj w d exp(+i 4π α Δr / c)`` with ``Δr`` from ``geometry.differential_range``; test data
come from the closed form ``geometry.signal_phase``.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarcli._native.layout import BpGeo
from sarcli.core import geometry
from sarcli.errors import AliasingWarning, SarcliInputError
from sarcli.formers.backprojection._kernels import kernels, next_fast_len, tile_width
from sarcli.formers.backprojection import (DEFAULT_INTERP, DEFAULT_UPSAMPLE, MAP_UPSAMPLE, Knobs, backproject,
                                           profile_length, reproject)
from sarcli.formers.options import BackprojectionOptions
from sarcli.core.collection import Collection
from sarcli.core.grid import Grid

GRID = Grid.square(10.0, 80)  # 20 m x 20 m, 0.25 m pixels


def exact_mf(data, freq, a, r0, grid, weights=None):
    """Brute-force spherical matched filter, normalised by W."""
    P, M = data.shape
    f = np.broadcast_to(np.asarray(freq, float), (P, M))
    w = np.ones((P, M)) if weights is None else np.broadcast_to(weights, (P, M))
    dr = geometry.differential_range(a, r0, grid.points().reshape(-1, 3))
    out = np.zeros(dr.shape[1], complex)
    for p in range(P):
        out += (w[p] * data[p]) @ np.exp(1j * 4 * np.pi / geometry.C * f[p][:, None] * dr[p][None, :])
    return (out / w.sum()).reshape(grid.shape)


def collection(points, amps, *, P=64, M=64, r0=10e3, el_deg=30.0, fc=10e9, bw=300e6, aperture_deg=3.0,
               freq=None):
    """Circular-path spotlight data of point scatterers (spherical model, closed form)."""
    el = np.radians(el_deg)
    if freq is None:
        freq = fc - bw / 2 + np.arange(M) * bw / (M - 1)
    az = np.radians(np.linspace(-aperture_deg / 2, aperture_deg / 2, P))
    a = geometry.antenna_positions_circle(az, el, r0)
    rr = np.linalg.norm(a, axis=1)
    psi = geometry.signal_phase(freq, az, np.full(P, el), np.atleast_2d(points), model="spherical",
                                antenna_position_m=a, range_to_center_m=rr)
    return (np.exp(-1j * psi) * np.asarray(amps)).sum(-1), freq, a, rr


def rel_err(f, ref):
    return np.linalg.norm(f - ref) / np.linalg.norm(ref)


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-8, 8, 6), rng.uniform(-8, 8, 6), np.zeros(6)])
    amps = rng.normal(size=6) + 1j * rng.normal(size=6)
    data, freq, a, r0 = collection(pts, amps)
    return data, freq, a, r0, exact_mf(data, freq, a, r0, GRID)


def test_default_settings_match_exact_matched_filter(scene):
    data, freq, a, r0, ref = scene
    err = rel_err(backproject(data, Collection(freq, a, r0), GRID), ref)
    assert (DEFAULT_INTERP, DEFAULT_UPSAMPLE, MAP_UPSAMPLE) == ("lagrange", 12, 16)
    assert err < 1e-3  # the contract is 1e-2
    # an image's default (float32, Lagrange at 12) errs less than Keys at 16 (measured 2.6e-5, 3.5e-5)
    img = backproject(data, Collection(freq, a, r0), GRID, BackprojectionOptions())
    keys = backproject(data, Collection(freq, a, r0), GRID, BackprojectionOptions(interp="cubic", upsample=16))
    assert rel_err(img, ref) < rel_err(keys, ref) < 5e-5


def test_error_falls_with_upsampling_and_higher_order_kernel(scene):
    data, freq, a, r0, ref = scene
    col = Collection(freq, a, r0)

    def err(upsample, interp):
        opts = BackprojectionOptions(upsample=upsample, interp=interp, precision="float64")
        return rel_err(backproject(data, col, GRID, opts), ref)

    lin = [err(u, "linear") for u in (2, 4, 8, 16)]
    cub = [err(u, "cubic") for u in (2, 4, 8, 16)]
    lan = err(4, "lanczos")
    # linear interpolation error is O(1/u²): each doubling divides it by about 4
    assert all(e1 / e2 > 3.5 for e1, e2 in zip(lin, lin[1:])), lin
    assert all(e1 / e2 > 7.0 for e1, e2 in zip(cub, cub[1:])), cub  # cubic: at least O(1/u³)
    assert all(c < l / 3 for c, l in zip(cub, lin)), (cub, lin)
    assert lan < lin[1] / 3
    assert lin[2] < 1e-2  # linear needs upsample 8 for the 1e-2 contract (measured 6.2e-3)


def test_lagrange_errs_less_than_keys_at_the_same_upsampling(scene):
    """Cubic Lagrange is exact for cubics (error O(1/u⁴) in the profile upsampling u, Keys' O(1/u³)):
    against the exact matched filter it errs less than Keys at every upsampling, by the factor the
    planner's model predicts, and at 12 less than Keys at 16."""
    from sarcli.formers.ffbp.model import interp_error

    data, freq, a, r0, ref = scene
    col = Collection(freq, a, r0)

    def err(upsample, interp):
        opts = BackprojectionOptions(upsample=upsample, interp=interp, precision="float64")
        return rel_err(backproject(data, col, GRID, opts), ref)

    ups = (4, 8, 12, 16)
    keys = {u: err(u, "cubic") for u in ups}
    lag = {u: err(u, "lagrange") for u in ups}
    for u in ups:
        # measured: ratio 0.72 (u=4), 0.45 (8), 0.32 (12), 0.24 (16), the model's within 4%
        model = interp_error("lagrange", u) / interp_error("cubic", u)
        assert lag[u] < 1.1 * model * keys[u], (u, keys[u], lag[u], model)
    assert lag[8] / lag[16] > 12, lag            # O(1/u⁴): 16 (measured 15.8)
    assert keys[8] / keys[16] < 10, keys          # O(1/u³): 8 (measured 8.3)
    assert lag[12] < keys[16], (lag, keys)        # measured 2.6e-5 against 3.5e-5


@pytest.mark.parametrize("interp,upsample", [(DEFAULT_INTERP, DEFAULT_UPSAMPLE), ("linear", 32)])
def test_unit_point_on_pixel_centre_peaks_at_one(interp, upsample):
    for row, col in [(35, 43), (20, 61), (70, 9)]:
        x0, y0 = GRID.x[col], GRID.y[row]
        data, freq, a, r0 = collection([[x0, y0, 0.0]], [1.0])
        opts = BackprojectionOptions(interp=interp, upsample=upsample, precision="float64")
        img = backproject(data, Collection(freq, a, r0), GRID, opts)
        assert np.unravel_index(np.argmax(np.abs(img)), img.shape) == (row, col)
        assert abs(img[row, col] - 1.0) < 1e-3  # magnitude and phase


def test_weights_and_per_pulse_frequencies_match_reference():
    rng = np.random.default_rng(3)
    P, M = 24, 48
    pts = [[2.0, -3.0, 0.0], [-5.5, 4.25, 0.0]]
    base = 9.8e9 + np.arange(M) * 5e6
    freq = base[None, :] + rng.uniform(0, 20e6, size=(P, 1))  # each pulse its own start
    data, _, a, r0 = collection(pts, [1.0, 0.5j], P=P, M=M, freq=freq)
    w = np.outer(np.hanning(P + 2)[1:-1], np.hamming(M))
    ref = exact_mf(data, freq, a, r0, GRID, w)
    img = backproject(data, Collection(freq, a, r0, w), GRID)
    assert rel_err(img, ref) < 1e-3


def test_float32_precision_at_100_km_keeps_phase(monkeypatch):
    """r0 = 100 km: the float32 path (float64 tile geometry, float32 inside) keeps float64's phase.
    Both run the rows across the look: float64's profile samples span twice float32's cache lines, so
    at 48 pulses the two would otherwise pick different orientations (tilings whose range models
    differ within MODEL_TOLERANCE)."""
    import sarcli.formers.backprojection._rows as bp_rows

    monkeypatch.setattr(bp_rows, "TRANSPOSE_COST", 0.0)
    pts = [[7.25, -6.5, 0.0], [-9.0, 9.5, 0.0], [0.0, 0.0, 0.0]]
    data, freq, a, r0 = collection(pts, [1.0, 1.0, 1.0], r0=100e3, P=48, M=64)
    f64 = backproject(data, Collection(freq, a, r0), GRID, BackprojectionOptions(precision="float64"))
    f32 = backproject(data, Collection(freq, a, r0), GRID, BackprojectionOptions(precision="float32"))
    ref = exact_mf(data, freq, a, r0, GRID)
    strong = np.abs(ref) > 0.1
    phase_err = np.max(np.abs(np.angle(f32[strong] / f64[strong])))
    # measured on AVX-512 / AVX2 / baseline kernels (SARCLI_BP_ISA=2, 1, 0): 6.9e-7, 6.9e-7, 6.9e-7 rad
    # (the 48 pulses summed in float32 in one pass over the image, the rows across the look)
    assert phase_err < 1e-6
    assert np.max(np.abs(np.angle(f32[strong] / ref[strong]))) < 1.2e-4   # measured 4.6e-5 (interpolation)
    assert rel_err(f32, ref) < 4e-5   # measured 2.4e-5, float64's own error
    assert rel_err(f32, f64) < 2e-7   # measured 1.5e-7 (Keys at 16: 1.3e-7)


@pytest.mark.parametrize("precision,tol", [("float64", 1e-14), ("float32", 2e-6)])
@pytest.mark.parametrize("interp", ["linear", "cubic", "lanczos", "lagrange"])
def test_reproject_is_exact_adjoint(interp, precision, tol):
    rng = np.random.default_rng(7)
    P, M = 20, 32
    data, freq, a, r0 = collection([[0.0, 0.0, 0.0]], [1.0], P=P, M=M)
    grid = Grid(40, 36, 0.5, 0.6, 3.0, -2.0)  # x up to 13 m: 19% of pixel-pulses skipped
    d = rng.normal(size=(P, M)) + 1j * rng.normal(size=(P, M))
    f = rng.normal(size=grid.shape) + 1j * rng.normal(size=grid.shape)
    w = rng.uniform(0.1, 1.0, size=(P, M))
    col, opts = Collection(freq, a, r0, w), BackprojectionOptions(upsample=3, interp=interp, precision=precision)
    # the grid reaches past the unambiguous window (±7.7 m): skipped pixels are transposed too
    with pytest.warns(AliasingWarning):
        lhs = np.vdot(f, backproject(d, col, grid, opts))
    with pytest.warns(AliasingWarning):
        rhs = np.vdot(reproject(f, col, grid, opts), d)
    # measured: float64 2e-16 to 4e-16 (the same float32 weights, float64 profiles and sums);
    # float32 1e-7 to 2e-7 (float32 profiles and sums)
    assert abs(lhs - rhs) / abs(lhs) < tol
    assert rhs != 0


@pytest.mark.filterwarnings("ignore::sarcli.errors.AliasingWarning")  # corners only; x0 is inside
def test_reproject_scaled_by_w_approximates_forward_model():
    """W · reproject(δ at x0) is the spherical data of a unit point at x0 (to interpolation error)."""
    P, M = 16, 32
    row, col = 30, 50
    x0, y0 = GRID.x[col], GRID.y[row]
    data, freq, a, r0 = collection([[x0, y0, 0.0]], [1.0], P=P, M=M)
    delta = np.zeros(GRID.shape, complex)
    delta[row, col] = 1.0
    model = P * M * reproject(delta, Collection(freq, a, r0), GRID)
    assert rel_err(model, data) < 2e-3


def test_grid_outside_unambiguous_window_gives_zeros(scene):
    data, freq, a, r0, _ = scene
    window = geometry.C / (4 * (freq[1] - freq[0]))  # |Δr| < c / (4 Δα) ≈ 32 m here
    far = Grid(16, 16, 0.5, 0.5, -1000.0, 0.0)     # about 1 km down-range: far outside
    assert window < 100
    for prec in ("float64", "float32"):
        with pytest.warns(AliasingWarning, match="unambiguous range window"):
            img = backproject(data, Collection(freq, a, r0), far, BackprojectionOptions(precision=prec))
        assert np.count_nonzero(img) == 0
    with pytest.warns(AliasingWarning):
        assert np.count_nonzero(reproject(np.ones(far.shape), Collection(freq, a, r0), far)) == 0
    # a grid straddling the window edge: inside pixels match the reference, outside are zero
    edge = Grid(8, 8, 1.0, 1.0, -window / np.cos(np.radians(30.0)), 0.0)
    with pytest.warns(AliasingWarning):
        img = backproject(data, Collection(freq, a, r0), edge)
    dr = geometry.differential_range(a, r0, edge.points())
    assert np.all(img[np.all(np.abs(dr) >= window * 1.001, axis=0)] == 0)
    assert np.count_nonzero(img[np.all(np.abs(dr) < window * 0.999, axis=0)]) > 0


def test_decreasing_frequencies_give_the_same_image(scene):
    data, freq, a, r0, ref = scene
    img = backproject(data[:, ::-1], Collection(freq[::-1], a, r0), GRID)
    assert rel_err(img, ref) < 1e-3


def test_thread_count_does_not_change_result(scene):
    data, freq, a, r0, _ = scene
    one = backproject(data, Collection(freq, a, r0), GRID, nthreads=1)
    two = backproject(data, Collection(freq, a, r0), GRID, nthreads=2)
    assert np.max(np.abs(one - two)) < 1e-12


def test_unequal_frequency_spacing_is_refused():
    freq = np.sort(np.random.default_rng(0).uniform(9.8e9, 10.2e9, 32))
    data, _, a, r0 = collection([[0.0, 0.0, 0.0]], [1.0], P=4, M=32, freq=freq)
    with pytest.raises(SarcliInputError, match="direct"):
        backproject(data, Collection(freq, a, r0), GRID)
    with pytest.raises(SarcliInputError, match="interp must be one of linear, cubic, lanczos"):
        BackprojectionOptions(interp="nearest")
    with pytest.raises(SarcliInputError, match="interpolation"):   # the maps' own check
        backproject(data, Collection(np.linspace(9e9, 1e10, 32), a, r0), GRID, Knobs(16, "nearest", "float64"))


def test_profile_length_is_even_fast_and_large_enough():
    for m, u in [(424, 8), (64, 3), (101, 4.5)]:
        n = profile_length(m, u)
        assert n % 2 == 0 and n >= u * m and n < 1.25 * u * m + 2


def test_polynomial_carrier_matches_libm():
    """The kernels' carrier (float64 reduction, float32 polynomial) against numpy."""
    k = kernels()
    x = np.random.default_rng(5).uniform(-3e4, 3e4, 20000)
    c = np.empty(x.size, np.float32)
    s = np.empty(x.size, np.float32)
    k.carrier_values(x, c, s)
    assert np.max(np.abs(c + 1j * s - np.exp(1j * x))) < 6e-7  # measured 3.9e-7


def test_interpolation_weights_match_their_formulas():
    k = kernels()
    t = np.linspace(0.0, 1.0, 101, endpoint=False).astype(np.float32)
    td = t.astype(np.float64)
    for kind, taps in ((0, 2), (1, 4), (2, 6), (4, 4)):
        w = np.empty((t.size, taps), np.float32)
        k.weight_values(t, kind, w)
        if kind == 0:
            ref = np.stack([1 - td, td], 1)
        elif kind == 1:   # Keys a = -1/2 at offsets -1, 0, 1, 2
            d = np.abs(td[:, None] - np.arange(-1, 3)[None, :])
            ref = np.where(d < 1, 1.5 * d**3 - 2.5 * d**2 + 1, -0.5 * d**3 + 2.5 * d**2 - 4 * d + 2)
        elif kind == 4:   # cubic Lagrange at offsets -1, 0, 1, 2: Π_{m≠n} (t - m) / (n - m)
            offs = np.arange(-1, 3)
            ref = np.stack([np.prod([(td - m) / (n - m) for m in offs if m != n], axis=0) for n in offs], 1)
        else:             # normalised Lanczos-3 at offsets -2..3
            d = td[:, None] - np.arange(-2, 4)[None, :]
            ref = np.sinc(d) * np.sinc(d / 3)
            ref /= ref.sum(1, keepdims=True)
        assert np.max(np.abs(w - ref)) < 2e-6, kind


def test_lagrange_weights_sum_to_one_and_reproduce_cubics():
    """The kernels' Lagrange weights (float32) interpolate every cubic exactly (to float32
    rounding) and sum to one; Keys' reproduce only quadratics (its error on t³ is of order 0.1)."""
    k = kernels()
    t = np.random.default_rng(3).uniform(0.0, 1.0, 997).astype(np.float32)
    td = t.astype(np.float64)
    offs = np.arange(-1, 3, dtype=np.float64)
    lag, keys = np.empty((t.size, 4), np.float32), np.empty((t.size, 4), np.float32)
    k.weight_values(t, 4, lag)
    k.weight_values(t, 1, keys)
    assert np.max(np.abs(lag.astype(np.float64).sum(1) - 1)) < 1e-6
    for power in range(4):
        exact = td ** power
        assert np.max(np.abs(lag @ offs ** power - exact)) < 4e-6, power   # measured ≤ 1e-6
    assert np.max(np.abs(keys @ offs ** 3 - td ** 3)) > 0.05
    assert np.max(np.abs(keys @ offs ** 2 - td ** 2)) < 4e-6


def test_next_fast_len_matches_scipy():
    scipy_fft = pytest.importorskip("scipy.fft")
    for n in list(range(1, 300)) + [3391, 4097, 6785, 8193, 12289]:
        assert next_fast_len(n) == scipy_fft.next_fast_len(n), n


@pytest.mark.parametrize("level", ["0", "1"])
def test_every_instruction_set_gives_the_same_image(scene, monkeypatch, level):
    """The AVX2 and baseline copies of the kernels against the best one here."""
    data, freq, a, r0, _ = scene
    col = Collection(freq, a, r0)
    kws = [BackprojectionOptions(interp=i, precision=p) for i in ("linear", "cubic", "lanczos", "lagrange")
           for p in ("float64", "float32")]
    best = [backproject(data, col, GRID, kw) for kw in kws]
    monkeypatch.setenv("SARCLI_BP_ISA", level)
    for kw, ref in zip(kws, best):
        # measured: AVX2 = AVX-512 bit for bit; baseline (no fused multiply-adds) 4e-7
        assert rel_err(backproject(data, col, GRID, kw), ref) < 4e-6, kw


def test_orbit_range_keeps_phase():
    """r0 = 800 km (a 740 km orbit): the tiled range model against the exact matched filter."""
    pts = [[20.0, -12.5, 0.0], [-31.0, 27.5, 0.0], [0.0, 0.0, 0.0]]
    grid = Grid.square(40.0, 80)                    # 1 m pixels
    data, freq, a, r0 = collection(pts, [1.0, 0.7, 1.0], r0=800e3, el_deg=50.0, P=96, M=128,
                                   aperture_deg=0.2)
    ref = exact_mf(data, freq, a, r0, grid)
    for prec in ("float64", "float32"):
        img = backproject(data, Collection(freq, a, r0), grid, BackprojectionOptions(precision=prec))
        strong = np.abs(ref) > 0.1
        # measured 2.4e-5 rad (2.5e-5 on the baseline kernels), 1.9e-5 on every instruction set
        assert np.max(np.abs(np.angle(img[strong] / ref[strong]))) < 4e-5
        assert rel_err(img, ref) < 3e-5, prec


def test_tiles_narrow_near_the_antenna():
    grid = Grid.square(10.0, 80)
    assert tile_width(grid, 10e3, 420.0, 30.0) == 16
    assert tile_width(grid, 100.0, 420.0, 30.0) < 16
    # an antenna 60 m from a 20 m grid: narrow tiles keep the image exact (16-pixel tiles: 2.5e-2)
    pts = [[3.0, -2.0, 0.0]]
    data, freq, a, r0 = collection(pts, [1.0], r0=60.0, el_deg=45.0, P=32, M=64, aperture_deg=20.0)
    ref = exact_mf(data, freq, a, r0, GRID)
    img = backproject(data, Collection(freq, a, r0), GRID, BackprojectionOptions(upsample=32, precision="float64"))
    near = np.abs(ref) > 0.05 * np.abs(ref).max()
    assert rel_err(img[near], ref[near]) < 4e-6   # measured 1.9e-6


def test_range_profiles_are_the_padded_inverse_fft():
    """range_profiles (shared with ffbp) against numpy, with (M,), (1, M) and (P, M) weights."""
    from sarcli.formers.backprojection._setup import PAD, range_profiles

    rng = np.random.default_rng(2)
    P, M, L = 37, 24, 96
    d = rng.normal(size=(P, M)) + 1j * rng.normal(size=(P, M))
    w = rng.uniform(0.5, 1.0, M)
    buf = np.zeros((P, L), complex)
    buf[:, (np.arange(M) - M // 2) % L] = d * w / 3.0
    ref = np.fft.fftshift(np.fft.ifft(buf, axis=1) * L, axes=1)
    ref = np.concatenate([ref[:, -PAD:], ref, ref[:, :PAD]], axis=1)
    for wk in (w, w[None, :], np.broadcast_to(w, (P, M))):
        re, im = range_profiles(d, wk, 3.0, L, 1)
        assert np.max(np.abs(re + 1j * im - ref)) < 1e-12


@pytest.mark.parametrize("threaded", [False, True])
def test_profiles_of_every_block_through_one_work_are_the_padded_inverse_fft(monkeypatch, threaded):
    """Blocks of pulses one after another through one ProfileWork, on one thread (numpy's FFT into the
    spectrum) and on two (scipy's, which may use the spectrum as scratch and return another array):
    every block's profiles are the padded inverse FFT of its own samples. (With the threaded FFT
    the spectrum's zero padding was taken as intact after the first block, and every later block's
    profiles carried the first's leftovers: backprojection of 1024² pixels from 1024 pulses erred
    4.5e-2.)"""
    import sarcli.formers.backprojection._setup as bs
    from sarcli._native import using_threads

    monkeypatch.setattr(bs, "THREADED_FFT_SAMPLES", 0 if threaded else 1 << 40)
    rng = np.random.default_rng(5)
    P, M, L, B = 40, 24, 96, 16
    d = rng.normal(size=(P, M)) + 1j * rng.normal(size=(P, M))
    work = bs.ProfileWork(B, M, L, np.complex128)
    with using_threads(2 if threaded else 1):
        for lo in range(0, P, B):
            blk = d[lo:lo + B]
            got = bs.profiles(blk, None, 3.0, L, np.complex128, work).copy()
            buf = np.zeros((blk.shape[0], L), complex)
            buf[:, (np.arange(M) - M // 2) % L] = blk / 3.0
            ref = np.fft.fftshift(np.fft.ifft(buf, axis=1) * L, axes=1)
            ref = np.concatenate([ref[:, -bs.PAD:], ref, ref[:, :bs.PAD]], axis=1)
            assert np.max(np.abs(got - ref)) < 1e-12, lo


# ---------------------------------------------------------------------------------------------
# The range models near and far from the radar (the quadratic and the exact, backprojection._kernels.tiling)
# ---------------------------------------------------------------------------------------------
def _tone_collection(r0, dx, *, P=4, M=16, n=128, el_deg=30.0, tone=0):
    """One frequency lit per pulse (``j = M//2 + tone``): the range profile is a pure tone that the
    16x-oversampled interpolation reproduces to ~1e-7, so the image's departure from the exact
    matched filter is the range model's, in radians (scaled by W / P = M)."""
    grid = Grid(n, n, dx, dx)
    el = np.radians(el_deg)
    dalpha = geometry.C / (4.0 * 1.2 * grid.half_diagonal * np.cos(el))
    freq = 10e9 - dalpha * M / 2 + dalpha * np.arange(M)
    a = geometry.antenna_positions_circle(np.radians(np.linspace(-10, 10, P)), el, r0)
    r0s = np.linalg.norm(a, axis=1)
    data = np.zeros((P, M), complex)
    data[:, M // 2 + tone] = 1.0
    return data, freq, a, r0s, grid


def _forced_tiling(monkeypatch, model, width):
    import sarcli.formers.backprojection._kernels as bk
    import sarcli.formers.backprojection._rows as _bp_rows

    monkeypatch.setattr(_bp_rows, "tiling", lambda *args, **kw: bk.Tiling(model, width, 0.0, 1.0))


@pytest.mark.parametrize("model", ["quadratic", "series"])
@pytest.mark.parametrize("r0", [30.0, 200.0, 1e3, 1e4, 1e6])
def test_range_model_error_within_its_bound(monkeypatch, model, r0):
    """Each model, forced to 64-, 16- and 4-pixel tiles: the largest phase error against the exact
    matched filter is within the bound the tiling is chosen by (quadratic_error / series_error times
    the larger of kc and 1/bin), plus the float32 carrier's and weights' floor; and the quadratic's
    bound is sharp (within 10x) wherever its error rises above that floor."""
    import sarcli.formers.backprojection._kernels as bk
    from sarcli.formers.backprojection._setup import Setup

    floor = 1.5e-6   # measured 3e-7 (AVX-512, AVX2) to 7e-7 (baseline)
    bound = bk.quadratic_error if model == "quadratic" else bk.series_error
    for tone in (0, 1):   # tone 1: its interpolation error stays below the floor (tone 3: 6e-6)
        data, freq, a, r0s, grid = _tone_collection(r0, min(0.25, r0 / 300), tone=tone)
        ref = exact_mf(data, freq, a, r0s, grid)
        st = Setup(data.shape, Collection(freq, a, r0s), grid, DEFAULT_UPSAMPLE, "cubic", "float32")
        scale = max(np.max(np.abs(st.geo[BpGeo.KC])), np.max(np.abs(st.geo[BpGeo.INV_BIN])))
        r_min = bk.min_range(a, grid)
        for width in (64, 16, 4):
            _forced_tiling(monkeypatch, model, width)
            img = backproject(data, Collection(freq, a, r0s), grid, BackprojectionOptions(precision="float32"))
            err = np.max(np.abs(img - ref)) * data.shape[1]
            predicted = bound(0.5 * (width - 1) * grid.dx, r_min) * scale
            assert err <= predicted + floor, (tone, width, err, predicted)
            if model == "quadratic" and err > 10 * floor:
                assert err > predicted / 10, (tone, width, err, predicted)   # measured 0.3-0.6


@pytest.mark.parametrize("r0", [200.0, 1e3, 1e4])
def test_rows_across_the_look_direction_keep_the_cosine_bound(monkeypatch, r0):
    """The antennas at azimuth 90° ± 10° (rows across the look direction): at 128-pixel tiles the
    quadratic's largest phase error against the exact matched filter is within its bound taken at
    the collection's largest direction cosine along the rows (``row_cosine``), and that bound gives
    the quadratic wider tiles than the cosine-blind bound, and a tiling at least as cheap."""
    import sarcli.formers.backprojection._kernels as bk
    from sarcli.formers.backprojection._setup import Setup

    floor = 1.5e-6
    data, freq, a, r0s, grid = _tone_collection(r0, min(0.25, r0 / 300), n=256)
    a = np.c_[-a[:, 1], a[:, 0], a[:, 2]]   # the flight path turned by 90°: looking along y
    ref = exact_mf(data, freq, a, r0s, grid)
    st = Setup(data.shape, Collection(freq, a, r0s), grid, DEFAULT_UPSAMPLE, "cubic", "float32")
    kc, ib = np.max(np.abs(st.geo[BpGeo.KC])), np.max(np.abs(st.geo[BpGeo.INV_BIN]))
    r_min, c_max = bk.min_range(a, grid), bk.row_cosine(a, grid)
    assert c_max < 0.5   # below 1/√3, where the cosine-blind bound sits
    _forced_tiling(monkeypatch, "quadratic", 128)
    img = backproject(data, Collection(freq, a, r0s), grid, BackprojectionOptions(precision="float32"))
    err = np.max(np.abs(img - ref)) * data.shape[1]
    assert err <= bk.quadratic_error(0.5 * 127 * grid.dx, r_min, c_max) * max(kc, ib) + floor
    monkeypatch.undo()
    blind, aware = bk.tiling(grid, r_min, kc, ib), bk.tiling(grid, r_min, kc, ib, c_max=c_max)
    assert aware.cost <= blind.cost and st.tiling == aware
    wide, narrow = tile_width(grid, r_min, kc, ib, c_max), tile_width(grid, r_min, kc, ib)
    assert wide > narrow if r0 >= 1e3 else wide >= narrow   # at 200 m the quartic term sets both


def test_a_coarse_interpolator_prices_its_tiles_for_its_own_accuracy(monkeypatch):
    """Linear interpolation at 4x errs 2.5e-2: its range model may add 1 % of that (2.5e-4 rad), the
    default's keeps MODEL_TOLERANCE; the cheaper tiling it takes changes its image by no more than that
    tolerance against the same image at the default's tiling."""
    import sarcli.formers.backprojection._kernels as bk
    import sarcli.formers.backprojection._rows as bp_rows
    from sarcli.formers.backprojection._setup import Setup
    from sarcli.formers.ffbp.model import interp_error

    assert bk.model_tolerance("cubic", 16) == bk.MODEL_TOLERANCE
    tol = bk.model_tolerance("linear", 4)
    assert tol == pytest.approx(bk.MODEL_SHARE * interp_error("linear", 4.0)) and tol > 10 * bk.MODEL_TOLERANCE
    data, freq, a, r0s, grid = _tone_collection(1e4, 0.25, n=256)
    col = Collection(freq, a, r0s)
    lin = BackprojectionOptions(precision="float32", interp="linear", upsample=4)
    coarse = Setup(data.shape, col, grid, 4, "linear", "float32")
    strict = bk.tiling(grid if not coarse.transposed else bp_rows.transposed_grid(grid), bk.min_range(a, grid),
                       np.max(np.abs(coarse.geo[BpGeo.KC])), np.max(np.abs(coarse.geo[BpGeo.INV_BIN])),
                       c_max=coarse.orientation.c_max)
    assert coarse.tiling.cost < strict.cost and coarse.tiling.error <= tol
    img = backproject(data, col, grid, lin)
    monkeypatch.setattr(bp_rows, "tiling", lambda *args, **kw: strict)
    assert Setup(data.shape, col, grid, 4, "linear", "float32").tiling == strict
    forced = backproject(data, col, grid, lin)
    assert 0 < np.max(np.abs(img - forced)) * data.shape[1] <= tol + 1.5e-6


def test_row_cosine_is_the_largest_cosine_along_the_rows():
    """row_cosine against a dense sampling of the grid's rectangle, for antennas looking along x and y."""
    from sarcli.formers.backprojection._kernels import row_cosine

    grid = Grid(40, 30, 0.5, 0.5, 3.0, -2.0)
    xs, ys = np.meshgrid(np.linspace(grid.x[0] - 0.25, grid.x[-1] + 0.25, 81),
                         np.linspace(grid.y[0] - 0.25, grid.y[-1] + 0.25, 61))
    for pos in ([[800.0, 20.0, 300.0]], [[10.0, -900.0, 500.0]], [[5.0, 2.0, 40.0]]):
        p = np.asarray(pos)
        d = np.stack([xs - p[0, 0], ys - p[0, 1], -p[0, 2] + 0 * xs])
        dense = np.max(np.abs(d[0]) / np.linalg.norm(d, axis=0))
        got = row_cosine(p, grid)
        assert dense <= got + 1e-12 and got <= 1.0
        assert got <= 1.5 * dense + 1e-3   # a bound, not far above the truth


def test_tiling_keeps_wide_tiles_near_the_radar():
    """The quadratic's tiles narrow to 2 pixels at 200 m; the series model keeps 96 within the same
    tolerance, and far away (1,000 km) the cheaper quadratic keeps the widest, 128, itself."""
    from sarcli.formers.backprojection._kernels import MODEL_TOLERANCE, QUADRATIC, SERIES, tiling

    grid = Grid(512, 512, 0.25, 0.25)
    kc, ib = 4 * np.pi * 10e9 / geometry.C, 1.0 / 0.01
    assert tile_width(grid, 150.0, kc, ib) <= 4
    near = tiling(grid, 150.0, kc, ib)
    assert (near.model, near.width) == (SERIES, 96) and near.error <= MODEL_TOLERANCE
    assert tiling(grid, 50.0, kc, ib).width >= 32
    far = tiling(grid, 1e6, kc, ib)
    assert (far.model, far.width) == (QUADRATIC, 128) and far.cost < near.cost
    # a tile may not reach past half the range (where the series converges too slowly)
    assert tiling(Grid(64, 64, 1.0, 1.0), 20.0, kc, ib).width <= 21


@pytest.mark.parametrize("r0", [50.0, 200.0, 1e3, 1e4, 1e6])
def test_default_error_at_every_range_within_prediction(monkeypatch, r0):
    """The image's error against the exact matched filter from 50 m to 1,000 km, at form_image's
    defaults (float32, cubic Lagrange, upsample 12), below Keys cubic's at 16: the tiling's range
    model departs from the range evaluated in float64 at every pixel (one-pixel tiles) by at most
    its predicted error, and the whole error stays within the planner's margin (SAFETY) of the
    error it predicts (interpolation + unequal spacing + the tiling's model error)."""
    import sarcli.formers.backprojection._kernels as bk
    from sarcli.formers.backprojection._setup import tiling_for
    from sarcli.formers.backprojection import DEFAULT_PRECISION
    from sarcli.formers.ffbp.model import frequency_error, interp_error
    from sarcli.formers.planning.planner import SAFETY

    dx = min(0.25, r0 / 200)
    grid = Grid(64, 64, dx, dx)
    half = 28 * dx
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(-half, half, 5), rng.uniform(-half, half, 5), np.zeros(5)])
    data, freq, a, rr = collection(pts, rng.normal(size=5) + 1j * rng.normal(size=5), P=48, M=64, r0=r0,
                                   bw=geometry.C / (4 * 1.1 * grid.half_diagonal * np.cos(np.radians(30))) * 63,
                                   aperture_deg=3.0 if r0 > 1e3 else 20.0)
    ref = exact_mf(data, freq, a, rr, grid)
    img = backproject(data, Collection(freq, a, rr), grid, BackprojectionOptions(precision=DEFAULT_PRECISION))
    t = tiling_for(freq, a, None, grid, DEFAULT_UPSAMPLE)
    predicted = interp_error(DEFAULT_INTERP, float(DEFAULT_UPSAMPLE)) + frequency_error(freq, a, grid) + t.error
    # measured 2.6e-5 (1,000 km) to 3.1e-5 (200 m) against 2.6e-5 to 3.3e-5 predicted: the
    # interpolation's RMS model, the same with one-pixel tiles
    assert rel_err(img, ref) <= SAFETY * predicted, (t, rel_err(img, ref), predicted)
    # Keys at 16 (the same cost a pixel): measured 2.9e-5 to 4.0e-5, 1.1 to 1.3 times the default's
    keys = backproject(data, Collection(freq, a, rr), grid, BackprojectionOptions(interp="cubic", upsample=16))
    assert rel_err(img, ref) < rel_err(keys, ref)
    _forced_tiling(monkeypatch, bk.QUADRATIC, 1)
    pixelwise = backproject(data, Collection(freq, a, rr), grid, BackprojectionOptions(precision=DEFAULT_PRECISION))
    assert rel_err(img, pixelwise) <= t.error + 3e-6     # measured 6e-7 to 1.2e-6 (float32 roundings)


@pytest.mark.parametrize("level", ["0", "1"])
def test_series_model_every_instruction_set_and_adjoint(monkeypatch, level):
    """At 40 m (the series model; bistatic too): the AVX2 and baseline copies give
    AVX-512's image, and reproject stays backproject's exact adjoint."""
    from sarcli.formers.backprojection._setup import tiling_for

    rng = np.random.default_rng(11)
    data, freq, a, r0 = collection([[1.0, -2.0, 0.0]], [1.0], P=24, M=32, r0=40.0, aperture_deg=30.0)
    grid = Grid(96, 40, 0.1, 0.15)
    assert tiling_for(freq, a, None, grid, 4).model == "series"
    rcv = a + np.array([0.0, 1.5, 0.2])
    d = rng.normal(size=data.shape) + 1j * rng.normal(size=data.shape)
    f = rng.normal(size=grid.shape) + 1j * rng.normal(size=grid.shape)
    opts = BackprojectionOptions(upsample=4, interp="cubic", precision="float64")
    for q in (None, rcv):
        col = Collection(freq, a, r0, receive_position_m=q)
        best = backproject(d, col, grid, opts)
        monkeypatch.setenv("SARCLI_BP_ISA", level)
        img = backproject(d, col, grid, opts)
        assert rel_err(img, best) < 4e-6    # measured: AVX2 bit for bit; baseline ~1e-7
        lhs = np.vdot(f, img)
        rhs = np.vdot(reproject(f, col, grid, opts), d)
        assert abs(lhs - rhs) / abs(lhs) < 1e-14
        monkeypatch.delenv("SARCLI_BP_ISA")
