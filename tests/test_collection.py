"""The collection the range-model formers take (sarcli.core.collection): made from an acquisition,
sliced by pulses, and passed whole to a former."""

import numpy as np

from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.core.collection import Collection
from sarcli.core.grid import Grid
from sarcli.formers.backprojection import backproject


def _positions(P=12, r=3e3):
    az = np.radians(np.linspace(-2.0, 2.0, P))
    el = np.full(P, np.radians(30.0))
    return az, el, geometry.antenna_positions_circle(az, el, r)


def test_acquisition_collection_is_its_range_geometry():
    az, el, a = _positions()
    freq = 9.6e9 + 4e6 * np.arange(16)
    mono = Acquisition(freq, az, el, Grid(8, 8, 0.5, 0.5), antenna_position_m=a, model="spherical")
    w = np.hanning(18)[1:-1]
    col = mono.collection(w)
    assert col.receive_position_m is None and col.weights is w
    np.testing.assert_array_equal(col.antenna_position_m, a)
    np.testing.assert_array_equal(col.range_to_center_m, np.linalg.norm(a, axis=1))
    assert (col.n_pulses, col.n_frequencies) == (12, 16)
    q = a + np.array([0.0, 50.0, 5.0])
    bi = Acquisition(freq, az, el, Grid(8, 8, 0.5, 0.5), transmit_position_m=a, receive_position_m=q,
                     model="spherical").collection()
    np.testing.assert_array_equal(bi.antenna_position_m, a)     # the transmit positions, not the midpoint
    np.testing.assert_array_equal(bi.receive_position_m, q)
    np.testing.assert_array_equal(bi.range_to_center_m, geometry.bistatic_reference_range(a, q))


def test_pulses_slice_what_is_per_pulse_and_keep_what_is_shared():
    _, _, a = _positions()
    rng = np.random.default_rng(4)
    f2 = 9.6e9 + 4e6 * np.arange(16) + rng.uniform(0, 1e6, (12, 1))   # per-pulse frequencies
    w2 = rng.uniform(0.5, 1.0, (12, 16))
    q = a + 1.0
    col = Collection(f2, a, np.linalg.norm(a, axis=1), w2, q)
    sub = col.pulses(slice(3, 7))
    np.testing.assert_array_equal(sub.frequency_hz, f2[3:7])
    np.testing.assert_array_equal(sub.weights, w2[3:7])
    np.testing.assert_array_equal(sub.receive_position_m, q[3:7])
    assert sub.n_pulses == 4
    shared = Collection(f2[0], a, np.linalg.norm(a, axis=1), w2[0]).pulses(slice(0, 2))
    assert shared.frequency_hz is not None and shared.frequency_hz.ndim == 1 and shared.weights.ndim == 1
    assert shared.receive_position_m is None
    # a former on the slice gives the image of the sliced arrays, bit for bit
    d = rng.standard_normal((12, 16)) + 1j * rng.standard_normal((12, 16))
    grid = Grid(16, 12, 0.5, 0.5)
    whole = Collection(f2[3:7], a[3:7], np.linalg.norm(a, axis=1)[3:7], w2[3:7], q[3:7])
    assert np.array_equal(backproject(d[3:7], sub, grid), backproject(d[3:7], whole, grid))
