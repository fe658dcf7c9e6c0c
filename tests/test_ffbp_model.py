"""ffbp's shipped kernel tables against a fresh design, and the design itself."""

from __future__ import annotations

import numpy as np
import pytest

from sarcli.formers.ffbp import model as fm


def test_tables_ship_for_every_planned_oversampling():
    shipped = fm._shipped()
    for beta in fm.TABLE_BETAS:
        for name in ("optimal", "deapodized", "deapodized_mean", "deapodized_alias"):
            assert (name, beta) in shipped, (name, beta)


@pytest.mark.parametrize("beta", [1.5, 4.0])
def test_shipped_tables_equal_a_fresh_design(beta):
    fresh = fm.kernel_tables([beta])[0]
    row = np.load(fm.TABLE_PATH)
    row = row[row[:, 0] == beta][0]
    # the design is an iterative least-squares fit: LAPACK's rounding moves small weights by ~1e-13
    # between machines and thread counts (seen: 4e-13 on weights of 1e-5), a wrong table by O(1)
    np.testing.assert_allclose(row, fresh, rtol=1e-9, atol=1e-10 * np.max(np.abs(fresh[1:])))


def test_optimal_weights_are_minimax_per_fraction():
    """Batched Lawson against one fraction at a time by LAPACK's least squares (gelsd)."""
    beta, taps, t = 2.0, 6, np.array([0.1, 0.5, 0.83])
    offs = np.arange(-2, 4)
    nu = np.linspace(-0.5, 0.5, 129) / beta
    got = fm.optimal_weights(beta, t, taps)
    for i, ti in enumerate(t):
        a = np.exp(2j * np.pi * nu[:, None] * (offs[None, :] - ti))
        m, b = np.vstack([a.real, a.imag]), np.concatenate([np.ones(nu.size), np.zeros(nu.size)])
        lw = np.ones(nu.size)
        for _ in range(fm.LAWSON_ITERATIONS + 1):
            sw = np.sqrt(np.concatenate([lw, lw]))
            x = np.linalg.lstsq(m * sw[:, None], b * sw, rcond=None)[0]
            err = np.abs(1.0 - a @ x)
            lw = lw * (err + 1e-300)
            lw /= lw.sum()
        np.testing.assert_allclose(got[i], x, rtol=1e-10, atol=1e-12)
        # minimax: the error equioscillates, its peaks within a few % of each other
        e = np.abs(1.0 - a @ got[i])
        peaks = e[1:-1][(e[1:-1] >= e[:-2]) & (e[1:-1] >= e[2:])]
        assert peaks.min() > 0.9 * peaks.max()


def test_an_oversampling_without_a_table_is_designed():
    beta = 1.7
    assert ("optimal", beta) not in fm._shipped()
    k = fm.optimal_kernel(beta)
    e = fm.interp_error("optimal", beta)
    assert k.shape == (6, fm.DEGREE + 1)
    assert fm.interp_error("optimal", 2.0) < e < fm.interp_error("optimal", 1.5)


def test_a_missing_table_file_falls_back_to_design(monkeypatch, tmp_path):
    monkeypatch.setattr(fm, "TABLE_PATH", tmp_path / "none.npy")
    fm._shipped.cache_clear()
    try:
        assert fm._shipped() == {}
        assert fm._tabled("optimal", 1.5, lambda: "designed") == "designed"
    finally:
        monkeypatch.undo()
        fm._shipped.cache_clear()
