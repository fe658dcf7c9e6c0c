"""Backprojection's tiles on their own: each range model and the carrier against exact ranges,
the adjoint at tile widths that fill every SIMD lane, and a wide-baseline bistatic pair against
the exact matched filter (``direct``).

The range model is read out of the compiled kernel (``bp_tiles``) with one pulse and two
profiles whose interpolation is exact: a constant (every kernel's weights sum to one) gives
``exp(i kc Δr_model)`` at each pixel, and a linear ramp through the linear kernel with no carrier
gives ``Δr_model / bin``. Both are compared with ``geometry.bistatic_differential_range``; the
bound the tiling is chosen by (``backprojection._kernels.quadratic_error`` / ``series_error`` at the nearest
range) must hold at any tile width, for a monostatic pair and for transmitter and receiver 25°
apart at different ranges (each path's curvature its own). Every test runs on each instruction
set this CPU has (``$SARCLI_BP_ISA`` caps the kernels' level: 2 AVX-512, 1 AVX2, 0 baseline).
"""

from __future__ import annotations

import numpy as np
import pytest

from sarcli._native.layout import BpGeo as G
from sarcli.core import geometry
from sarcli.core.grid import Grid
import sarcli.formers.backprojection._rows as _bp_rows
from sarcli.formers.backprojection._kernels import (SERIES, GEO_ROWS, MODEL_TOLERANCE, QUADRATIC, Tiling, series_error, kernels,
                                        min_range, quadratic_error, tiling)
from sarcli.formers.backprojection._setup import PAD
from sarcli.formers.backprojection import backproject, reproject
from sarcli.formers.direct import direct_spherical
from sarcli.core.collection import Collection
from sarcli.formers.options import BackprojectionOptions

GRID = Grid.square(10.0, 80)  # 20 m x 20 m, 0.25 m pixels
KC = 4 * np.pi * 10e9 / geometry.C  # carrier wavenumber at 10 GHz (rad/m)
INV_BIN = 1.0  # profile bins per metre
N_LEN = 256  # profile length (the ramp's values stay small: float32 weights keep them exact)
#: float32 floor of the read-out: the carrier polynomial (3.9e-7 rad against libm) and the
#: linear weights' rounding of a ramp of at most ~30 bins
PHASE_FLOOR, BIN_FLOOR = 1e-6, 2e-6

LEVELS = [str(v) for v in range(kernels().isa_level() + 1)]


@pytest.fixture(params=LEVELS, ids=lambda v: f"isa{v}")
def isa(request, monkeypatch):
    monkeypatch.setenv("SARCLI_BP_ISA", request.param)
    return int(request.param)


def pair(r_t, r_r, sep_deg, *, az_deg=(-10.0, 0.0, 10.0), el_t=45.0, el_r=35.0):
    """Transmit and receive positions on circles about the scene centre, the receiver ``sep_deg``
    further in azimuth (the same positions when ``sep_deg`` is 0 and the ranges are equal: a
    monostatic collection); ``r0`` is half the two-way path to the centre."""
    az = np.radians(np.asarray(az_deg, float))
    t = geometry.antenna_positions_circle(az, np.radians(el_t), r_t)
    q = t if (sep_deg == 0.0 and r_t == r_r) else \
        geometry.antenna_positions_circle(az + np.radians(sep_deg), np.radians(el_r), r_r)
    return t, q, 0.5 * (np.linalg.norm(t, axis=1) + np.linalg.norm(q, axis=1))


