"""What the tool says agrees with what it does: the plan table, advice, help, `sar info` on a
SICD, and outputs in a folder that does not exist."""

from __future__ import annotations

import json
import math
import re
import warnings

import numpy as np
import pytest
from click.testing import CliRunner

from sarcli.cli.main import cli
from sarcli.cli.plan import STATUS_LEGEND, status_of, table
from sarcli.core import geometry
from sarcli.core.grid import Grid
from sarcli.core.types import Image
from sarcli.errors import DefocusWarning
from sarcli.formers.formation import METHODS, form_image
from sarcli.formers.planning.planner import SAFETY, Candidate

from .conftest import REPO
from .test_planner import spherical


def test_plan_status_words_say_what_they_mean():
    tol = 1e-3
    words = [status_of(Candidate("ffbp", {}, e, 1.0, 1.0), tol, SAFETY)
             for e in (4e-4, 5.2e-4, 8.0e-4, 1.2e-3, float("nan"))]
    assert words == ["safe", "meets", "meets", "misses", "unknown"]  # 5.2e-4 and 8.0e-4 meet 1e-3; nan: no model
    assert {w for w, _ in STATUS_LEGEND} == {"safe", "meets", "misses", "unknown"}


def test_plan_table_fits_a_terminal_and_keeps_every_knob():
    long = {"base": 16, "merge": 4, "os_range": 1.5, "os_angle": 1.5, "interp": "optimal", "upsample": 1.5,
            "tolerance": 1e-3}
    cands = [Candidate("ffbp", long, 4e-4, 0.02, 8e6, "3 stages"), Candidate("backprojection", {"upsample": 32},
                                                                            8e-4, 0.7, 1.8e7)]
    lines = table(cands, cands[0], 1e-3, SAFETY, width=80)
    assert max(len(line) for line in lines) <= 80
    text = " ".join(lines)
    for k, v in long.items():
        if k != "tolerance":
            assert f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" in text
    assert re.search(r"ffbp .* safe +<- auto", lines[1]) and "meets" in text and "TOL/2" in text


def test_cli_plan_json_carries_the_status(tmp_path):
    from sarcli.io.hdf5 import write_phase_history

    write_phase_history(tmp_path / "ph.h5", spherical(P=32))
    res = CliRunner().invoke(cli, ["plan", str(tmp_path / "ph.h5"), "--tolerance", "1e-3", "--json"])
    doc = json.loads(res.output)
    for c in doc["candidates"]:
        assert c["status"] == status_of(Candidate(c["method"], {}, c["predicted_error"], 0, 0), 1e-3, SAFETY)
    assert set(doc["status_legend"]) == {"safe", "meets", "misses", "unknown"}


def test_defocus_advice_names_what_auto_picks():
    ph = spherical(r0=2e3, P=32)
    with pytest.warns(DefocusWarning) as rec:
        form_image(ph, "nufft", grid=Grid.square(12.0, 24))
    msg = str(rec[0].message)
    assert "auto" in msg and all(m in msg for m in ("ffbp", "backprojection", "subimage", "direct"))


def test_one_defocus_threshold_named_once():
    text = (REPO / "docs" / "config.md").read_text()
    said = re.findall(r"DEFOCUS_WARN_RAD` = ([0-9.]+) rad", text)
    assert said and all(float(v) == geometry.DEFOCUS_WARN_RAD for v in said)
    assert not re.search(r"more than 0\.25 rad", text)


def test_help_lists_every_method_and_no_latex_label():
    out = CliRunner().invoke(cli, ["--help"]).output
    block = out[out.index("  form-image"):]
    line = " ".join(block[:block.index("\n  import")].split())  # the entry, however click wraps it
    for m in METHODS:
        assert m in line
    for cmd in ("psf", "form-image", "quality", "plan"):
        text = CliRunner().invoke(cli, [cmd, "--help"]).output
        assert "main-theorem" not in text and "Theorem main" not in text
    assert "main-theorem" not in out


@pytest.mark.parametrize("typed, meant", [("simulat", "simulate"), ("form-imag", "form-image"),
                                          ("qualty", "quality"), ("autofocs", "autofocus")])
def test_a_mistyped_command_is_one_line_naming_the_closest(typed, meant):
    res = CliRunner().invoke(cli, [typed, "x.yaml"])
    assert res.exit_code == 2 and res.output.count("\n") == 1, res.output
    assert f"No such command '{typed}'. Did you mean '{meant}'?" in res.output
    res = CliRunner().invoke(cli, ["zzzz"])
    assert res.exit_code == 2 and "Did you mean" not in res.output and "No such command 'zzzz'." in res.output
    res = CliRunner().invoke(cli, ["import", "gotch", "x.mat"])
    assert res.exit_code == 2 and "No such command 'gotch'. Did you mean 'gotcha'?" in res.output, res.output


