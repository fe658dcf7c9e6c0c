"""`sar quality` on crowded scenes: one peak per target, layover, close pairs, corner targets,
and the table saying what the JSON says."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from sarcli.analysis.quality import image_quality
from sarcli.cli.main import cli
from sarcli.core import geometry
from sarcli.core.grid import Grid
from sarcli.formers.formation import form_image
from sarcli.io.config import parse_acquisition
from sarcli.io.hdf5 import write_image, write_phase_history
from sarcli.simulation.simulator import simulate

EL_DEG, AZ_DEG = 35.0, 60.0
XI = np.array([math.cos(math.radians(AZ_DEG)), math.sin(math.radians(AZ_DEG))])  # range direction
PAIR = np.array([1.5, -2.0])
POINTS = [[0.0, 0.0, 0.0], [4.0, 4.0, 0.0], [-4.0, 4.0, 0.0], [4.0, -4.0, 0.0], [-4.0, -4.0, 0.0],
          [-2.0, 1.0, 2.0],                                   # 2 m off the image plane
          [*PAIR, 0.0], [*(PAIR + 0.6 * XI), 0.0]]            # 1.6 range cells apart


def _cfg(points=POINTS):
    """Ku band, 500 MHz, 5 deg at 8 km: the collection of a user's first scene, scaled down."""
    return {"name": "ku-small", "model": "spherical",
            "frequencies": {"center_frequency_ghz": 16.0, "bandwidth_mhz": 500.0, "count": 64},
            "elevation_deg": EL_DEG, "azimuths": {"center_deg": AZ_DEG, "extent_deg": 5.0, "count": 96},
            "geometry": {"path": "circle", "standoff_range_m": 8000.0},
            "scene": {"points": [{"position_m": p, "amplitude": 1.0} for p in points]}}


@pytest.fixture(scope="module")
def scene():
    ph = simulate(parse_acquisition(_cfg()), seed=0, snr_db=None)
    img = form_image(ph, method="direct")
    return ph, img


def _true_peak(ph, near, rho):
    """The image's actual peak near ``near``: the exact matched filter on a grid of 1/40 cell."""
    h = min(rho) / 40
    g = Grid.square(20 * h, 40, center=tuple(near))
    fine = form_image(ph, method="direct", grid=g)
    r, c = np.unravel_index(np.argmax(np.abs(fine.image)), fine.image.shape)
    return np.array([fine.x_m[c], fine.y_m[r]]), h


def _cells(d, rho):
    return math.hypot(float(np.dot(d, XI)) / rho[0], float(XI[0] * d[1] - XI[1] * d[0]) / rho[1])


def test_every_target_matched_to_its_own_peak_within_a_tenth_of_a_cell(scene):
    ph, img = scene
    res = image_quality(img, ph)
    rho = (res[0]["predicted"]["range"]["cell_m"], res[0]["predicted"]["cross_range"]["cell_m"])
    assert [r["name"] for r in res] == [f"T{i + 1}" for i in range(len(POINTS))]
    found = [(r["measured"]["x_m"], r["measured"]["y_m"]) for r in res]
    assert len({(round(x, 6), round(y, 6)) for x, y in found}) == len(found)  # no peak used twice
    worst = 0.0
    for r, xy in zip(res, found):
        true, h = _true_peak(ph, xy, rho)
        worst = max(worst, _cells(np.array(xy) - true, rho))
        assert _cells(np.array(xy) - np.array(r["expected_at_m"]), rho) < 0.1 or r["status"] == "close"
    assert worst < 0.1, worst


def test_off_plane_point_lies_over_toward_the_radar(scene):
    ph, img = scene
    r = image_quality(img, ph)[5]
    shift = np.array(r["layover_m"])
    # the textbook layover: z tan(elevation) toward the radar, i.e. against the look direction
    assert np.dot(shift, XI) == pytest.approx(-2.0 * math.tan(math.radians(EL_DEG)), rel=0.01)
    assert abs(XI[0] * shift[1] - XI[1] * shift[0]) < 0.01
    rho = (r["predicted"]["range"]["cell_m"], r["predicted"]["cross_range"]["cell_m"])
    measured = np.array([r["measured"]["x_m"], r["measured"]["y_m"]])
    assert _cells(measured - np.array(r["expected_at_m"]), rho) < 0.1
    assert r["status"] == "ok"


