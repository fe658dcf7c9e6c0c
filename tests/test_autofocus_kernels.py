"""The pieces min-entropy autofocus runs on: the fused stack pass and the L-BFGS driver."""

from __future__ import annotations

import numpy as np
import pytest

from sarcli.autofocus._imager import BlockImager, entropy_of
from sarcli.autofocus._lbfgs import lbfgs
from sarcli.core.collection import Collection
from sarcli.formers.options import BackprojectionOptions


def _stack_imager(order, nb=7, pixels=(3600, 33), seed=0):
    """A BlockImager over a random stack in two parts (the first spans two pixel tiles of the pass)."""
    from sarcli.core.grid import Grid

    rng = np.random.default_rng(seed)
    parts = [(rng.normal(size=(nb, n)) + 1j * rng.normal(size=(nb, n))).astype(np.complex64) for n in pixels]
    parts[0][:, :5] = 0  # pixels with no energy
    bounds = np.array([0, 3, 5, 9, 10, 14, 15, 19][:nb + 1])
    return BlockImager(None, Grid(4, 4, 1.0, 1.0), 0, 1, order=order, _parts=parts, _bounds=bounds)


def _reference(im, phi):
    """Entropy and per-pulse gradient from the image and entropy_of's weights (numpy)."""
    e = np.exp(-1j * im._theta(phi))
    f = np.concatenate([e.astype(np.complex128) @ p for p in im.parts])
    h, _, w = entropy_of(f, im.order)
    g = w * np.conj(f)
    v, k = 0.0, 0
    for p in im.parts:
        v = v + p.astype(np.complex128) @ g[k:k + p.shape[1]]
        k += p.shape[1]
    return h, np.repeat(2.0 * np.imag(e * v) / im._sizes, np.diff(im.bounds))


@pytest.mark.parametrize("order", [1.0, 0.5, 2.0])
def test_fused_stack_pass_matches_the_image_and_its_weights(order):
    im = _stack_imager(order)
    phi = np.random.default_rng(1).normal(0, 1.0, im.bounds[-1])
    h_ref, g_ref = _reference(im, phi)
    h, g = im.entropy_and_gradient(phi)
    assert abs(h - h_ref) < 1e-5 * abs(h_ref)
    assert abs(im.entropy(phi) - h) < 1e-12
    assert np.max(np.abs(g - g_ref)) < 1e-4 * np.max(np.abs(g_ref))


def test_fused_stack_pass_of_an_empty_image():
    im = _stack_imager(1.0)
    im.parts = [np.zeros_like(p) for p in im.parts]
    h, g = im.entropy_and_gradient(np.zeros(im.bounds[-1]))
    assert h == 0.0 and not np.any(g)


class _Stop(Exception):
    pass


def _recorded(driver, n, seed, max_iter, max_fun):
    rng = np.random.default_rng(seed)
    A, b = rng.normal(size=(n, n)), rng.normal(size=n)
    xs = []

    def f(c):
        if len(xs) >= max_fun:
            raise _Stop
        xs.append(np.array(c))
        z = A @ c - b
        return np.sum(np.log1p(z ** 2)) + 0.1 * np.sum(c ** 4), A.T @ (2 * z / (1 + z ** 2)) + 0.4 * c ** 3

    try:
        driver(f, n, max_iter, max_fun)
    except _Stop:
        pass
    return xs


@pytest.mark.parametrize("n, max_iter, max_fun", [(3, 15, 30), (40, 3, 6), (40, 30, 60), (95, 15, 15)])
def test_lbfgs_evaluates_the_points_scipy_minimize_does(n, max_iter, max_fun):
    from scipy.optimize import minimize

    def scipy_driver(f, n, mi, mf):
        minimize(f, np.zeros(n), jac=True, method="L-BFGS-B",
                 options={"maxiter": mi, "maxfun": mf, "ftol": 1e-12, "gtol": 1e-12})

    def ours(f, n, mi, mf):
        lbfgs(f, np.zeros(n), max_iter=mi, max_fun=mf, ftol=1e-12, gtol=1e-12)

    for seed in range(2):
        a, b = _recorded(scipy_driver, n, seed, max_iter, max_fun), _recorded(ours, n, seed, max_iter, max_fun)
        assert len(a) == len(b) and all(np.array_equal(u, v) for u, v in zip(a, b))


