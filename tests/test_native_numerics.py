"""The numerics the kernel families share (src/native/numerics/): the same bits in every family, and
the tables that cross into the kernels named alike on both sides."""

from __future__ import annotations

import numpy as np
import pytest

from sarcli._native import load
from sarcli._native.layout import BpGeo, BpPointGeo, FfbpFrame, FfbpPulse


def _bp_weights(kind, t):
    taps = {0: 2, 1: 4, 2: 6, 4: 4}[kind]
    w = np.empty((t.size, taps), np.float32)
    load("backprojection").weight_values(t, kind, w)
    return w


def _ffbp_weights(kind, t):
    w = np.empty(({0: 2, 1: 4, 2: 6, 4: 4}[kind], t.size), np.float32)
    load("ffbp").row_weights(kind, t, np.zeros((6, 8), np.float32), w)
    return w.T


@pytest.mark.parametrize("kind", [0, 1, 2, 4])
def test_interpolation_weights_are_the_same_bits_in_backprojection_and_ffbp(kind):
    """Linear, Keys cubic, Lanczos-3 and cubic Lagrange (numerics/keys.hpp, numerics/lanczos.hpp): one evaluation,
    so the two families' weights agree bit for bit at every fraction, the ends included."""
    t = np.concatenate([np.random.default_rng(kind).random(4000), [0.0, 0.5, 1e-7, 1 - 2**-24]]).astype(np.float32)
    bp, ff = _bp_weights(kind, t), _ffbp_weights(kind, t)
    assert bp.tobytes() == ff.tobytes(), np.max(np.abs(bp - ff))


def test_carrier_is_the_same_bits_in_backprojection_and_ffbp():
    """The float32 carrier of a float64 phase (numerics/sincos.hpp) at small and large phases."""
    rng = np.random.default_rng(11)
    ph = np.concatenate([rng.uniform(-4, 4, 4000), rng.uniform(-3e6, 3e6, 4000), [0.0, np.pi, -np.pi, 2 * np.pi]])
    out = {}
    for family in ("backprojection", "ffbp"):
        c, s = np.empty(ph.size, np.float32), np.empty(ph.size, np.float32)
        load(family).carrier_values(ph, c, s)
        out[family] = (c, s)
    assert out["backprojection"][0].tobytes() == out["ffbp"][0].tobytes()
    assert out["backprojection"][1].tobytes() == out["ffbp"][1].tobytes()
    c, s = out["ffbp"]
    assert np.max(np.abs(c + 1j * s - np.exp(1j * ph))) < 6e-7   # measured 3.9e-7


def test_carrier_in_turns_is_as_accurate_as_the_carrier_in_radians():
    """The tiled backprojection kernels' carrier of phases in turns (cos_sin_turns_f32): float32
    accuracy at small and large phases, and the same accuracy as the carrier of the same phase
    in radians."""
    rng = np.random.default_rng(12)
    q = np.concatenate([rng.uniform(-1, 1, 4000), rng.uniform(-5e5, 5e5, 4000), [0.0, 0.5, -0.5, 0.25, 1e-9]])
    kern = load("backprojection")
    c, s = np.empty(q.size, np.float32), np.empty(q.size, np.float32)
    kern.carrier_turn_values(q, c, s)
    exact = np.exp(2j * np.pi * (q - np.rint(q)))
    err = np.abs(c + 1j * s - exact)
    assert err.max() < 6e-7
    small = np.abs(q) <= 1
    cr, sr = np.empty(q.size, np.float32), np.empty(q.size, np.float32)
    kern.carrier_values(2 * np.pi * q[small], cr[:small.sum()], sr[:small.sum()])
    ref_err = np.abs(cr[:small.sum()] + 1j * sr[:small.sum()] - exact[small])
    assert np.sqrt(np.mean(err[small] ** 2)) < 2 * np.sqrt(np.mean(ref_err ** 2))


@pytest.mark.parametrize("family, name, rows", [("backprojection", "GEO_ROWS", BpGeo),
                                                ("backprojection", "POINT_ROWS", BpPointGeo),
                                                ("ffbp", "FRAME_ROWS", FfbpFrame),
                                                ("ffbp", "PULSE_ROWS", FfbpPulse)])
def test_table_rows_are_named_alike_in_python_and_the_kernels(family, name, rows):
    native = getattr(load(family), name)
    assert native == {r.name.lower(): int(r) for r in rows}
    assert sorted(native.values()) == list(range(len(rows)))


@pytest.mark.parametrize("family", ["backprojection", "ffbp"])
def test_interpolator_codes_are_the_same_in_python_and_the_kernels(family):
    from sarcli.core.sampling import INTERPOLATORS, PROFILE_INTERPOLATORS

    names = PROFILE_INTERPOLATORS if family == "backprojection" else tuple(INTERPOLATORS)
    assert load(family).INTERPOLATORS == {n: (INTERPOLATORS[n].code, INTERPOLATORS[n].taps) for n in names}
