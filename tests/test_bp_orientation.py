"""Backprojection's kernels on rows across the look direction: the transposed problem
(sarcli.formers.backprojection._setup.orient) gives the image of the exact matched filter, the adjoint
pair and the prepared backprojector as the untransposed one; and the pulse block's cache size reader."""

from __future__ import annotations

import numpy as np
import pytest

import sarcli.formers.backprojection._rows as bp_rows
import sarcli.formers.backprojection._setup as bp_setup
from sarcli._native.layout import BpGeo
from sarcli.core import geometry
from sarcli.core.collection import Collection
from sarcli.core.grid import Grid
from sarcli.formers.backprojection import (Backprojector, Setup, TilingInputs, backproject, pulse_contractions,
                                           reproject)
from sarcli.formers.backprojection._kernels import min_range
from sarcli.formers.backprojection._rows import FALLBACK_L2_BYTES, l2_cache_bytes
from sarcli.formers.options import BackprojectionOptions

# 16 m x 25.6 m of unequal pixels and unequal sides (a transposed shape or spacing mixed up fails),
# rows of whole 64-pixel tiles either way (equal tiling cost: the range step decides)
GRID = Grid(64, 128, 0.25, 0.2, 0.5, -1.0)
OPTS64 = BackprojectionOptions(precision="float64")


def _rotate(pos, quarter_turns):
    """Positions turned about z by ``quarter_turns`` x 90°."""
    out = np.array(pos, dtype=np.float64)
    for _ in range(quarter_turns % 4):
        out[:, 0], out[:, 1] = -out[:, 1].copy(), out[:, 0].copy()
    return out


def _case(look_along, P=64, M=64, r0=2e3, seed=0):
    """Spotlight data of six points, the antennas looking along x (azimuth near 0°) or y (near 90°)."""
    rng = np.random.default_rng(seed)
    el = np.radians(35.0)
    freq = 10e9 - 150e6 + np.arange(M) * 300e6 / (M - 1)
    az = np.radians(np.linspace(-2.0, 2.0, P))
    a = _rotate(geometry.antenna_positions_circle(az, el, r0), 0 if look_along == "x" else 1)
    r0s = np.linalg.norm(a, axis=1)
    pts = np.column_stack([rng.uniform(-7, 7, 6), rng.uniform(-6, 6, 6), np.zeros(6)])
    amps = rng.normal(size=6) + 1j * rng.normal(size=6)
    dr = geometry.differential_range(a, r0s, pts)
    k = 4 * np.pi * freq / geometry.C
    data = (amps[None, None, :] * np.exp(-1j * k[None, :, None] * dr[:, None, :])).sum(-1)
    return data, Collection(freq, a, r0s)


def _exact_mf(data, col, grid):
    from sarcli.formers.direct import direct_spherical

    return direct_spherical(data, col.frequency_hz, col.antenna_position_m, col.range_to_center_m, grid)


def _force(monkeypatch, transposed):
    """Make :class:`Setup` run the kernels transposed or not (square-enough pixels: equal tiling cost,
    so the range steps decide)."""
    monkeypatch.setattr(bp_setup, "row_steps", lambda a, b, grid: (1.0, 0.0) if transposed else (0.0, 1.0))


def _rel(f, ref):
    return float(np.linalg.norm(f - ref) / np.linalg.norm(ref))


@pytest.mark.parametrize("look_along,transposed", [("x", True), ("y", False)])
def test_rows_run_across_the_look_direction(look_along, transposed):
    data, col = _case(look_along)
    st = Setup(data.shape, col, GRID, 16, "cubic", "float64")
    assert st.transposed is transposed
    assert st.kernel_shape == (GRID.shape[::-1] if transposed else GRID.shape)
    # the planner prices the tiling the former runs
    o = TilingInputs(col.frequency_hz, col.antenna_position_m, None, GRID).orientation(16, "float64")
    assert o.transposed is transposed and o.tiling == st.tiling
    sx, sy = bp_rows.row_steps(col.antenna_position_m, col.antenna_position_m, GRID)
    assert (sx > sy) is transposed


