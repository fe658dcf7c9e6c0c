"""The numerics the kernel families share (src/native/numerics/): the same bits in every family, and
the tables that cross into the kernels named alike on both sides."""

from __future__ import annotations

import numpy as np
import pytest

from sarcli._native import load
from sarcli._native.layout import BpGeo, BpPointGeo, FfbpFrame, FfbpPulse


def _bp_weights(kind, t):
    taps = (2, 4, 6)[kind]
    w = np.empty((t.size, taps), np.float32)
    load("backprojection").weight_values(t, kind, w)
    return w


def _ffbp_weights(kind, t):
    w = np.empty(((2, 4, 6)[kind], t.size), np.float32)
    load("ffbp").row_weights(kind, t, np.zeros((6, 8), np.float32), w)
    return w.T


@pytest.mark.parametrize("kind", [0, 1, 2])
def test_interpolation_weights_are_the_same_bits_in_backprojection_and_ffbp(kind):
    """Linear, Keys cubic and Lanczos-3 (numerics/keys.hpp, numerics/lanczos.hpp): one evaluation,
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
