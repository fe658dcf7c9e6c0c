"""Contract tests of every Linop (adjoint, linearity, shapes) and the NUFFT/Toeplitz agreement."""

from __future__ import annotations

import numpy as np
import pytest

from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.core.grid import Grid
from sarcli.linops import (Diagonal, FiniteDifference, Identity, MatrixLinop, NufftOperator,
                           SphericalOperator, SubsampledDFT, gram_eigmax, phase_operator,
                           power_norm, sparsifying_operator)
from sarcli.core.collection import Collection

RNG = np.random.default_rng(20261122)


def _crandn(shape):
    return RNG.standard_normal(shape) + 1j * RNG.standard_normal(shape)


def _kspace(P=9, M=11, fc=10e9, bw=600e6, ext_deg=3.0):
    freq = np.linspace(fc - bw / 2, fc + bw / 2, M)
    az = np.deg2rad(50 + np.linspace(-ext_deg / 2, ext_deg / 2, P))
    return freq, az, np.full(P, np.deg2rad(30.0))


GRID = Grid(12, 10, 0.05, 0.04, 0.3, -0.2)  # non-square, offset centre


def _operators():
    freq, az, el = _kspace()
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    nufft = NufftOperator(kx, ky, GRID, eps=1e-13)
    a = geometry.antenna_positions_circle(az, el, 10_000.0)
    return {
        "nufft": nufft,
        "toeplitz_gram": nufft.toeplitz_gram(),
        "nufft_gram": nufft.gram(),
        "spherical": SphericalOperator(Collection(freq, a, np.linalg.norm(a, axis=1)), GRID),
        "fd1": FiniteDifference(GRID.shape, 1),
        "fd2": FiniteDifference(GRID.shape, 2),
        "fd3": FiniteDifference(GRID.shape, 3),
        "fd1_1d": FiniteDifference((17,), 1),
        "identity": Identity(GRID.shape),
        "theta": phase_operator(_crandn(GRID.shape)),
        "ptv": sparsifying_operator("ptv", GRID.shape, order=2, f0=_crandn(GRID.shape)),
        "ptv1": sparsifying_operator("ptv", GRID.shape, order=1, f0=_crandn(GRID.shape)),
        "matrix": MatrixLinop(_crandn((7, 12)), ishape=(3, 4)),
        "partial_dft": SubsampledDFT(RNG.random((8, 6)) < 0.5),
        "composite": 2.0 * FiniteDifference(GRID.shape, 1) @ Diagonal(_crandn(GRID.shape))
        - (1 - 0.5j) * FiniteDifference(GRID.shape, 2),
    }


OPS = _operators()


@pytest.mark.parametrize("name", sorted(OPS))
def test_adjoint_dot_product(name):
    op = OPS[name]
    x, y = _crandn(op.ishape), _crandn(op.oshape)
    lhs = np.vdot(y, op.forward(x))
    rhs = np.vdot(op.adjoint(y), x)
    assert abs(lhs - rhs) / abs(lhs) < 1e-10
    # the adjoint operator's adjoint is the operator
    assert np.allclose(op.H.H.forward(x), op.forward(x), rtol=0, atol=1e-12 * np.abs(lhs))


@pytest.mark.parametrize("name", sorted(OPS))
def test_linearity_and_shapes(name):
    op = OPS[name]
    x1, x2 = _crandn(op.ishape), _crandn(op.ishape)
    a, b = 0.7 - 1.3j, -2.1 + 0.4j
    y = op.forward(a * x1 + b * x2)
    assert y.shape == op.oshape
    assert op.adjoint(_crandn(op.oshape)).shape == op.ishape
    ref = a * op.forward(x1) + b * op.forward(x2)
    assert np.linalg.norm(y - ref) / np.linalg.norm(ref) < 1e-10
    with pytest.raises(ValueError):
        op.forward(np.zeros(op.ishape + (2,)))


def test_nufft_matches_direct_pixel_model():
    """A f equals the far-field sum over pixel centres (grid offset included), eq. 2D-DFT."""
    freq, az, el = _kspace(P=5, M=6)
    op = NufftOperator.from_acquisition(Acquisition(freq, az, el, GRID), eps=1e-13)
    f = _crandn(GRID.shape)
    psi = geometry.signal_phase(freq, az, el, GRID.points().reshape(-1, 3))
    direct = np.exp(-1j * psi) @ f.reshape(-1)
    assert np.linalg.norm(op.forward(f) - direct) / np.linalg.norm(direct) < 1e-11