def test_a_few_pulses_keep_the_grid_as_it_is():
    """The transposing copy is paid once a call: 64 pulses looking along x share it (13 lines a
    lane group saved each), 8 do not."""
    for pulses, transposed in ((64, True), (8, False)):
        data, col = _case("x", P=pulses)
        st = Setup(data.shape, col, GRID, 16, "cubic", "float32")
        assert st.transposed is transposed
        assert (st.orientation.lines < 1) is transposed   # the kernels' rows: across, or along the look


def test_tiling_cost_decides_before_the_range_step():
    """Pixels 4x finer along y, 60 m from the radar: rows along y take wider tiles (less work per
    pixel), so the kernels run along y though that is the look direction."""
    grid = Grid(64, 64, 0.4, 0.1)
    data, col = _case("y", r0=60.0)
    st = Setup(data.shape, col, grid, 16, "cubic", "float64")
    a = col.antenna_position_m
    sx, sy = bp_rows.row_steps(a, a, grid)
    assert sy > sx   # the range step alone would keep rows along x
    args = (min_range(a, grid), float(np.max(st.geo[BpGeo.KC])), float(np.max(st.geo[BpGeo.INV_BIN])))
    along_x, along_y = bp_rows.tiling(grid, *args), bp_rows.tiling(bp_rows.transposed_grid(grid), *args)
    assert along_y.cost < along_x.cost
    assert st.transposed and st.tiling == along_y


@pytest.mark.parametrize("lines,transposed", [(12.0, False), (20.0, True)])
def test_a_row_of_partial_tiles_against_the_lines(lines, transposed):
    """Rows of 128 pixels along the look (one 128-pixel tile, cost 8.23 / 8 = 1.0288) or of 120 across
    it (one tile of 120, eight lane groups: 8.23 / 7.5 = 1.0973): the 0.0686 between them is 13.7 lines
    at LINE_COST, so 12 lines along the look keep the rows and 20 turn them."""
    grid = Grid(128, 120, 0.25, 0.25)
    kc, inv_bin = 420.0, 68.0
    o = bp_rows.orient(grid, 1e5, kc, inv_bin, (lines / (2 * inv_bin), 0.0), 10**6, sample_bytes=8)
    assert o.transposed is transposed
    rows = bp_rows.tiling(grid, 1e5, kc, inv_bin)
    cols = bp_rows.tiling(bp_rows.transposed_grid(grid), 1e5, kc, inv_bin)
    assert (rows.width, cols.width) == (128, 120) and rows.model == cols.model == "quadratic"
    assert o.tiling == (cols if transposed else rows)
    along = bp_rows.row_cost(rows, 128) + bp_rows.LINE_COST * lines
    across = bp_rows.row_cost(cols, 120) + bp_rows.TRANSPOSE_COST / 10**6
    assert across - along == pytest.approx(8.23 / 7.5 - 8.23 / 8 - bp_rows.LINE_COST * lines, abs=1e-5)
    assert o.cost == pytest.approx(min(along, across))


@pytest.mark.parametrize("look_along", ["x", "y"])
def test_both_orientations_match_the_exact_matched_filter(monkeypatch, look_along):
    data, col = _case(look_along)
    ref = _exact_mf(data, col, GRID)
    imgs = {}
    for transposed in (False, True):
        _force(monkeypatch, transposed)
        assert Setup(data.shape, col, GRID, 16, "cubic", "float64").transposed is transposed
        imgs[transposed] = backproject(data, col, GRID, OPTS64)
    errs = [_rel(imgs[t], ref) for t in (False, True)]
    # measured: 3.3e-5 either way (the cubic interpolation's error), the two 5.9e-7 apart (the tiles'
    # range models and float32 weights differ with the orientation)
    assert max(errs) < 1e-4
    assert abs(errs[0] - errs[1]) < 1e-6
    assert _rel(imgs[True], imgs[False]) < 2e-6