def _circle_case(P, M, seed):
    """Random data of P pulses over 3° of a 10 km circle at 30° elevation, M frequencies from
    9.8 GHz in 5 MHz steps; with the generator, for what a test draws next."""
    from sarcli.core import geometry

    rng = np.random.default_rng(seed)
    freq = 9.8e9 + 5e6 * np.arange(M)
    az = np.radians(np.linspace(-1.5, 1.5, P))
    a = geometry.antenna_positions_circle(az, np.radians(30), 10e3)
    r0 = np.linalg.norm(a, axis=1)
    d = rng.normal(size=(P, M)) + 1j * rng.normal(size=(P, M))
    return rng, d, freq, a, r0


@pytest.mark.parametrize("opts", [BackprojectionOptions(upsample=4, interp="linear", precision="float32"),
                                  BackprojectionOptions(upsample=8, interp="cubic", precision="float64"),
                                  BackprojectionOptions(upsample=6, interp="lagrange", precision="float64")])
def test_pulse_contractions_are_the_reprojection_formula(opts):
    from sarcli.core.grid import Grid
    from sarcli.formers.backprojection import backproject, pulse_contractions, reproject

    rng, d, freq, a, r0 = _circle_case(37, 48, 3)
    grid = Grid(45, 38, 0.25, 0.25)
    col = Collection(freq, a, r0)
    g = rng.normal(size=grid.shape) * np.conj(backproject(d, col, grid, opts))
    ref = np.sum(np.conj(reproject(np.conj(g), col, grid, opts)) * d, axis=1)
    tol = 1e-5 if opts.precision == "float32" else 1e-12
    v1 = pulse_contractions(d, g, col, grid, opts, nthreads=1)
    assert np.max(np.abs(v1 - ref)) < tol * np.max(np.abs(ref))
    assert np.array_equal(v1, pulse_contractions(d, g, col, grid, opts, nthreads=2))


def test_group_images_add_up_to_the_backprojection():
    from sarcli.core.grid import Grid
    from sarcli.errors import SarcliInputError
    from sarcli.formers.backprojection._prepared import Backprojector
    from sarcli.formers.backprojection import backproject

    _, d, freq, a, r0 = _circle_case(23, 32, 4)
    grid = Grid(30, 26, 0.25, 0.25)
    bounds = [0, 5, 6, 15, 23]
    bp = Backprojector(d, Collection(freq, a, r0), grid)
    imgs = [re + 1j * im for _, re, im in bp.group_images(bounds)]
    assert len(imgs) == 4
    one = backproject(d[6:15], Collection(freq, a[6:15], r0[6:15]), grid) * (9 / 23)
    assert np.max(np.abs(imgs[2] - one)) < 1e-12 * np.max(np.abs(one))
    full = backproject(d, Collection(freq, a, r0), grid)
    assert np.max(np.abs(sum(imgs) - full)) < 1e-12 * np.max(np.abs(full))
    with pytest.raises(SarcliInputError):
        next(bp.group_images([0, 5, 5, 23]))


