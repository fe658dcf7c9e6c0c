"""Speckle metrics against closed forms (exponential speckle statistics, flat and one-pixel images)."""

import numpy as np
import pytest

from sarcli.analysis.speckle import (contrast, equivalent_number_of_looks, image_entropy,
                                     peak_to_mean, speckle_metrics)


def _speckle(shape, looks=1, seed=0):
    """Complex image whose intensity is the mean of ``looks`` independent exponential looks."""
    rng = np.random.default_rng(seed)
    inten = np.zeros(shape)
    for _ in range(looks):
        z = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
        inten += np.abs(z) ** 2
    return np.sqrt(inten / looks) * np.exp(1j * rng.uniform(0, 2 * np.pi, shape))


def test_entropy_extremes():
    n = 64
    assert image_entropy(np.ones((8, 8))) == pytest.approx(np.log(n), rel=1e-12)
    one = np.zeros((8, 8), complex)
    one[3, 5] = 2 - 1j
    assert image_entropy(one) == 0.0
    assert image_entropy(np.zeros((4, 4))) == 0.0


def test_entropy_two_levels_closed_form():
    # p = (a, a, b, b ...) -> H = -sum p ln p exactly
    f = np.array([1.0, 1.0, 2.0, 0.0])
    p = np.array([1, 1, 4]) / 6.0
    assert image_entropy(f) == pytest.approx(-np.sum(p * np.log(p)), rel=1e-12)


def test_entropy_is_scale_invariant_and_lower_when_sharper():
    rng = np.random.default_rng(1)
    f = rng.standard_normal((32, 32)) + 1j * rng.standard_normal((32, 32))
    assert image_entropy(7.5 * f) == pytest.approx(image_entropy(f), rel=2e-15)   # measured 2.3e-16
    blurred = np.convolve(np.r_[np.zeros(20), 1.0, np.zeros(20)], np.ones(5) / 5, "same")
    sharp = np.r_[np.zeros(20), 1.0, np.zeros(20)]
    assert image_entropy(sharp) < image_entropy(blurred)
    assert peak_to_mean(sharp) > peak_to_mean(blurred)


def test_peak_to_mean_closed_form():
    f = np.zeros(16)
    f[0] = 1.0
    assert peak_to_mean(f) == 16.0
    assert peak_to_mean(np.full((3, 3), 2.0 + 2.0j)) == pytest.approx(1.0)
    assert peak_to_mean(np.zeros(4)) == 0.0


@pytest.mark.parametrize("looks", [1, 4])
def test_enl_and_contrast_of_speckle(looks):
    f = _speckle((256, 256), looks=looks)
    enl = equivalent_number_of_looks(f)
    assert enl == pytest.approx(looks, rel=0.06)
    assert contrast(f) == pytest.approx(1 / np.sqrt(looks), rel=0.04)
    assert contrast(f) == pytest.approx(1 / np.sqrt(enl), rel=1e-12)


def test_region_mask_and_slices():
    f = _speckle((128, 128), looks=1)
    f[:, 64:] = 3.0                       # constant right half
    assert equivalent_number_of_looks(f, (slice(None), slice(64, None))) == np.inf
    assert contrast(f, (slice(None), slice(64, None))) == 0.0
    mask = np.zeros(f.shape, bool)
    mask[:, :64] = True
    assert equivalent_number_of_looks(f, mask) == pytest.approx(1.0, rel=0.1)
    with pytest.raises(ValueError, match="region"):
        contrast(f, np.zeros(f.shape, bool))
    m = speckle_metrics(f, mask)
    assert set(m) == {"entropy", "peak_to_mean", "enl", "contrast"}
    assert m["enl"] == pytest.approx(equivalent_number_of_looks(f, mask))


def test_zero_region_is_nan():
    assert np.isnan(equivalent_number_of_looks(np.zeros((4, 4))))
    assert np.isnan(contrast(np.zeros((4, 4))))


def _write_speckle_image(path, seed=0):
    from sarcli.core.types import Image
    from sarcli.io.hdf5 import write_image

    f = _speckle((64, 64), looks=1, seed=seed)
    f[:, 32:] = _speckle((64, 32), looks=16, seed=seed + 1)      # right half: 16 looks
    x = np.arange(64) * 0.5 - 16.0
    write_image(path, Image(f, x, x.copy(), method="test", parameters={}))
    return f


def test_quality_cli_speckle_section(tmp_path):
    import json

    from click.testing import CliRunner

    from sarcli.cli.main import cli

    p = tmp_path / "img.h5"
    _write_speckle_image(p)
    r = CliRunner().invoke(cli, ["quality", str(p), "--speckle", "--region", "0.5,15.5,-16,15.5", "--json"])
    assert r.exit_code == 0, r.output
    m = json.loads(r.output)["speckle"]
    assert m["enl"] == pytest.approx(16, rel=0.02)           # the 16-look half only (measured 15.95, 2.9e-3)
    assert m["contrast"] == pytest.approx(0.25, rel=0.01)    # measured 0.2504, 1.5e-3
    assert m["region_pixels"] == [64, 31]
    r = CliRunner().invoke(cli, ["quality", str(p), "--speckle"])
    assert r.exit_code == 0 and "ENL" in r.output and "entropy" in r.output
    for bad in ("1,2,3", "5,1,0,1", "100,200,0,1", "a,b,c,d"):
        r = CliRunner().invoke(cli, ["quality", str(p), "--region", bad])
        assert r.exit_code == 2 and "--region" in r.output and "Traceback" not in r.output
