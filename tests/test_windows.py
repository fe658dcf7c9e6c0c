"""Window weights: shapes, validation, peak preservation and sidelobe levels."""

import numpy as np
import pytest

from sarcli.core import geometry
from sarcli.formers.direct import direct_farfield
from sarcli.core.grid import Grid
from sarcli.core.windows import WINDOW_KINDS, window_1d, window_weights


def _peak_sidelobe_db(w, pad=64):
    """Peak sidelobe (dB below the main lobe) of a window's zero-padded spectrum."""
    spec = np.abs(np.fft.fft(w, pad * w.size))
    spec /= spec[0]
    half = spec[: spec.size // 2]
    first_null = np.argmax(np.diff(half) > 0)  # end of the main lobe
    return 20 * np.log10(half[first_null:].max())


@pytest.mark.parametrize("kind", WINDOW_KINDS)
def test_shape_and_range(kind):
    w = window_weights(7, 5, kind)
    assert w.shape == (7, 5)
    assert w.dtype == np.float64
    assert w.max() <= 1.0 + 1e-12 and w.min() >= 0.0
    # separable: rank one
    s = np.linalg.svd(w, compute_uv=False)
    assert s[1] < 1e-12 * s[0]


def test_none_single_and_degenerate():
    assert np.array_equal(window_weights(3, 4, "none"), np.ones((3, 4)))
    for kind in WINDOW_KINDS:
        assert np.array_equal(window_weights(1, 1, kind), np.ones((1, 1)))
    # a two-sample Hann window would be all zeros: flat instead
    assert np.array_equal(window_1d(2, "hann"), np.ones(2))


def test_unknown_kind_names_valid_ones():
    with pytest.raises(ValueError, match="hann, hamming, taylor"):
        window_weights(4, 4, "blackman")


def test_sidelobe_levels():
    n = 128
    assert _peak_sidelobe_db(window_1d(n, "none")) == pytest.approx(-13.26, abs=0.1)
    assert _peak_sidelobe_db(window_1d(n, "hann")) == pytest.approx(-31.5, abs=0.3)
    assert _peak_sidelobe_db(window_1d(n, "hamming")) < -41.0
    assert _peak_sidelobe_db(window_1d(n, "taylor")) < -34.5  # defaults nbar=4, -35 dB: -35.2
    for sll in (-30, -35, -40):
        level = _peak_sidelobe_db(window_1d(n, "taylor", nbar=5, sll_db=sll))
        assert sll - 1.5 < level < sll + 0.5  # approximately at the requested level


@pytest.mark.parametrize("kind", WINDOW_KINDS)
def test_unit_point_keeps_peak_one(kind):
    p, m = 40, 48
    az = np.deg2rad(50 + np.linspace(-1.5, 1.5, p))
    el = np.full(p, np.deg2rad(30))
    freq = 1e10 + np.linspace(-3e8, 3e8, m)
    kx, ky = geometry.kspace_coordinates(freq, az, el)
    grid = Grid.square(6.0, 32)
    point = np.array([[1.5, -0.75, 0.0]])  # a pixel centre
    data = np.exp(-1j * geometry.signal_phase(freq, az, el, point))[..., 0]
    image = direct_farfield(data, kx, ky, grid, window_weights(p, m, kind))
    row, col = grid.index_of(1.5, -0.75)
    assert np.unravel_index(np.argmax(np.abs(image)), image.shape) == (row, col)
    assert abs(image[row, col]) == pytest.approx(1.0, abs=1e-12)


def test_blackman_harris_closed_form_and_sidelobes():
    from sarcli.core.windows import BLACKMAN_HARRIS_MAINLOBE_BINS, blackman_harris

    w = blackman_harris(65)
    np.testing.assert_allclose(w, w[::-1], atol=1e-15)
    assert abs(w[32] - 1.0) < 1e-12 and abs(w[0] - 6e-5) < 1e-12  # a0 + a1 + a2 + a3 = 1; a0 - a1 + a2 - a3
    spec = np.abs(np.fft.fft(w, 65 * 64))
    spec_db = 20 * np.log10(spec / spec[0] + 1e-300)
    beyond = np.arange(spec.size) / 64.0  # frequency in bins of the unpadded DFT
    lobe = (beyond > BLACKMAN_HARRIS_MAINLOBE_BINS) & (beyond < 65 - BLACKMAN_HARRIS_MAINLOBE_BINS)
    assert spec_db[lobe].max() < -91.0  # the 4-term window's -92 dB sidelobes, outside the main lobe
    assert blackman_harris(1).tolist() == [1.0]