def test_scipy_still_ships_the_lbfgsb_routine_the_driver_was_written_for():
    """The pin on scipy's private ``scipy.optimize._lbfgsb.setulb``. ``sarcli.autofocus._lbfgs``
    drives it without importing ``scipy.optimize`` (whose import costs about 0.3 s of CPU time and
    44 MiB per ``sar autofocus`` run on GOTCHA); on a scipy that moved or changed it the driver
    falls back to ``scipy.optimize.minimize`` (the same points, so the same estimates) and this
    test fails, so that the change is seen rather than paid silently."""
    import scipy

    from sarcli.autofocus._lbfgs import _works, find_setulb

    setulb = find_setulb()
    assert setulb is not None, (
        f"scipy {scipy.__version__} has no loadable scipy.optimize._lbfgsb.setulb: sarcli's L-BFGS "
        "driver (sarcli/autofocus/_lbfgs.py) runs scipy.optimize.minimize instead; port _drive to the "
        "new routine or make minimize the only route")
    assert _works(setulb), (
        f"scipy {scipy.__version__}'s scipy.optimize._lbfgsb.setulb takes other arguments than the "
        "scipy 1.17 routine sarcli/autofocus/_lbfgs.py drives: port _drive to it")


def test_lbfgs_driver_refuses_a_routine_of_another_interface():
    from sarcli.autofocus._lbfgs import _works

    def wrong_arguments(*args):
        raise TypeError("setulb() takes 18 arguments")

    assert not _works(wrong_arguments)
    assert not _works(lambda *args: None)  # asks for nothing: never reaches the minimum


def test_level_search_ends_when_an_iteration_gains_little():
    """minimize stops once an iteration lowers the value by less than LEVEL_FTOL of it, well
    before its budget on a quadratic bowl, and returns the best point it evaluated."""
    from sarcli.autofocus._lbfgs import minimize

    rng = np.random.default_rng(3)
    A = rng.normal(size=(20, 20))
    H, b = A @ A.T + 20 * np.eye(20), rng.normal(size=20)
    calls = []

    def value(c):
        return float(0.5 * c @ H @ c - b @ c + 10.0)

    def fun(c):
        calls.append(c.copy())
        return value(c), H @ c - b

    x = minimize(fun, 20, max_iter=200, max_fun=400)
    assert len(calls) < 50
    np.testing.assert_array_equal(x, min(calls, key=value))
    # the value left above the minimum is of the order of the stopping tolerance
    assert value(x) - value(np.linalg.solve(H, b)) < 1e-4


@pytest.mark.parametrize("opts", [BackprojectionOptions(upsample=4, interp="linear", precision="float32"),
                                  BackprojectionOptions(upsample=8, interp="cubic", precision="float64")])
def test_prepared_backprojector_is_backproject_and_pulse_contractions(opts):
    from sarcli.core.grid import Grid
    from sarcli.errors import SarcliInputError
    from sarcli.formers.backprojection._prepared import Backprojector
    from sarcli.formers.backprojection import backproject, pulse_contractions

    rng, d, freq, a, r0 = _circle_case(150, 40, 5)   # more pulses than one profile block
    w = np.hanning(42)[1:-1]
    grid, other = Grid(45, 38, 0.25, 0.25), Grid(20, 30, 0.5, 0.25, 1.0, -2.0)
    phi = rng.uniform(-np.pi, np.pi, 150)
    tol = 2e-6 if opts.precision == "float32" else 1e-12
    col = Collection(freq, a, r0, w)
    bp = Backprojector(d, col, grid, opts)
    for g, b in ((grid, bp), (other, bp.on(other))):
        assert b.grid == g
        ref = backproject(d * np.exp(-1j * phi)[:, None], col, g, opts)
        assert np.max(np.abs(b.image(phi) - ref)) < tol * np.max(np.abs(ref))
        ref0 = backproject(d, col, g, opts)
        assert np.max(np.abs(b.image() - ref0)) < tol * np.max(np.abs(ref0))
        h = rng.normal(size=g.shape) * np.conj(ref)
        v = pulse_contractions(d, h, col, g, opts)
        assert np.max(np.abs(b.contract(h) - v)) < tol * np.max(np.abs(v))
    assert bp.on(other).profiles is bp.profiles
    bounds = [0, 7, 8, 100, 150]
    groups = [(b, re.copy(), im.copy()) for b, re, im in bp.group_images(bounds)]
    # each its share of the whole; a call on a few of the pulses picks its own orientation and range
    # model (the transposing copy is shared by fewer pulses), which agree within the models' tolerance
    from sarcli.formers.backprojection._kernels import MODEL_TOLERANCE
    gtol = max(tol, MODEL_TOLERANCE)
    for (b, re, im), lo, hi in zip(groups, bounds[:-1], bounds[1:]):
        ref = backproject(d[lo:hi], col.pulses(slice(lo, hi)), grid, opts) * ((hi - lo) / 150)
        assert np.max(np.abs(re + 1j * im - ref)) < gtol * np.max(np.abs(ref))
    assert [b for b, _, _ in groups] == [0, 1, 2, 3]
    assert len(groups) == 4
    with pytest.raises(SarcliInputError):
        next(bp.group_images([0, 7, 149]))
    with pytest.raises(SarcliInputError):
        bp.image(phi[:-1])
    with pytest.raises(SarcliInputError):
        bp.contract(np.ones(other.shape))