def model_read_out(t, q, grid, model, width):
    """Per pulse, the kernel's carrier phase ``kc Δr_model`` (wrapped) and position ``Δr_model/bin``
    at every pixel, for tiles of ``width`` pixels."""
    k = kernels()
    nt, nq = np.linalg.norm(t, axis=1), np.linalg.norm(q, axis=1)
    geo = np.empty((GEO_ROWS, len(t)))
    geo[G.TWO_AX], geo[G.TWO_AY], geo[G.A2], geo[G.NA] = 2 * t[:, 0], 2 * t[:, 1], nt * nt, nt
    geo[G.TWO_BX], geo[G.TWO_BY], geo[G.B2], geo[G.NB] = 2 * q[:, 0], 2 * q[:, 1], nq * nq, nq
    geo[G.OFFSET] = 0.0  # r0 = (|t| + |q|) / 2
    geo[G.INV_BIN] = INV_BIN
    bist = not np.array_equal(t, q)
    lp = N_LEN + 2 * PAD
    x, y = np.ascontiguousarray(grid.x), np.ascontiguousarray(grid.y)
    const = np.zeros((1, lp, 2))
    const[..., 0] = 1.0
    ramp = np.zeros((1, lp, 2))
    ramp[0, :, 0] = np.arange(lp) - PAD - N_LEN // 2  # bin offset from the scene centre's
    phases, bins = [], []
    for p in range(len(t)):
        g = np.array(geo[:, p:p + 1])
        out = []
        for prof, kc, kind in ((const, KC, 1), (ramp, 0.0, 0)):
            g[G.KC] = kc
            re, im = np.zeros(grid.shape), np.zeros(grid.shape)
            k.bp_tiles(prof, x, y, g, N_LEN, PAD, kind, bist, width, model == SERIES, 1, re, im)
            out.append(re + 1j * im)
        phases.append(np.angle(out[0]))
        bins.append(out[1].real)
    return np.array(phases), np.array(bins)


def model_errors(t, q, r0, grid, model, width):
    """Largest carrier-phase (rad) and position (bins) error of the tile model over the pixels."""
    dr = geometry.bistatic_differential_range(t, q, r0, grid.points().reshape(-1, 3)).reshape((len(t),) + grid.shape)
    phase, bins = model_read_out(t, q, grid, model, width)
    assert np.all(np.abs(INV_BIN * dr) < N_LEN / 2 - 8)  # every pixel inside the profile window
    return (float(np.max(np.abs(np.angle(np.exp(1j * (phase - KC * dr)))))),
            float(np.max(np.abs(bins - INV_BIN * dr))))


def bound(model, grid, width, r_min):
    """The range error (m) the tiling is chosen by, for tiles of ``width`` pixels in ``model``."""
    return (quadratic_error if model == QUADRATIC else series_error)(0.5 * (width - 1) * abs(grid.dx), r_min)


NEAR = [(60.0, 60.0, 0.0), (60.0, 45.0, 25.0), (200.0, 100.0, 25.0)]
NEAR_IDS = ["monostatic-60m", "bistatic-60m-45m", "bistatic-200m-100m"]


# measured phase error (rad) of the quadratic at widths 16, 12: monostatic 60 m 4.7e-2, 1.9e-2; 25°
# bistatic 60/45 m 7.9e-2, 3.1e-2; 25° bistatic 200/100 m 1.0e-2, 3.9e-3; 1.3-2.4 times under its bound
@pytest.mark.parametrize("r_t, r_r, sep", NEAR, ids=NEAR_IDS)
@pytest.mark.parametrize("width", [16, 12])
def test_quadratic_model_near_the_radar_within_its_bound(isa, r_t, r_r, sep, width):
    """Quadratic tiles wider than the tiling would pick, tens of metres from a 20 m grid: the model
    (economised cubic term, both one-way paths averaged) errs no more than the bound the tiling is
    chosen by, in phase and in profile bins, and not 3 times less (the bound is sharp)."""
    t, q, r0 = pair(r_t, r_r, sep)
    e = bound(QUADRATIC, GRID, width, min(min_range(t, GRID), min_range(q, GRID)))
    e_phase, e_bin = model_errors(t, q, r0, GRID, QUADRATIC, width)
    assert KC * e / 3 <= e_phase <= KC * e + PHASE_FLOOR, (e_phase, KC * e)
    assert e_bin <= INV_BIN * e + BIN_FLOOR, (e_bin, INV_BIN * e)


