"""``sarcli.batch.benchmark`` and ``sar bench``: error against run time, Pareto front, CSV/PNG."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sarcli.analysis import accuracy
from sarcli.batch import benchmark as bm
from sarcli.viz import plot_benchmark
from sarcli.cli.main import cli

from .conftest import small_config

from .conftest import GOTCHA_FILES  # noqa: E402


def _farfield_cfg(**kw):
    cfg = small_config(model="farfield", geometry={"path": "farfield"},
                       image={"half_width_m": 2.0, "pixels": 32}, **kw)
    cfg["scene"]["points"][1]["position_m"] = [-0.75, 0.5]  # on a pixel centre of the 32 x 32 grid
    return cfg


@pytest.fixture
def ph(write_config):
    return bm.load_input(write_config(_farfield_cfg()))


def test_pareto_front_by_hand():
    err = [1e-1, 1e-3, 1e-2, 1e-6, 1e-4, np.nan]
    sec = [0.1, 0.2, 0.3, 1.0, 2.0, 0.01]
    # (0.1, 1e-1), (0.2, 1e-3), (1.0, 1e-6) are unbeaten; (0.3, 1e-2) and (2.0, 1e-4) are dominated
    assert accuracy.pareto_front(err, sec).tolist() == [0, 1, 3]


def test_sweep_covers_every_accuracy_knob():
    s = bm.sweep()
    eps = sorted(k["eps"] for m, k in s if m == "nufft" and "eps" in k)
    assert eps[0] == pytest.approx(1e-12) and eps[-1] == pytest.approx(1e-2) and len(eps) == 11
    bp = [k for m, k in s if m == "backprojection" and "upsample" in k]
    assert len(bp) == 5 * 4 * 2 and {k["upsample"] for k in bp} == {1, 2, 4, 8, 16}
    assert {k["interp"] for k in bp} == {"linear", "cubic", "lagrange", "lanczos"}
    pfa = [k for m, k in s if m == "pfa" and "oversample" in k]
    assert {k["oversample"] for k in pfa} == {1.25, 1.5, 2.0, 3.0} and {k["kernel"] for k in pfa} == {"kaiser", "linear"}
    assert sum(k.get("window") == "taylor" for _, k in s) == 3


def test_reference_subgrid_pixels_are_grid_pixels(ph):
    grid = ph.acquisition.grid
    sub, rs, cs, cost = accuracy.reference_grid(ph, grid, max_cost=cost_of(ph) / 10)
    assert cost == pytest.approx(cost_of(ph))
    assert sub.nx < grid.nx and sub.nx * sub.ny * ph.data.size <= cost_of(ph) / 10
    np.testing.assert_allclose(sub.x, grid.x[cs], atol=1e-12)
    np.testing.assert_allclose(sub.y, grid.y[rs], atol=1e-12)
    # strided over the whole image: first and last sampled pixels lie within one stride of the edges
    stride = cs[1] - cs[0]
    assert stride == 4 and cs[0] < stride and cs[-1] >= grid.nx - stride
    assert accuracy.reference_grid(ph, grid, max_cost=cost_of(ph))[0] == grid


def cost_of(ph):
    g = ph.acquisition.grid
    return ph.data.size * g.nx * g.ny


def test_run_benchmark_errors_and_truth(ph):
    settings = [("nufft", {"eps": 1e-2}), ("nufft", {"eps": 1e-12}), ("pfa", {"width": 8, "oversample": 2.0}),
                ("backprojection", {"upsample": 16, "interp": "cubic", "precision": "float64"}),
                ("nufft", {"window": "taylor"})]
    res = bm.run_benchmark(ph, repeat=1, settings=settings)
    rows = {(r.method, tuple(sorted(r.knobs.items()))): r for r in res.rows}
    direct = [r for r in res.rows if r.method == "direct" and r.knobs["window"] == "none"][0]
    assert direct.error == 0.0
    coarse = rows[("nufft", (("eps", 1e-2),))]
    fine = rows[("nufft", (("eps", 1e-12),))]
    assert fine.error < 1e-10 < coarse.error < 1e-1
    assert rows[("pfa", (("oversample", 2.0), ("width", 8)))].error < 1e-6
    assert rows[("backprojection", (("interp", "cubic"), ("precision", "float64"), ("upsample", 16)))].error < 1e-3
    # windowed image measured against the windowed reference, not the unwindowed one
    assert rows[("nufft", (("window", "taylor"),))].error < 1e-8
    # unit points at pixel centres: matched-filter peaks are 1 up to the other target's sidelobes;
    # an exact-to-1e-12 image has the reference's truth error
    assert fine.error_truth < 0.1
    assert fine.error_truth == pytest.approx(direct.error_truth, abs=1e-9)
    assert all(r.seconds > 0 and r.compile_s >= 0 for r in res.rows)
    assert all(r.peak_mb > 0 for r in res.rows if r.method != "direct")
    assert "peak amplitudes" in " ".join(res.notes)


def test_subgrid_reference_is_said_and_used(ph):
    res = bm.run_benchmark(ph, methods=("nufft",), repeat=1, settings=[("nufft", {"eps": 1e-12})],
                           max_reference_cost=cost_of(ph) / 4, memory=False)
    assert res.reference_grid.nx < res.grid.nx
    assert "sub-grid" in res.notes[0]
    assert res.rows[0].error < 1e-10


def test_csv_png_and_table(ph, tmp_path):
    res = bm.run_benchmark(ph, repeat=1, settings=[("nufft", {"eps": 1e-3}), ("pfa", {"kernel": "linear"})],
                           memory=False)
    path = bm.write_csv(res, tmp_path / "error_vs_time.csv")
    lines = path.read_text().splitlines()
    assert lines[0].startswith("# reference")
    rows = list(csv.DictReader(line for line in lines if not line.startswith("#")))
    assert tuple(rows[0]) == bm.CSV_COLUMNS and len(rows) == 3
    assert float(rows[1]["error"]) == pytest.approx(res.rows[1].error, rel=1e-5)
    png = plot_benchmark(res, tmp_path / "error_vs_time.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    table = bm.format_table(res)
    assert "nufft" in table and "eps=0.001" in table


def test_regularizer_sweep_rows(ph):
    rows = bm.regularizer_sweep(ph, "ptv", grid=ph.acquisition.grid, iters=(1, 4))
    assert [r.knobs["iters"] for r in rows] == [1, 4]
    assert all(np.isnan(r.error) and np.isfinite(r.error_truth) for r in rows)
    assert rows[1].error_truth < rows[0].error_truth  # more iterations come closer to the truth


def test_cli_bench(write_config, tmp_path):
    cfg = write_config(_farfield_cfg())
    out = tmp_path / "bench"
    res = CliRunner().invoke(cli, ["bench", str(cfg), "-o", str(out), "--methods", "direct,nufft",
                                   "--repeat", "1", "--windows", "none", "--no-memory"])
    assert res.exit_code == 0, res.output
    rows = list(csv.DictReader(ln for ln in (out / "error_vs_time.csv").read_text().splitlines()
                               if not ln.startswith("#")))
    assert len(rows) == 1 + 11
    assert min(float(r["error"]) for r in rows if r["method"] == "nufft") < 1e-10
    assert (out / "error_vs_time.png").exists()
    assert "reference: exact matched filter" in res.stdout


def test_cli_bench_bad_method_is_one_line(write_config, tmp_path):
    res = CliRunner().invoke(cli, ["bench", str(write_config(_farfield_cfg())), "-o", str(tmp_path / "b"),
                                   "--methods", "fft"])
    assert res.exit_code == 2
    assert res.stderr.strip().splitlines() == ["error: unknown method 'fft'; choose from direct, nufft, pfa, "
                                               "backprojection, ffbp, subimage"]


@pytest.mark.gotcha
def test_gotcha_bench_on_a_subgrid():
    files = GOTCHA_FILES
    ph = bm.load_input(files[:1])
    res = bm.run_benchmark(ph, repeat=1, extent=4.0, settings=[("nufft", {"eps": 1e-6}),
                                                              ("backprojection", {"upsample": 8})],
                           memory=False)
    errs = {r.method: r.error for r in res.rows}
    assert errs["direct"] == 0.0
    assert errs["backprojection"] < 1e-2  # spherical and exact up to interpolation
    assert np.isfinite(errs["nufft"])  # far-field model error only (GOTCHA r0 ~ 10 km)


def test_refusing_method_is_a_row_not_a_crash(write_config):
    cfg = _farfield_cfg()
    cfg["frequencies"] = {"center_frequency_ghz": 10.0, "bandwidth_mhz": 0.0, "count": 1}
    ph = bm.load_input(write_config(cfg))
    res = bm.run_benchmark(ph, repeat=1, settings=[("backprojection", {"upsample": 2}), ("nufft", {"eps": 1e-12})],
                           memory=False)
    bp = [r for r in res.rows if r.method == "backprojection"][0]
    assert np.isnan(bp.error) and bp.warnings[0].startswith("refused: backprojection needs at least two")
    assert [r for r in res.rows if r.method == "nufft"][0].error < 1e-10