@pytest.mark.parametrize("spacing", ["on its line", "rounded", "jittered"])
def test_point_signals_are_the_matched_filter_sum(spacing):
    """Each pulse's matched filter at points, compiled (Horner's scheme about the frequency line,
    its deviations by their series, or sample by sample beyond the series' bound) against the sum
    with one exponential per sample."""
    from sarcli._native import load

    rng = np.random.default_rng(3)
    P, M, K = 5, 97, 37
    freq = 9.6e9 + 1.5e6 * np.arange(M) + np.zeros((P, 1)) + 1e6 * np.arange(P)[:, None]
    if spacing == "rounded":    # float32 frequencies, as GOTCHA's: deviations of a few hundred Hz
        freq = freq.astype(np.float32).astype(np.float64)
    elif spacing == "jittered":  # far from any line: the series does not hold
        freq = freq + rng.uniform(-2e5, 2e5, freq.shape)
    kw = 4 * np.pi * freq / 299792458.0
    d = rng.normal(size=(P, M)) + 1j * rng.normal(size=(P, M))
    dr = rng.uniform(-80, 80, (P, K))
    z = np.empty((P, K), complex)
    load("autofocus").point_signals(d, kw, dr, z)
    ref = np.einsum("pj,pjk->pk", d, np.exp(1j * kw[:, :, None] * dr[:, None, :])) / M
    assert np.abs(z - ref).max() <= 1e-10 * np.abs(ref).max()


def test_pulse_signals_of_a_spherical_collection_are_its_phases_summed():
    """``pulse_signals`` on spherical data (the compiled path) against the sum over ``_phases``."""
    from sarcli.autofocus._common import _phases, pulse_signals
    from sarcli.core.acquisition import Acquisition
    from sarcli.core.geometry import antenna_positions_circle
    from sarcli.core.grid import Grid
    from sarcli.core.types import PhaseHistory

    rng = np.random.default_rng(4)
    P, M = 24, 64
    az = np.radians(np.linspace(-2, 2, P))
    a = antenna_positions_circle(az, np.radians(30), 5e3)
    freq = (9.6e9 + 4e6 * np.arange(M)).astype(np.float32).astype(np.float64)
    acq = Acquisition(freq, az, np.full(P, np.radians(30)), Grid(32, 32, 0.5, 0.5), antenna_position_m=a,
                      range_to_center_m=np.linalg.norm(a, axis=1), model="spherical")
    ph = PhaseHistory(rng.normal(size=(P, M)) + 1j * rng.normal(size=(P, M)), acq)
    pts = rng.uniform(-8, 8, (9, 2))
    ref = np.einsum("pj,pjk->pk", ph.data, np.exp(1j * _phases(acq, np.column_stack([pts, np.zeros(9)])))) / M
    z = pulse_signals(ph, pts)
    assert np.abs(z - ref).max() <= 1e-10 * np.abs(ref).max()
