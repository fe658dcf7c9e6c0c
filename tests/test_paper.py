"""The paper's numerical claims at CI sizes (the full-size figures run in ``make paper``).

Each test calls the same ``compute`` function as the figure script in ``scripts/paper/``, with
smaller sizes, and asserts the number that docs/paper.md reports.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts" / "paper"))

import fig01_kspace  # noqa: E402
import fig02_scene_size  # noqa: E402
import fig03_1dconv  # noqa: E402
import fig04_kernel  # noqa: E402
import fig05_phase1d  # noqa: E402
import fig06_phase  # noqa: E402
import fig07_1d  # noqa: E402
import fig08_admm2d  # noqa: E402
import fig09_opt  # noqa: E402
import fig10_gotcha  # noqa: E402
import fig11_projection  # noqa: E402
import fig12_example  # noqa: E402
from _common import acquisition  # noqa: E402




def test_fig01_wrapped_frequencies_alias_exactly():
    acq = acquisition("three-points", image={"pixels": 64}, frequencies={"count": 64}, azimuths={"count": 32})
    res = fig01_kspace.compute(acq, n_pixels_checked=8)
    assert res["aliased_fraction"] > 0.5  # 15.6 cm pixels: the X-band samples lie far beyond π
    assert res["share_wrapped"] > 0.95    # the image spectrum sits on the wrapped (orange) copies
    assert res["share_mirrored"] < 0.5    # far less on their mirror image (a sign error: < 25 %)
    assert res["operator_error"] < 1e-8


def test_fig02_alias_free_radii_match_the_formulas_and_the_replicas():
    r = fig02_scene_size.radii(acquisition("three-points"))
    assert r["rel_range"] < 1e-10 and r["rel_cross"] < 1e-10
    assert r["r_pi"] == pytest.approx(73.705, abs=1e-3)  # c / (4 · 600 MHz/511 · cos 30°)
    rep = fig02_scene_size.replicas(acquisition("three-points", **fig02_scene_size.DEMO), n_range=281, n_cross=201)
    assert rep["range_replica_error"] <= max(rep["range_step"], 0.5 * rep["rho_r"])
    assert rep["cross_in_band"]


def test_fig03_proposition_1_partial_sum_is_convolution():
    res = fig03_1dconv.compute(n_points=101, n_discrete=128)
    for kc in (0, 125):
        assert res[kc]["error"] < 1e-12
        assert res[kc]["discrete_error"] < 1e-12
    # the real step at K_c = 125: flat parts vanish, the jump does not
    x, mag = res["x"], np.abs(res[125]["sum"])
    assert mag[np.abs(np.abs(x) - np.pi / 2) < 0.5].max() < 0.1 * mag[np.abs(x) < 0.2].max()


def test_fig04_three_targets_are_three_shifted_kernels():
    acq = fig04_kernel.farfield_three_points(48, frequencies={"count": 64}, azimuths={"count": 32})
    res = fig04_kernel.superposition_error(acq)
    assert res["rel_l2"] < 1e-10


def test_fig04_spherical_gorham_moore_demo_is_close_to_the_kernel_sum():
    # backprojection of the spherical data vs the far-field theorem's three kernels (3.9 % measured)
    assert fig04_kernel.spherical_comparison(100) < 0.1


def test_fig05_random_phase_theorem_monte_carlo():
    res = fig05_phase1d.compute(n=512, n_draws=2000, seed=7)
    assert res["wrapped"][125] == 125  # the band 100..150 really is off-centre at N = 512
    with pytest.raises(ValueError, match="wrapping"):
        fig05_phase1d.compute(n=128, n_draws=2)  # 125 ± 25 would wrap to -3 ± 25
    for kc in (0, 125):
        assert res[kc]["max_z"] <= res["z_bound"]
        # neighbouring samples are strongly correlated, so the mean of z² over the samples scatters
        # (0.6-1.3 across seeds); a formula off by 10 % would give mean z² in the dozens
        assert 0.3 < res[kc]["mean_z2"] < 3.0


def test_fig05_formula_is_independent_of_the_band_centre():
    mag = fig05_phase1d.step_magnitude(64)
    rng = np.random.default_rng(0)
    f = mag * np.exp(1j * rng.uniform(-np.pi, np.pi, (3000, 64)))
    p0 = np.mean(np.abs(fig05_phase1d.band_sum(f, 0, 20)) ** 2, axis=0)
    p1 = np.mean(np.abs(fig05_phase1d.band_sum(f, 20, 20)) ** 2, axis=0)  # band 10..30: off-centre
    expected = fig05_phase1d.expected_power(mag, 20)
    assert np.max(np.abs(p0 - expected)) / expected.max() < 0.1
    assert np.max(np.abs(p1 - expected)) / expected.max() < 0.1


def test_fig06_random_phase_recovers_the_interior_real_phase_only_edges():
    res = fig06_phase.compute(pixels=64, n_freq=64, n_pulses=64, n_draws=150)
    assert 0.8 < res["mean_z2"] < 1.25
    assert res["interior_expected"] > 0.7
    assert res["interior_random"] > 0.7
    assert res["interior_real"] < 0.5 * res["interior_expected"]


def test_fig07_tv_removes_gibbs_and_fills_coefficients():
    assert fig07_1d.quadrature_check((1, 2, 7, 75)) < 1e-10  # f̂_k = i/(πk)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the iteration cap is part of the setting
        res = fig07_1d.compute(n=512, k_max=75, iters=1500)  # the paper's |k| ≤ 75
    o, e = res["overshoot"], res["error"]
    assert 0.14 < o["partial"] < 0.18  # sampled Gibbs overshoot (0.153; 0.179 in the continuum)
    assert o["tv"] < 0.01 and o["hann"] < 0.01
    assert e["tv"] < 0.85 * e["partial"] and e["tv"] < e["hann"]  # measured 0.0387, 0.0481, 0.0616
    assert res["coef_err"] < 0.3  # coefficients beyond the band (0.22); partial/filtered sums: 1
    assert res["data_fit"] < 1e-3
    assert fig07_1d.bounds_hold(res)


def test_fig08_admm_objective_is_monotone_for_the_most_part():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = fig08_admm2d.compute(n=48, iters=100)
    assert res["rise_fraction"] < 0.01
    assert res["objective"][-1] < 0.5 * res["objective0"]
    assert res["error_admm"] < res["error_zero_filled"]


def test_fig09_optimality_conditions_hold_after_admm():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = fig09_opt.compute(m=80, n=100, lam=0.5, iters=2000)
    assert res["grad_rel"] < 1e-3
    assert res["cond2_nonzero"] < 1e-2
    assert res["cond2_zero"] <= 1 + 1e-2
    assert res["constraint"] < 1e-3
    assert res["cond4_max"] <= 1 + 1e-2
    assert res["cond4_lsq"] < 1e-2


@pytest.mark.gotcha
def test_fig10_regularisation_reduces_speckle_and_sharpens_on_gotcha():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = fig10_gotcha.compute(n_files=1, extent_m=24.0, pixel_m=0.25, iters=30, priors=("tv",))
    assert len(res["blocks"]) >= 5  # homogeneous (fully developed speckle) blocks exist
    m, r = res["speckle"]["mf"], res["speckle"]["tv"]  # TV: the paper's prior for GOTCHA
    assert r["enl"] > 1.2 * m["enl"] and r["contrast"] < 0.9 * m["contrast"]  # reduced speckle (ENL 2.6 vs 1.09)
    assert r["entropy"] < m["entropy"] and r["peak_to_mean"] > m["peak_to_mean"]  # sharper targets
    assert fig10_gotcha.claim_holds(res, "tv")


def test_fig10_cv_column_analogue_l1_on_a_sparse_scene():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = fig10_gotcha.cv_analogue(n=32, n_points=8)
    assert res["err"]["l1"] < 0.2 * res["err"]["mf"]            # measured 0.03 vs 1.18 at n = 40
    assert res["entropy"]["l1"] < res["entropy"]["mf"] - 1.0     # sharper: less sidelobe energy
    assert np.all(np.abs(res["peaks"] - 1) < 0.1)                # true features kept
    assert res["outside"]["l1"] > 10 * res["outside"]["mf"]      # k-space filled beyond the data


def test_fig11_projection_lemma_dot_test_and_sar_link():
    proj = fig11_projection.Projection(fig11_projection.Grid.square(1.0, 48), 0.6, 101, 2.0 / 48)
    assert fig11_projection.dot_test(proj) < 1e-12
    lem = fig11_projection.lemma_formula(proj)
    assert lem["linear"] < 1e-12 and lem["smooth"] <= lem["smooth_bound"]
    assert fig11_projection.disk_projection(n=128) < 0.03
    # sarcli's single-look matched filter is the backprojection of the look's range profile
    assert fig11_projection.sar_single_look(n=32) < 1e-3


def test_fig12_example_analogue_range_profiles_are_projections():
    res = fig12_example.compute(n_looks=400, n_freq=100, pixels=128, pixel_m=0.04)
    assert res["share"].min() > 0.99
    assert max(res["corner_errors"]) <= 1.5 * res["grid"].dx


def test_every_figure_of_the_paper_has_a_module():
    import importlib
    import re

    import run_all

    tex = REPO.parent / "shared" / "paper" / "spotlight-sar-fourier-analysis.tex"
    if not tex.exists():
        pytest.skip(f"the paper's source is not at {tex}")
    figures = re.findall(r"\\begin\{figure\}(.*?)\\end\{figure\}", tex.read_text(), re.S)
    labels = {re.search(r"\\label\{([^}]*)\}", f).group(1) for f in figures}
    assert len(figures) == 12 and len(labels) == 12
    covered = {importlib.import_module(m).LABEL for m in run_all.MODULES}
    assert labels == covered