def test_nufft_adjoint_over_pm_is_matched_filter_peak_one():
    freq, az, el = _kspace()
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    op = NufftOperator(kx, ky, GRID, eps=1e-12)
    row, col = 3, 7
    e = np.zeros(GRID.shape, complex)
    e[row, col] = 1.0
    mf = op.adjoint(op.forward(e)) / kx.size
    assert abs(mf[row, col] - 1.0) < 1e-10
    assert np.unravel_index(np.argmax(np.abs(mf)), mf.shape) == (row, col)


@pytest.mark.parametrize("shape", [(16, 16), (12, 20)])
def test_toeplitz_gram_matches_nufft_pair(shape):
    """AᴴA by the 2N×2N Toeplitz embedding equals Aᴴ(A f) by the NUFFT pair (eps 1e-9) to 1e-9."""
    freq, az, el = _kspace(P=40, M=48, ext_deg=6.0)
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    grid = Grid(shape[1], shape[0], 0.07, 0.05, -0.4, 0.25)
    op = NufftOperator(kx, ky, grid, eps=1e-9)
    for _ in range(3):
        f = _crandn(shape)
        ref = op.adjoint(op.forward(f))
        assert np.linalg.norm(op.toeplitz_gram().forward(f) - ref) / np.linalg.norm(ref) < 1e-9   # measured 9e-11


def test_toeplitz_gram_from_several_threads():
    """The kept work arrays serve one caller at a time; concurrent callers get their own and the
    same answers as one after another."""
    from concurrent.futures import ThreadPoolExecutor

    freq, az, el = _kspace(P=40, M=48, ext_deg=6.0)
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    gram = NufftOperator(kx, ky, Grid.square(2.0, 64), eps=1e-9).toeplitz_gram()
    fs = [_crandn((64, 64)) for _ in range(8)]
    ref = [gram.forward(f) for f in fs]
    with ThreadPoolExecutor(4) as pool:
        for _ in range(3):
            got = list(pool.map(gram.forward, fs))
            assert all(np.array_equal(a, b) for a, b in zip(got, ref))


@pytest.mark.parametrize("fft_dtype", [np.complex128, np.complex64])
def test_toeplitz_gram_blocks_and_folded_scale(fft_dtype):
    """The x-pass in uneven blocks of rows equals one block, and ``c·AᴴA`` equals ``c`` times it."""
    freq, az, el = _kspace(P=40, M=48, ext_deg=6.0)
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    gram = NufftOperator(kx, ky, GRID, eps=1e-9).toeplitz_gram(fft_dtype=fft_dtype)
    assert gram._block >= 2 * GRID.shape[0]  # a small grid is one block
    f = _crandn(GRID.shape)
    one = gram.forward(f)
    gram._block = 3  # 2·ny = 20 rows: blocks of 3 and a last one of 2
    tol = 1e-14 if fft_dtype == np.complex128 else 1e-6
    assert np.linalg.norm(gram.forward(f) - one) / np.linalg.norm(one) < tol
    c = 0.37
    scaled = (c * gram).forward(f)
    assert scaled.dtype == np.complex128
    assert np.linalg.norm(scaled - c * gram.forward(f)) / np.linalg.norm(one) < 1e-15
    assert np.linalg.norm((c * gram).adjoint(f) - scaled) / np.linalg.norm(one) < 1e-15


def test_finite_difference_values_and_norm():
    x = np.arange(6.0) ** 2  # 0 1 4 9 16 25
    d1 = FiniteDifference((6,), 1).forward(x)[0].real
    d2 = FiniteDifference((6,), 2).forward(x)[0].real
    assert np.allclose(d1[:5], [1, 3, 5, 7, 9]) and d1[5] == -25  # periodic wrap
    assert np.allclose(d2[:4], 0.5 * 2.0)  # second difference 2, scaled by 2^(1-2)
    for k in (1, 2, 3):  # ‖Dᵏ‖ = 2 per axis: 2-D stack has ‖·‖² = 8
        lam = gram_eigmax(FiniteDifference((16, 16), k).gram(), iters=200)
        assert abs(lam - 8.0) < 1e-3