def test_close_pair_is_flagged_and_each_has_its_own_peak(scene):
    ph, img = scene
    res = image_quality(img, ph)
    a, b = res[6], res[7]
    assert a["status"] == b["status"] == "close"
    assert (a["neighbour"], b["neighbour"]) == ("T8", "T7")
    assert a["neighbour_cells"] == pytest.approx(0.6 / a["predicted"]["range"]["cell_m"], rel=1e-6)
    sep = math.hypot(a["measured"]["x_m"] - b["measured"]["x_m"], a["measured"]["y_m"] - b["measured"]["y_m"])
    assert sep == pytest.approx(0.6, abs=0.1)
    for r in (a, b):  # cut figures would cross the neighbour's main lobe
        assert r["measured"]["range"]["pslr_db"] is None and r["measured"]["cross_range"]["irw_m"] is None
    for r in res[:6]:
        assert r["status"] == "ok" and r["measured"]["range"]["pslr_db"] < -12


def test_corner_targets_keep_their_sidelobes_on_the_derived_grid(scene):
    ph, img = scene
    rho = geometry.resolutions(ph.acquisition.frequency_hz, ph.acquisition.azimuth_rad,
                               ph.acquisition.elevation_rad)
    th = math.radians(AZ_DEG)
    hx = 4 * math.hypot(rho[0] * math.cos(th), rho[1] * math.sin(th))
    assert img.x_m[-1] + img.grid.dx / 2 >= 4.0 + hx - 1e-9
    assert img.x_m[-1] - 4.0 > 4 * min(rho) + img.grid.dx  # more than the cross-range margin alone
    for r in image_quality(img, ph)[1:5]:
        assert r["measured"]["range"]["pslr_db"] == pytest.approx(r["predicted"]["range"]["pslr_db"], abs=0.5)


def test_unresolved_targets_do_not_share_a_peak():
    pts = [[0.0, 0.0, 0.0], [0.05, 0.0, 0.0]]
    ph = simulate(parse_acquisition(_cfg(pts)), seed=0, snr_db=None)
    img = form_image(ph, method="direct", grid=Grid.square(2.0, 64))
    res = image_quality(img, ph)
    assert sorted(r["status"] for r in res) == ["close", "no peak"]
    assert [r["measured"] is None for r in res].count(True) == 1


def test_table_says_what_the_json_says(scene, tmp_path):
    ph, img = scene
    write_phase_history(tmp_path / "ph.h5", ph)
    write_image(tmp_path / "img.h5", img)
    runner = CliRunner()
    out = json.loads(runner.invoke(cli, ["quality", str(tmp_path / "img.h5"), "--ph", str(tmp_path / "ph.h5"),
                                         "--json"]).output)
    table = runner.invoke(cli, ["quality", str(tmp_path / "img.h5"), "--ph", str(tmp_path / "ph.h5")]).output
    rows = {line.split()[0]: line.split() for line in table.splitlines() if line[:1] == "T" and line.split()[0][1:].isdigit()}
    assert set(rows) == {r["name"] for r in out}
    for r in out:
        row = rows[r["name"]]
        assert row[1] == r["status"]
        m = r["measured"]
        assert [float(v) for v in row[2:8]] == pytest.approx(
            [*r["expected_at_m"], m["x_m"], m["y_m"], m["peak_position_error_m"], m["peak_magnitude"]], abs=6e-4)
        for d in ("range", "cross_range"):  # the cut's own peak is the measured one
            assert abs(m[d]["peak_position"]) < 0.1 * m[d]["resolution_m"]
    assert "T6: 2 m off the image plane" in table and "T7: close to T8" in table
