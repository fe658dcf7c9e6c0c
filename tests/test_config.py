"""Every validation rule of the YAML loader: exit code 2, one line naming the key."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from click.testing import CliRunner

import sarcli
from sarcli.cli.main import cli
from sarcli.errors import AliasingWarning, ConfigError

from .conftest import CONFIGS, small_config


def _run_bad(write_config, tmp_path, cfg):
    path = write_config(cfg)
    out = tmp_path / "ph.h5"
    res = CliRunner().invoke(cli, ["simulate", str(path), "-o", str(out)])
    return res, out


def _with(path, value):
    cfg = small_config()
    node = cfg
    keys = path.split(".")
    for k in keys[:-1]:
        node = node[k]
    if value is KeyError:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return cfg


BAD = [
    # (key path, value, text the message must contain)
    ("frequencies.bandwidth_mhz", -5.0, "frequencies.bandwidth_mhz"),
    ("frequencies.center_frequency_ghz", 1.0e10, "looks like Hz"),
    ("frequencies.bandwidth_mhz", 6.0e8, "looks like Hz"),
    ("frequencies.count", 0, "frequencies.count"),
    ("frequencies.count", 12.5, "frequencies.count"),
    ("frequencies.count", "many", "frequencies.count"),
    ("frequencies.center_frequency_ghz", KeyError, "frequencies.center_frequency_ghz"),
    ("elevation_deg", 90.0, "elevation_deg"),
    ("elevation_deg", 95.0, "elevation_deg"),
    ("elevation_deg", -10.0, "elevation_deg"),
    ("elevation_deg", "thirty", "elevation_deg"),
    ("image.pixels", 63, "odd"),
    ("image.pixels", 1, "image.pixels"),
    ("image.half_width_m", -1.0, "image.half_width_m"),
    ("image.half_width_m", KeyError, "image.half_width_m"),
    ("azimuths.count", -3, "azimuths.count"),
    ("azimuths.extent_deg", 400.0, "azimuths.extent_deg"),
    ("azimuths.extent_deg", KeyError, "azimuths.extent_deg"),
    ("geometry.path", "zigzag", "geometry.path"),
    ("geometry.standoff_range_m", 0.0, "geometry.standoff_range_m"),
    ("model", "curved", "model"),
    ("scene.points", [{"position_m": [0, 0, 0, 0]}], "position_m"),
    ("scene.points", [{"position_m": [0, 0], "amplitude": "big"}], "amplitude"),
]


@pytest.mark.parametrize("key,value,needle", BAD, ids=[f"{k}={v}" for k, v, _ in BAD])
def test_bad_values_exit_2_with_one_line(write_config, tmp_path, key, value, needle):
    res, out = _run_bad(write_config, tmp_path, _with(key, value))
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.strip().splitlines() if ln.startswith("error")]
    assert len(lines) == 1, res.output
    assert needle in lines[0]
    assert "acq.yaml" in lines[0]
    assert "Traceback" not in res.output
    assert not out.exists()


def test_unknown_key_suggests_closest(write_config, tmp_path):
    cfg = small_config()
    cfg["elevation_dgr"] = cfg.pop("elevation_deg")
    res, _ = _run_bad(write_config, tmp_path, cfg)
    assert res.exit_code == 2
    assert "elevation_dgr" in res.output and "did you mean 'elevation_deg'" in res.output
    cfg = small_config()
    cfg["frequencies"]["bandwith_mhz"] = cfg["frequencies"].pop("bandwidth_mhz")
    res, _ = _run_bad(write_config, tmp_path, cfg)
    assert res.exit_code == 2 and "frequencies.bandwith_mhz" in res.output and "bandwidth_mhz" in res.output


def test_missing_section(write_config, tmp_path):
    res, _ = _run_bad(write_config, tmp_path, small_config(azimuths=None))
    assert res.exit_code == 2 and "'azimuths'" in res.output and "missing" in res.output


def test_wrong_type_section_and_bad_yaml(write_config, tmp_path):
    res, _ = _run_bad(write_config, tmp_path, small_config(frequencies=[1, 2, 3]))
    assert res.exit_code == 2 and "frequencies" in res.output
    path = write_config("frequencies: {center_frequency_ghz: 10\n  bad: [", name="broken.yaml")
    res = CliRunner().invoke(cli, ["simulate", str(path), "-o", str(tmp_path / "x.h5")])
    assert res.exit_code == 2 and "broken.yaml" in res.output and "YAML" in res.output
    res = CliRunner().invoke(cli, ["simulate", str(tmp_path / "nope.yaml"), "-o", str(tmp_path / "x.h5")])
    assert res.exit_code == 2 and "nope.yaml" in res.output


def test_spherical_needs_path(write_config, tmp_path):
    cfg = small_config(geometry={"path": "farfield"}, model="spherical")
    res, _ = _run_bad(write_config, tmp_path, cfg)
    assert res.exit_code == 2 and "model" in res.output and "flight path" in res.output


def test_units_converted_once(write_config):
    acq = sarcli.load_acquisition(write_config(small_config()))
    f = acq.frequency_hz
    assert f.size == 64 and np.isclose(f.max() - f.min(), 600e6) and np.isclose(f.mean(), 10e9)
    assert np.allclose(np.degrees(acq.elevation_rad), 30.0)
    assert np.isclose(np.degrees(np.ptp(acq.azimuth_rad)), 3.0)
    assert acq.grid.nx == 64 and np.isclose(acq.grid.dx, 8.0 / 64)


def test_explicit_lists_and_full_circle(write_config):
    cfg = small_config(frequencies={"list_ghz": [9.9, 10.0, 10.1]},
                       azimuths={"list_deg": [10, 11, 12.5]})
    with pytest.warns(AliasingWarning):  # 3 frequencies, 3 looks: a tiny alias-free scene
        acq = sarcli.load_acquisition(write_config(cfg))
    assert np.allclose(acq.frequency_hz, [9.9e9, 10e9, 10.1e9])
    assert np.allclose(np.degrees(acq.azimuth_rad), [10, 11, 12.5])
    cfg = small_config(azimuths={"full_circle": True, "count": 8})
    with pytest.warns(AliasingWarning, match="cross-range 0.0107 m"):
        acq = sarcli.load_acquisition(write_config(cfg))
    assert np.isclose(np.degrees(acq.total_aperture_rad()), 360.0)


def test_geometry_paths(write_config):
    for path in ("circle", "line"):
        acq = sarcli.load_acquisition(write_config(small_config(geometry={"path": path, "standoff_range_m": 5000.0})))
        assert np.degrees(np.ptp(acq.azimuth_rad)) == pytest.approx(3.0)
        # the look directions recomputed from the antenna positions reproduce the requested azimuths
        assert np.allclose(np.degrees(acq.azimuth_rad), np.linspace(48.5, 51.5, 32), atol=1e-9)
        assert np.isclose(acq.range_to_center_m[16], 5000.0, rtol=1e-3)
    pos = [[-5000.0, float(y), 3000.0] for y in np.linspace(-100, 100, 5)]
    with pytest.warns(AliasingWarning):  # five pulses over 2.3°: cross-range radius 0.85 m
        acq = sarcli.load_acquisition(write_config(small_config(geometry={"path": "positions", "antenna_position_m": pos},
                                                            azimuths={"center_deg": 0, "extent_deg": 1, "count": 5})))
    assert acq.n_pulses == 5 and np.allclose(acq.antenna_position_m, pos)


def test_derived_grid_and_alias_warning(write_config):
    cfg = small_config(image=None)
    acq = sarcli.load_acquisition(write_config(cfg))
    rho = min(acq.resolutions())
    assert np.isclose(acq.grid.dx, rho / 2)  # default oversampling 2
    # scene reaches |y| = 1 m, |x| = 1.5 m: extent = scene + 4 range cells along the range direction and
    # 4 cross-range cells across it (an ellipse's half-extents in x and y), far below the alias-free radius
    rho_r, rho_cr = acq.resolutions()
    th = float(np.angle(np.mean(np.exp(1j * acq.azimuth_rad))))
    hx = 4 * np.hypot(rho_r * np.cos(th), rho_cr * np.sin(th))
    hy = 4 * np.hypot(rho_r * np.sin(th), rho_cr * np.cos(th))
    assert acq.grid.extent[0] / 2 == pytest.approx(max(1.5 + hx, 1.0 + hy), abs=acq.grid.dx)
    assert acq.grid.extent[0] / 2 > 1.5 + 4 * rho + acq.grid.dx  # not the finest cell alone
    cfg = small_config(scene={"points": [{"position_m": [60.0, 0.0]}]})
    with pytest.warns(AliasingWarning, match=r"60 m .* alias-free radius is"):
        sarcli.load_acquisition(write_config(cfg))


@pytest.mark.parametrize("path, center_deg", [("line", 90.0), ("line", 50.0), ("circle", 0.0), ("circle", 130.0)])
def test_derived_grid_keeps_cells_around_every_point(write_config, path, center_deg):
    """A Ku-band collection at 8 km over 3 degrees, five points and a disk phantom (the derived grid
    must not put a corner target 0.56 m, under five range cells, from the edge): every point keeps
    POINT_MARGIN_CELLS range cells along the range direction and as many cross-range cells across it."""
    from sarcli.io.config import POINT_MARGIN_CELLS
    from sarcli.io.scene_spec import point_targets

    pts = [[0.0, 0.0], [5.0, 5.0], [-5.0, 5.0], [5.0, -5.0], [-6.0, -4.0]]
    cfg = small_config(image=None, frequencies={"center_frequency_ghz": 16.0, "bandwidth_mhz": 1500.0, "count": 256},
                       azimuths={"center_deg": center_deg, "extent_deg": 3.0, "count": 200},
                       geometry={"path": path, "standoff_range_m": 8000.0},
                       scene={"points": [{"position_m": q} for q in pts], "phantom": {"name": "disks", "half_width_m": 4.0}})
    acq = sarcli.load_acquisition(write_config(cfg))
    g = acq.grid
    rho_r, rho_cr = acq.resolutions()
    assert POINT_MARGIN_CELLS >= 3 and rho_r < 0.12  # a few cells of a fine range resolution
    th = np.radians(center_deg)
    k = POINT_MARGIN_CELLS
    hx = k * np.hypot(rho_r * np.cos(th), rho_cr * np.sin(th))
    hy = k * np.hypot(rho_r * np.sin(th), rho_cr * np.cos(th))
    x0, x1 = g.x[0] - g.dx / 2, g.x[-1] + g.dx / 2
    y0, y1 = g.y[0] - g.dy / 2, g.y[-1] + g.dy / 2
    for x, y, _ in point_targets(acq.scene)[0]:
        assert min(x - x0, x1 - x) >= hx - 1e-9 and min(y - y0, y1 - y) >= hy - 1e-9, (x, y, g.as_dict())
    # and not much more: the grid is the farthest point plus its margin, rounded up to even pixels
    assert g.extent[0] / 2 <= max(6.0 + hx, 5.0 + hy) + 2 * g.dx


def test_shipped_configs_load():
    for name in ("three-points", "shepp-logan", "circular-360", "narrowband"):
        acq = sarcli.load_acquisition(CONFIGS / f"{name}.yaml")
        assert acq.n_pulses > 0 and acq.grid.nx % 2 == 0
    acq = sarcli.load_acquisition(CONFIGS / "narrowband.yaml")
    assert acq.bandwidth_hz / acq.center_frequency_hz == pytest.approx(1e-3)


def test_config_error_is_value_error():
    with pytest.raises(ValueError):
        sarcli.parse_acquisition({"frequencies": {}, "azimuths": {}}, source="x.yaml")
    with pytest.raises(ConfigError, match="x.yaml: key 'frequencies.center_frequency_ghz'"):
        sarcli.parse_acquisition(copy.deepcopy({"frequencies": {}, "azimuths": {}}), source="x.yaml")


# -- the strict YAML loader, the overwrite guard, the memory check, reserved outputs --

@pytest.mark.parametrize("text,match", [
    ("a: 1\nb: 2\na: 3\n", r"line 3: duplicate key 'a' \(lines 1 and 3\)"),
    ("a: {b: 1, b: 2}\n", "duplicate key 'b'"),
    ("a: &x [1, 2]\nb: *x\n", "anchor 'x' refused"),
    ("a: .nan\n", r"line 1: value '\.nan' is not a finite number"),
    ("a: [1.0, -.inf]\n", "not a finite number"),
    ("a: " + "[" * 100 + "]" * 100, "nested deeper than 64"),
])
def test_strict_yaml_refuses(text, match):
    from sarcli._util.yamlsafe import load_yaml_text

    with pytest.raises(ConfigError, match=match):
        load_yaml_text(text, source="t.yaml")


def test_strict_yaml_reads_plain_yaml_and_short_repr_is_short():
    from sarcli._util.yamlsafe import load_yaml_text, short_repr

    assert load_yaml_text("a: [1, 2.5, x]\nb: {c: true}\n") == {"a": [1, 2.5, "x"], "b": {"c": True}}
    assert len(short_repr(list(range(10**6)))) <= 203


def test_huge_count_refused_before_allocation(tmp_path):
    from sarcli._util.resources import set_memory_limit

    cfg = {"frequencies": {"center_frequency_ghz": 10.0, "bandwidth_mhz": 600.0, "count": 10**12},
           "azimuths": {"center_deg": 0.0, "extent_deg": 3.0, "count": 8}}
    set_memory_limit(1 << 30)
    try:
        with pytest.raises(ConfigError, match=r"frequencies\.count.*needs about 29\.1 TiB.*limit 1 GiB"):
            sarcli.parse_acquisition(cfg)
    finally:
        set_memory_limit(None)


def test_parse_size():
    from sarcli._util.resources import parse_size
    from sarcli.errors import SarcliInputError

    assert parse_size("4G") == 4 << 30 and parse_size("512MiB") == 512 << 20 and parse_size("1.5 GB") == 3 << 29
    with pytest.raises(SarcliInputError):
        parse_size("lots")


def test_refuse_overwrite_links_and_inodes(tmp_path):
    import os

    from sarcli._util.guard import refuse_overwrite, same_file
    from sarcli.errors import SarcliInputError

    a = tmp_path / "a.h5"
    a.write_text("x")
    (tmp_path / "s.h5").symlink_to(a)
    os.link(a, tmp_path / "h.h5")
    for other in ("s.h5", "h.h5", "sub/../a.h5"):
        (tmp_path / "sub").mkdir(exist_ok=True)
        assert same_file(a, tmp_path / other)
        with pytest.raises(SarcliInputError, match="the same file"):
            refuse_overwrite([("input", a)], [("output", tmp_path / other)])
    refuse_overwrite([("input", a)], [("output", tmp_path / "new.h5")])  # a new name is fine


def test_reserved_output_is_released_and_atomic_write_commits(tmp_path):
    from sarcli._util.atomic import atomic_path, release_all, reserve

    out = tmp_path / "o.txt"
    tmp = reserve(out)
    assert not tmp.exists() and not out.exists()  # the temporary exists only while writing
    with atomic_path(out) as t:
        assert t == tmp
        t.write_text("done")
    assert out.read_text() == "done" and not tmp.exists()
    reserve(tmp_path / "never.txt")
    assert [p.name for p in release_all()] == [".never.txt.tmp-" + str(__import__("os").getpid())]
    assert not list(tmp_path.glob(".*tmp*"))


def test_temporaries_of_dead_processes_are_removed_by_the_next_writer(tmp_path):
    import os
    import subprocess

    from sarcli._util.atomic import atomic_path, remove_stale

    gone = subprocess.Popen(["true"])
    gone.wait()  # its process id no longer exists
    out = tmp_path / "o.h5"
    stale, live, mine = (tmp_path / f".o.h5.tmp-{pid}" for pid in (gone.pid, os.getppid(), os.getpid()))
    other = tmp_path / f".other.h5.tmp-{gone.pid}"
    for p in (stale, live, other):
        p.write_bytes(b"")
    assert remove_stale(out) == [stale]
    assert live.exists() and other.exists()  # a running writer's, and another output's
    stale.write_bytes(b"")
    with atomic_path(out) as t:
        assert t == mine and not stale.exists() and not t.exists()  # created by the writer itself
        t.write_text("done")
    assert out.read_text() == "done" and live.exists()