@pytest.mark.parametrize("transposed", [False, True])
@pytest.mark.parametrize("precision,tol", [("float64", 1e-14), ("float32", 2e-6)])
def test_adjoint_pair_in_both_orientations(monkeypatch, transposed, precision, tol):
    rng = np.random.default_rng(3)
    data, col = _case("x", P=20)
    _force(monkeypatch, transposed)
    opts = BackprojectionOptions(upsample=3, interp="cubic", precision=precision)
    d = rng.normal(size=data.shape) + 1j * rng.normal(size=data.shape)
    f = rng.normal(size=GRID.shape) + 1j * rng.normal(size=GRID.shape)
    lhs = np.vdot(f, backproject(d, col, GRID, opts))
    rhs = np.vdot(reproject(f, col, GRID, opts), d)
    assert abs(lhs - rhs) / abs(lhs) < tol
    # the contractions are the same numbers gathered (pulse_contractions' definition)
    v = pulse_contractions(d, f, col, GRID, opts)
    ref = np.sum(np.conj(reproject(np.conj(f), col, GRID, opts)) * d, axis=1)
    assert np.max(np.abs(v - ref)) / np.max(np.abs(ref)) < 1e3 * tol


@pytest.mark.parametrize("look_along", ["x", "y"])
def test_prepared_backprojector_agrees_in_both_orientations(look_along):
    data, col = _case(look_along)
    bp = Backprojector(data, col, GRID, OPTS64)
    assert bp._st.transposed is (look_along == "x")
    img = backproject(data, col, GRID, OPTS64)
    # float64 rounding: one kernel call over all pulses sums in another order than one per block
    assert np.max(np.abs(bp.image() - img)) < 1e-12 * np.max(np.abs(img))
    g = np.random.default_rng(1).normal(size=GRID.shape) + 0j
    v = pulse_contractions(data, g, col, GRID, OPTS64)
    assert np.max(np.abs(bp.contract(g) - v)) < 1e-12 * np.max(np.abs(v))
    total = np.zeros(GRID.shape, complex)
    for _, re, im in bp.group_images([0, 17, data.shape[0]]):
        assert re.shape == GRID.shape
        total += re + 1j * im
    assert np.max(np.abs(total - img)) < 1e-12 * np.max(np.abs(img))


def _sysfs(tmp_path, entries):
    for name, (level, kind, size) in entries.items():
        d = tmp_path / name
        d.mkdir()
        (d / "level").write_text(f"{level}\n")
        (d / "type").write_text(f"{kind}\n")
        (d / "size").write_text(f"{size}\n")
    return tmp_path


def test_l2_cache_size_from_sysfs(tmp_path):
    root = _sysfs(tmp_path, {"index0": (1, "Data", "48K"), "index1": (1, "Instruction", "32K"),
                             "index2": (2, "Unified", "2048K"), "index3": (3, "Unified", "105M")})
    assert l2_cache_bytes(root, sysconf=None) == 2 << 20
    # no level-2 entry: sysconf's answer
    only_l1 = tmp_path / "l1"
    only_l1.mkdir()
    assert l2_cache_bytes(_sysfs(only_l1, {"index0": (1, "Data", "48K")}), sysconf=lambda name: 1 << 20) == 1 << 20


def test_l2_cache_size_falls_back_without_sysfs(tmp_path):
    missing = tmp_path / "nothing"
    assert l2_cache_bytes(missing, sysconf=lambda name: 1280 * 1024) == 1280 * 1024
    for sysconf in (None, lambda name: 0, lambda name: -1, lambda name: (_ for _ in ()).throw(ValueError(name))):
        assert l2_cache_bytes(missing, sysconf=sysconf) == FALLBACK_L2_BYTES
    bad = tmp_path / "bad"
    bad.mkdir()
    _sysfs(bad, {"index2": (2, "Unified", "lots")})
    assert l2_cache_bytes(bad, sysconf=None) == FALLBACK_L2_BYTES