def test_info_says_which_resolution_it_prints_and_the_definition_holds(write_config):
    """`sar info`'s resolution is c/(2B cos el), the first null; the predicted -3 dB width of an
    unwindowed cut (what `sar quality` calls IRW) is IRW_FACTOR_UNIFORM of it, as the line says."""
    from sarcli.analysis.psf import predicted_ipr
    from sarcli.core.windows import IRW_FACTOR_UNIFORM
    from sarcli.io.config import load_acquisition

    path = REPO / "configs" / "three-points.yaml"
    doc = json.loads(CliRunner().invoke(cli, ["info", str(path), "--json"]).output)
    f_lo, f_hi = doc["band_hz"]
    assert doc["resolution_m"]["range"] == pytest.approx(geometry.C / (2 * (f_hi - f_lo) * math.cos(math.radians(30))))
    assert "c/(2 B cos(elevation))" in doc["resolution_definition"]
    assert f"is {IRW_FACTOR_UNIFORM:.3f} of it without a window" in doc["resolution_definition"]
    irw = predicted_ipr(load_acquisition(path))["range"]["irw_m"]
    assert irw / doc["resolution_m"]["range"] == pytest.approx(IRW_FACTOR_UNIFORM, rel=0.01)
    lines = CliRunner().invoke(cli, ["info", str(path)]).output.splitlines()
    at = next(i for i, line in enumerate(lines) if line.strip().startswith("resolution_m:"))
    assert lines[at + 1].strip().startswith("resolution_definition: range c/(2 B cos(elevation))")


def test_info_on_a_sicd_reads_its_metadata_and_shows_no_dependency_warning(tmp_path):
    from sarcli.io.sicd import write_sicd

    g = Grid.square(4.0, 32)
    img = Image(np.ones(g.shape, np.complex64), g.x, g.y, method="ffbp", parameters={"window": "none"},
                runtime_s=12.5, attrs={"scene_center_lat_deg": 34.95, "scene_center_lon_deg": -106.52})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        write_sicd(img, tmp_path / "a.sicd")
    res = CliRunner().invoke(cli, ["info", str(tmp_path / "a.sicd"), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert doc["method"] == "ffbp" and doc["runtime_s"] == 12.5 and doc["warnings"] == []
    text = CliRunner().invoke(cli, ["info", str(tmp_path / "a.sicd")]).output
    assert "deprecated" not in text and "warning" not in text


def test_sicd_from_another_tool_has_an_unknown_runtime():
    from lxml import etree

    from sarcli.io.sicd import _image_metadata

    xml = etree.fromstring(b"<SICD><ImageFormation><ImageFormAlgo>PFA</ImageFormAlgo></ImageFormation></SICD>")
    method, runtime, params = _image_metadata(xml)
    assert method == "pfa" and math.isnan(runtime) and params == {}


@pytest.mark.parametrize("cmd", [["simulate", "{cfg}", "-o", "{out}"], ["export", "{img}", "-o", "{out}"]])
def test_output_in_a_missing_folder_is_one_line(tmp_path, write_config, cmd):
    from sarcli.io.hdf5 import write_image

    from .conftest import small_config

    cfg = write_config(small_config())
    g = Grid.square(4.0, 16)
    write_image(tmp_path / "img.h5", Image(np.ones(g.shape, np.complex64), g.x, g.y, method="t"))
    out = tmp_path / "tpyo" / ("x.h5" if cmd[0] == "simulate" else "x.png")
    args = [a.format(cfg=cfg, img=tmp_path / "img.h5", out=out) for a in cmd]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 2
    lines = [l for l in res.output.splitlines() if l.strip()]
    assert len(lines) == 1 and "tpyo" in lines[0] and "does not exist" in lines[0]
    assert not (tmp_path / "tpyo").exists()


def test_info_does_not_warn_about_a_grid_clamped_to_the_alias_free_radius(tmp_path, write_config):
    """The derived grid stops at the alias-free radius, rounded up to an even pixel count: no
    warning that it exceeds the radius (the scene itself reaching beyond is the simulator's warning)."""
    from .test_quality_matching import _cfg

    cfg = _cfg([[0.0, 0.0, 0.0], [7.0, 7.0, 0.0]])  # 96 pulses over 5 deg: cross-range radius 6 m
    path = write_config(cfg)
    res = CliRunner().invoke(cli, ["simulate", str(path), "-o", str(tmp_path / "ph.h5")])
    assert res.exit_code == 0 and "AliasingWarning" in res.output, res.output
    doc = json.loads(CliRunner().invoke(cli, ["info", str(tmp_path / "ph.h5"), "--json"]).output)
    assert max(doc["grid_extent_m"]) / 2 >= min(doc["alias_free_radius_m"].values())
    assert not any("exceeds the alias-free radius" in w for w in doc["warnings"])


def test_a_folder_output_is_created_only_under_an_existing_parent(tmp_path):
    from sarcli.cli.options import output_folder
    from sarcli.errors import SarcliInputError

    assert output_folder(tmp_path / "new").is_dir()
    with pytest.raises(SarcliInputError, match="tpyo.* does not exist"):
        output_folder(tmp_path / "tpyo" / "new")
    assert not (tmp_path / "tpyo").exists()


@pytest.mark.parametrize("user, advised", [(None, False), ("1", True)])
def test_the_command_line_leaves_huge_pages_off_unless_the_user_asks(user, advised):
    # the `sar` entry sets numpy's variable before numpy is imported, and leaves a user's setting
    import os
    import subprocess
    import sys

    code = ("import sys\nfrom sarcli.cli.main import cli\nsys.argv = ['sar', 'info', '--help']\n"
            "try:\n    cli()\nexcept SystemExit:\n    pass\nimport numpy\n"
            "print('advised', numpy._core.multiarray._get_madvise_hugepage())")
    env = {k: v for k, v in os.environ.items() if k != "NUMPY_MADVISE_HUGEPAGE"}
    if user is not None:
        env["NUMPY_MADVISE_HUGEPAGE"] = user
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert f"advised {advised}" in out
