"""The one home of "equally spaced frequencies", range wavenumbers and the interpolator registry."""
import numpy as np
import pytest

from sarcli.core import geometry, sampling
from sarcli.errors import SarcliInputError


def test_frequency_line_is_least_squares():
    f = 9.3e9 + 1.5e6 * np.arange(424.0)
    ref, step = sampling.frequency_line(f[None, :], 212)
    assert abs(ref[0] - f[212]) < 1e-3 and abs(step[0] - 1.5e6) < 1e-6
    rounded = f.astype(np.float32).astype(np.float64)[None, :]   # as in GOTCHA files
    ref, step = sampling.frequency_line(rounded, 212)
    line = ref[0] + (np.arange(424) - 212) * step[0]
    coef = np.polyfit(np.arange(424), rounded[0], 1)
    assert np.max(np.abs(line - np.polyval(coef, np.arange(424)))) < 1e-2


def test_spacing_deviation_measures_the_worst_sample_and_the_rms():
    m = 64
    f = np.tile(1e10 + 1e6 * np.arange(m, dtype=np.float64), (300, 1))   # more rows than one block
    f[257, 10] += 0.01 * 1e6                 # one sample off by 1 % of a step, in the second block
    worst, rms = sampling.spacing_deviation(f)
    # the least-squares line of that row absorbs a little of the deviation: between 0.9 % and 1 %
    assert 0.009 < worst <= 0.01
    assert rms == pytest.approx(np.sqrt((0.01e6) ** 2 * (1 - 1 / m) / f.size), rel=0.05)
    assert sampling.spacing_deviation(np.ones((3, 1))) == (0.0, 0.0)


def test_equally_spaced_accepts_float32_rounding_and_rejects_jitter():
    f = 9.3e9 + 1.5e6 * np.arange(424.0)
    ref, step = sampling.equally_spaced(f.astype(np.float32).astype(np.float64), "test")
    assert ref.shape == (1,) and step[0] == pytest.approx(1.5e6, rel=1e-6)
    bad = f.copy()
    bad[100] += 3 * sampling.SPACING_TOLERANCE * 1.5e6
    with pytest.raises(SarcliInputError, match=r"test needs equally spaced.*tolerance 0\.002"):
        sampling.equally_spaced(bad, "test")
    with pytest.raises(SarcliInputError, match="repeated"):
        sampling.equally_spaced(np.full(8, 1e10), "test")
    with pytest.raises(SarcliInputError, match="at least two"):
        sampling.equally_spaced(np.array([1e10]), "test")
    with pytest.raises(SarcliInputError, match="increasing"):
        sampling.equally_spaced(f[::-1], "test", increasing=True)
    sampling.equally_spaced(f[::-1], "test")      # decreasing but equally spaced is fine otherwise


def test_range_wavenumbers():
    assert sampling.range_wavenumbers(geometry.C / (4 * np.pi)) == pytest.approx(1.0)


def test_interpolator_registry_matches_the_formers():
    from sarcli.formers import backprojection
    from sarcli.formers.ffbp._kernels import NTAPS
    assert set(sampling.PROFILE_INTERPOLATORS) <= set(sampling.INTERPOLATORS)
    assert backprojection.INTERPOLATORS == {n: sampling.INTERPOLATORS[n].code for n in ("linear", "cubic", "lanczos", "lagrange")}
    for i in sampling.INTERPOLATORS.values():
        assert NTAPS[i.code] == i.taps