# measured (rad), the same on every instruction set to within 1e-7: width 64, 2.3e-6 to 2.5e-6 (60 m),
# 1.3e-5 to 1.4e-5 (60/45 m), 5.7e-7 to 6.4e-7 (200/100 m); width 17, 4.7e-7 to 5.4e-7 (the carrier's
# floor); positions <= 9.6e-7 bins
SERIES_MEASURED = {(60.0, 64): 2.5e-6, (45.0, 64): 1.41e-5, (100.0, 64): 6.4e-7}


@pytest.mark.parametrize("r_t, r_r, sep", NEAR, ids=NEAR_IDS)
@pytest.mark.parametrize("width", [64, 17])
def test_series_model_near_the_radar_within_its_bound(isa, r_t, r_r, sep, width):
    """The series model on 64- and 17-pixel tiles 60-200 m from the radar, mono- and bistatic
    (the bistatic pair's coefficients the mean of its ends'): within its truncation and rounding
    bound (``series_error``) plus the carrier's floor, and within twice the largest error measured
    on any instruction set. At 64 pixels, 35-90 m from the nearest pixel, a wrong coefficient as
    high as ``u⁹``'s would exceed the bound."""
    t, q, r0 = pair(r_t, r_r, sep)
    e = bound(SERIES, GRID, width, min(min_range(t, GRID), min_range(q, GRID)))
    e_phase, e_bin = model_errors(t, q, r0, GRID, SERIES, width)
    assert e_phase <= KC * e + PHASE_FLOOR, (e_phase, KC * e)
    assert e_phase <= 2 * SERIES_MEASURED.get((r_r, width), 5.4e-7)
    assert e_bin <= INV_BIN * e + BIN_FLOOR, (e_bin, INV_BIN * e)


# measured (rad, at the tiling's pick): 60 m series 48: 9.8e-7 to 1.1e-6; 200/100 m series 64: 5.7e-7 to
# 6.4e-7; 100 km quadratic 80 (the row): 2.1e-6; 800/700 km quadratic 80: 3.5e-7 to 3.8e-7; positions
# <= 9.7e-7 bins
@pytest.mark.parametrize("r_t, r_r, sep", [(60.0, 60.0, 0.0), (200.0, 100.0, 25.0), (100e3, 100e3, 0.0),
                                           (800e3, 700e3, 25.0)],
                         ids=["monostatic-60m", "bistatic-200m-100m", "monostatic-100km", "bistatic-800km-700km"])
def test_tiling_the_planner_picks_keeps_the_model_exact(isa, r_t, r_r, sep):
    """At the tiling's pick the model and the carrier leave its predicted error plus the float32
    carrier polynomial's, even where kc Δr reaches 10⁴ rad (100 km, 800 km): the phase is reduced
    in float64 before any float32 step."""
    t, q, r0 = pair(r_t, r_r, sep)
    pick = tiling(GRID, min(min_range(t, GRID), min_range(q, GRID)), KC, INV_BIN)
    assert pick.error <= MODEL_TOLERANCE
    e_phase, e_bin = model_errors(t, q, r0, GRID, pick.model, pick.width)
    assert e_phase <= pick.error + PHASE_FLOOR, (e_phase, pick)
    assert e_bin <= pick.error + BIN_FLOOR, (e_bin, pick)


def _collection(t, q, r0, points, amps, M=64):
    freq = 10e9 - 150e6 + np.arange(M) * 300e6 / (M - 1)
    dr = geometry.bistatic_differential_range(t, q, r0, points)
    return (np.exp(-1j * 4 * np.pi / geometry.C * freq[None, :, None] * dr[:, None, :]) * amps).sum(-1), freq


def rel_err(f, ref):
    return np.linalg.norm(f - ref) / np.linalg.norm(ref)