def test_fused_phase_corrected_difference_equals_the_composition():
    """D Θ in one compiled pass (first differences, 2-D) equals D applied to Θ f, and back."""
    f0 = _crandn(GRID.shape)
    fused = sparsifying_operator("ptv", GRID.shape, f0=f0)
    assert fused._fused
    D, theta = FiniteDifference(GRID.shape, 1), phase_operator(f0)
    x, y = _crandn(GRID.shape), _crandn((2,) + GRID.shape)
    assert np.max(np.abs(fused.forward(x) - D.forward(theta.forward(x)))) < 1e-14
    assert np.max(np.abs(fused.adjoint(y) - theta.adjoint(D.adjoint(y)))) < 1e-14
    assert np.max(np.abs(fused.forward(x.real) - D.forward(theta.forward(x.real)))) < 1e-14


def test_staggered_empty():
    """Large work arrays start at different offsets within a page; all are C-contiguous."""
    from sarcli.linops._reduce import empty

    arrays = [empty((2, 128, 160)) for _ in range(6)]
    assert all(a.flags.c_contiguous and a.dtype == np.complex128 and a.shape == (2, 128, 160)
               for a in arrays)
    assert len({a.ctypes.data % 4096 for a in arrays}) == 6
    assert empty((3, 4)).shape == (3, 4)


def test_phase_operator_makes_f0_real_positive():
    f0 = _crandn((5, 4))
    theta = phase_operator(f0)
    assert np.allclose(theta.forward(f0), np.abs(f0), atol=1e-14)


def test_power_norm_of_unitary_subsampled_dft_is_one():
    assert abs(power_norm(SubsampledDFT(RNG.random((8, 8)) < 0.5)) - 1.0) < 1e-12


def test_single_precision_toeplitz_at_loose_eps():
    """At eps ≥ 1e-6 the Toeplitz FFTs run in complex64 and still agree with the pair to 1e-5."""
    freq, az, el = _kspace(P=40, M=48, ext_deg=6.0)
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    op = NufftOperator(kx, ky, GRID, eps=1e-6)
    gram = op.toeplitz_gram()
    assert gram.fft_dtype == np.complex64
    f = _crandn(GRID.shape)
    ref = NufftOperator(kx, ky, GRID, eps=1e-12).gram().forward(f)
    out = gram.forward(f)
    assert out.dtype == np.complex128
    assert np.linalg.norm(out - ref) / np.linalg.norm(ref) < 1e-6   # measured 1.4e-7


def test_spherical_operator_draws_no_bar_of_its_own(monkeypatch):
    # an operator applied inside an iteration with its own bar must not start a backprojection bar
    import sarcli.formers.backprojection._maps as bp
    from sarcli._util.progress import is_quiet

    seen = []
    real = bp.progress

    def spy(*args, **kwargs):
        seen.append(is_quiet())
        return real(*args, **kwargs)

    monkeypatch.setattr(bp, "progress", spy)
    op = _operators()["spherical"]
    y = op.forward(_crandn(GRID.shape))
    op.adjoint(y)
    assert seen and all(seen)
    assert not is_quiet()  # restored afterwards
    seen.clear()
    bp.backproject(y, op.collection, GRID)
    assert seen == [False]  # a former called on its own keeps its bar


def test_toeplitz_gram_gives_the_same_bits_on_one_thread_and_two():
    """With two kernel threads the x-pass's blocks of rows are shared out (each block's transforms
    on one thread): the product is the one-thread product, bit for bit, in both precisions."""
    from sarcli._native import using_threads
    from sarcli.linops.toeplitz import ToeplitzGram

    rng = np.random.default_rng(1)
    k1, k2 = rng.uniform(-3, 3, (2, 3000))
    x = rng.standard_normal((300, 260)) + 1j * rng.standard_normal((300, 260))
    for eps in (1e-4, 1e-9):
        gram = ToeplitzGram(k1, k2, (300, 260), eps=eps)
        with using_threads(1):
            one = gram.apply(x)
        with using_threads(2):
            two = gram.apply(x)
        assert np.array_equal(one, two)
        assert np.linalg.norm(one) > 0


def test_spherical_operator_refuses_window_weights():
    """A = W · reproject holds for the unweighted model only; a weighted collection is refused."""
    op = _operators()["spherical"]
    col = op.collection
    with pytest.raises(ValueError, match="without weights"):
        SphericalOperator(col.with_(weights=np.ones(col.n_frequencies)), GRID)
