"""Autofocus never leaves a collection further from its truth than it found it: the family of
simulated cases (tests/autofocus_family.py), PGA's evidence, and the sharpness both methods report."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from sarcli.autofocus import DECISION_CODES, autofocus
from sarcli.autofocus._common import AutofocusWarning
from sarcli.autofocus._levels import gauge_basis, predicted_residual
from sarcli.autofocus.pga import dominance, halves_agreement, peak_positions, scatterer_weights
from sarcli.core.grid import Grid

from .autofocus_family import GOOD_RAD, all_cases, family_case, user_case


def _both(case):
    out = {}
    for method in ("pga", "min-entropy"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AutofocusWarning)   # "applied no correction" is an outcome here
            _, res = autofocus(case.bad, method)
        out[method] = res
    return out


def _check(case, results):
    """Left ≤ injected for each method; PGA within GOOD_RAD wherever minimum entropy is, or nothing
    applied; and nothing applied says so."""
    inj = case.injected
    left = {m: case.residual(r.phase_rad) for m, r in results.items()}
    for m, r in results.items():
        assert left[m] <= inj + 1e-9, (case.name, m, left[m], inj, r.describe())
        assert r.code in DECISION_CODES
        # nothing applied says why (its code), and an applied correction says so
        assert (r.code == "applied") == bool(np.any(r.phase_rad)), (r.code, r.describe())
    pga = results["pga"]
    if left["min-entropy"] <= GOOD_RAD and np.any(pga.phase_rad):
        assert left["pga"] <= GOOD_RAD, (case.name, left, pga.describe())
    return left


@pytest.mark.parametrize("error, scene, path", all_cases())
def test_family_never_further_from_the_truth(error, scene, path):
    """Each case of the family, seed 0 (bench/bench_autofocus_family.py reports more seeds)."""
    case = family_case(error, scene, path, seed=0)
    _check(case, _both(case))


def test_the_users_case():
    """Ku band, a straight path at 8 km, 3°, five points and a disk phantom, a smooth error of
    0.65 rad rms: PGA took halves correlating 0.27 (chance 0.13) as agreement, applied 0.695 rad
    rms and left 0.757. Each method leaves less than was injected, and PGA, where it applies
    anything, is within 0.2 rad rms as minimum entropy is (measured, seed 0: PGA 0.057, minimum
    entropy 0.065 rad rms left)."""
    case = user_case(seed=0)
    results = _both(case)
    left = _check(case, results)
    assert left["min-entropy"] < 0.15   # what the test is for: minimum entropy reaches the truth here
    for r in results.values():
        assert r.entropy_after <= r.entropy_before


def test_both_methods_report_the_same_sharpness_before():
    """The entropy and peak-to-mean "before" are one quantity in both methods: the images of the grid
    asked for, formed the same way (they differed by the grid and the image former: 8.1329 and
    8.1369 on one collection)."""
    case = user_case(seed=0)
    results = _both(case)
    pga, me = results["pga"], results["min-entropy"]
    assert pga.entropy_before == pytest.approx(me.entropy_before, rel=1e-9)
    assert pga.peak_to_mean_before == pytest.approx(me.peak_to_mean_before, rel=1e-9)
    assert pga.entropy_after < pga.entropy_before and me.entropy_after < me.entropy_before


def test_halves_agreement_is_taken_modulo_two_pi_and_predicts_the_residual():
    """Two halves' estimates that differ by whole turns on some pulses and by an unobservable
    linear phase agree exactly; with independent noise of rms σ on each, the whole scene's estimate
    (noise about σ/√2) is predicted to leave about σ/√2."""
    case = family_case("smooth", "points", "line", seed=0)
    gauge = gauge_basis(case.clean.acquisition)
    rng = np.random.default_rng(3)
    e = case.error
    turns = 2 * np.pi * rng.integers(-2, 3, e.size)
    lin = gauge @ np.array([0.7, -1.3])
    corr, spread = halves_agreement(e, e + turns + lin, gauge)
    assert corr == pytest.approx(1.0, abs=1e-9) and spread == pytest.approx(0.0, abs=1e-9)
    sigma = 0.3
    a, b = e + rng.normal(0, sigma, e.size), e + rng.normal(0, sigma, e.size)
    corr, spread = halves_agreement(a, b + turns, gauge)
    assert spread == pytest.approx(sigma / np.sqrt(2), rel=0.15)
    rho = np.mean(e ** 2) / (np.mean(e ** 2) + sigma ** 2)
    assert corr == pytest.approx(rho, abs=0.05)


def test_speckle_lines_carry_no_weight():
    """A selected line whose peak stands no higher over its median than speckle does (about
    log2 P) gets weight 0; a dominant scatterer's line gets 1/median, so a line in stronger clutter
    counts for less."""
    rng = np.random.default_rng(0)
    P = 128
    speckle = rng.exponential(1.0, (4 * P, 3))
    speckle[0] = speckle.max(axis=0)   # its brightest cell centred, as the centre shift does
    point = rng.exponential(1.0, (4 * P, 2)) * np.array([1.0, 4.0])
    point[0] = 500.0
    w = scatterer_weights(np.column_stack([speckle, point]), P)
    assert dominance(P) == pytest.approx(14.0)
    np.testing.assert_array_equal(w[:3], 0.0)
    assert w[3] == pytest.approx(1.0 / np.median(point[:, 0])) and w[4] == pytest.approx(1.0 / np.median(point[:, 1]))
    assert w[3] > 2 * w[4]


@pytest.mark.parametrize("error, scene, path, method", [("smooth", "points", "curved", "pga"),
                                                        ("white", "extended", "curved", "min-entropy")])
def test_seed_three_cases(error, scene, path, method):
    """Two cases of seed 3 where a method left more than its targets allow: PGA 0.260 rad rms
    where minimum entropy left 0.041 (its scatterers taken at pixel centres: on a path whose
    elevation changes, a scatterer off its pixel in range adds a smooth phase of its own), and
    minimum entropy 0.279 of an injected 0.226 (its halves' estimates correlated 0.55, yet one
    left 0.46 and the other 0.13). Now PGA reaches 0.2 rad rms and minimum entropy, whose halves
    cannot vouch for its estimate, applies nothing and says why."""
    case = family_case(error, scene, path, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AutofocusWarning)
        _, res = autofocus(case.bad, method)
    left = case.residual(res.phase_rad)
    assert left <= case.injected
    if method == "pga":
        assert res.code == "applied" and left <= GOOD_RAD, res.describe()
    else:
        assert res.code == "untrusted" and not res.history["trust"]["trusted"], res.describe()
        t = res.history["trust"]
        assert t["predicted_rad"] >= t["signal_low_rad"]


def test_predicted_residual_bounds_the_residual_and_finds_the_error():
    """Two halves ``ε + n_a``, ``ε + n_b`` (noise of rms σ each) and a whole-scene estimate ``φ``
    that departs from their mean by δ: the prediction (spread + departure) is at least the true
    residual, the signal is the rms of ``ε``, and an estimate noisier than the error is not
    trusted."""
    case = family_case("smooth", "points", "line", seed=0)
    gauge = gauge_basis(case.clean.acquisition)
    rng = np.random.default_rng(5)
    e = case.error
    P = e.size
    rms = lambda x: float(np.sqrt(np.mean(x ** 2)))   # noqa: E731
    for sigma, trusted in ((0.1, True), (1.5, False)):
        a, b = e + rng.normal(0, sigma, P), e + rng.normal(0, sigma, P)
        phi = (a + b) / 2 + rng.normal(0, 0.05, P)
        t = predicted_residual(phi, a, b + 2 * np.pi * rng.integers(-1, 2, P), gauge)
        assert t["predicted_rad"] >= case.residual(phi)
        assert t["spread_rad"] == pytest.approx(sigma / np.sqrt(2), rel=0.2)
        assert t["trusted"] is trusted
        if trusted:
            assert t["signal_rad"] == pytest.approx(rms(e), rel=0.1)
            assert t["departure_rad"] == pytest.approx(0.05, rel=0.3)


def test_peak_positions_find_a_peak_between_pixels():
    """A peak between pixels is placed to a small fraction of a pixel (a parabola through the
    log magnitude, exact for a Gaussian); one on the grid's edge stays at its pixel."""
    grid = Grid(32, 32, 0.125, 0.125)
    x0, y0 = grid.x[10] + 0.3 * grid.dx, grid.y[20] - 0.4 * grid.dy
    xx, yy = np.meshgrid(grid.x, grid.y)
    img = np.exp(-((xx - x0) ** 2 + (yy - y0) ** 2) / (2 * 0.2 ** 2)) + 0j
    pts = peak_positions(img, np.array([20, 0]), np.array([10, 10]), grid)
    np.testing.assert_allclose(pts[0], [x0, y0], atol=1e-9)
    np.testing.assert_allclose(pts[1], [x0, grid.y[0]], atol=1e-9)