# measured 3.59e-5 at (2 km, 1 km) and 3.56e-5 at (500 m, 300 m), float32 and float64 alike, on every
# instruction set: the cubic kernel's interpolation error at upsample 16 (a monostatic scene gives 3.5e-5)
@pytest.mark.parametrize("r_t, r_r", [(2e3, 1e3), (500.0, 300.0)])
@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_wide_baseline_bistatic_matches_direct(isa, r_t, r_r, precision):
    """Transmitter and receiver 25° apart in azimuth (and 10° in elevation) at different ranges:
    backprojection against the exact bistatic matched filter. Each path's range curvature is its
    own, so a kernel that used one path's model for both misses by far more than this."""
    rng = np.random.default_rng(1)
    pts = np.column_stack([rng.uniform(-8, 8, 6), rng.uniform(-8, 8, 6), np.zeros(6)])
    amps = rng.normal(size=6) + 1j * rng.normal(size=6)
    t, q, r0 = pair(r_t, r_r, 25.0, az_deg=np.linspace(-1.5, 1.5, 64), el_t=30.0, el_r=20.0)
    data, freq = _collection(t, q, r0, pts, amps)
    ref = direct_spherical(data, freq, t, r0, GRID, receive_position_m=q)
    img = backproject(data, Collection(freq, t, r0, receive_position_m=q), GRID,
                      BackprojectionOptions(precision=precision))
    assert rel_err(img, ref) < 6e-5


@pytest.mark.parametrize("width", [16, 64, 13, 17, 1])
@pytest.mark.parametrize("model", [QUADRATIC, SERIES])
@pytest.mark.parametrize("bistatic", [False, True], ids=["monostatic", "bistatic"])
@pytest.mark.parametrize("precision, tol", [("float64", 1e-14), ("float32", 1e-6)])
def test_adjoint_and_forward_at_tile_widths_that_fill_every_lane(isa, monkeypatch, width, model, bistatic, precision,
                                                                 tol):
    """Rows of 45 pixels: tiles of 16 (every lane of an AVX-512 float vector, then 13 left), 64
    (16 + 16 + 13 in one tile), 13 and 17 (odd remainders), 1; each range model. Reprojection is
    the exact adjoint of backprojection at each, and the forward image matches the exact matched
    filter wherever the lanes fall (either model is within tolerance at 10 km even for 64 pixels)."""
    monkeypatch.setattr(_bp_rows, "tiling", lambda *args, **kw: Tiling(model, width, 0.0, 1.0))
    rng = np.random.default_rng(7)
    grid = Grid(45, 6, 0.25, 0.25, 0.4, -0.3)
    t, q, r0 = pair(10e3, 9e3 if bistatic else 10e3, 4.0 if bistatic else 0.0,
                    az_deg=np.linspace(-1.5, 1.5, 24), el_t=30.0, el_r=25.0)
    pts = np.array([[grid.x[c], grid.y[r], 0.0] for r, c in ((1, 3), (2, 14), (3, 15), (4, 30), (5, 44))])
    data, freq = _collection(t, q, r0, pts, np.ones(len(pts)), M=48)
    col, opts = Collection(freq, t, r0, receive_position_m=q), BackprojectionOptions(precision=precision)
    img = backproject(data, col, grid, opts)
    ref = direct_spherical(data, freq, t, r0, grid, receive_position_m=q)
    assert rel_err(img, ref) < 6e-5   # measured 3.1e-5 to 3.7e-5 (cubic interpolation)
    d = rng.normal(size=data.shape) + 1j * rng.normal(size=data.shape)
    f = rng.normal(size=grid.shape) + 1j * rng.normal(size=grid.shape)
    lhs = np.vdot(f, backproject(d, col, grid, opts))
    rhs = np.vdot(reproject(f, col, grid, opts), d)
    assert abs(lhs - rhs) / abs(lhs) < tol   # measured float64 <= 2.1e-15, float32 <= 3.7e-7
