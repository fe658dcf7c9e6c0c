"""One interface for every former: options dataclasses, plans, and ``sar plan`` / ``sar form-image``
agreeing on them (docs/architecture.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

from sarcli.cli.form_image import command as form_image_command
from sarcli.cli.main import cli
from sarcli.cli.options import method_options
from sarcli.errors import SarcliInputError
from sarcli.formers.planning.cost import Samples, form_image_bytes
from sarcli.formers.backprojection import DEFAULT_UPSAMPLE
from sarcli.formers.families import FORMERS
from sarcli.formers.formation import PLANNED, default_candidates, form_image, image_error, plan_rows
from sarcli.formers.former import Settings
from sarcli.formers.options import KNOB_NAMES, OPTIONS

from .test_planner import GRID, spherical



@pytest.fixture(scope="module")
def scenes():
    from sarcli.core.types import PhaseHistory

    sph = spherical(P=64)
    acq = sph.acquisition
    from sarcli.core.acquisition import Acquisition

    far = PhaseHistory(sph.data, Acquisition(acq.frequency_hz, acq.azimuth_rad, acq.elevation_rad, GRID,
                                             model="farfield"))
    return {"spherical": sph, "farfield": far}


def parse_flags(flags):
    """The options ``sar form-image`` runs for ``flags`` (its own parser, under ``sar``'s context)."""
    parent = cli.make_context("sar", ["form-image"], resilient_parsing=True)
    ctx = form_image_command.make_context("form-image", ["ph.h5", "-o", "img.h5", *flags], parent=parent)
    return method_options(ctx.params["method"], {k: ctx.params[k] for k in KNOB_NAMES})


def test_every_family_has_options_and_a_former():
    assert set(OPTIONS) == set(FORMERS) | {"auto"}
    assert {m for ms in PLANNED.values() for m in ms} == set(FORMERS)


@pytest.mark.parametrize("model", ["spherical", "farfield"])
def test_plans_default_row_is_what_the_method_runs_with_no_knob(scenes, model):
    """For every family sar plan lists: the default row's options are the dataclass's defaults,
    its flags are ``--method X`` alone and parse back to the same options, and its knobs are the
    ones form_image runs with no knob."""
    ph = scenes[model]
    rows = default_candidates(ph, GRID, 1e-3)
    assert [r.method for r in rows] == list(PLANNED[model])
    for row in rows:
        assert row.default and row.options == OPTIONS[row.method]()
        assert row.flags() == ["--method", row.method]
        assert parse_flags(row.flags()) == row.options
        img = form_image(ph, row.method)
        ran = {k: img.parameters[k] for k in row.knobs if k in img.parameters}
        assert ran == {k: row.knobs[k] for k in ran}, (row.method, ran, row.knobs)


def test_every_plan_rows_flags_parse_back(scenes):
    for model, ph in scenes.items():
        rows = plan_rows(ph, GRID, 1e-3)
        assert len(rows) > len(PLANNED[model])   # tuned rows besides the defaults
        for row in rows:
            assert parse_flags(row.flags()) == row.options, row.flags()


def test_a_tuned_row_runs_its_knobs(scenes):
    ph = scenes["spherical"]
    row = next(r for r in plan_rows(ph, GRID, 1e-3) if r.method == "backprojection" and not r.default)
    opts = parse_flags(row.flags())
    img = form_image(ph, opts.method, **opts.given())
    assert img.parameters["upsample"] == row.knobs["upsample"] and img.parameters["interp"] == row.knobs["interp"]


def test_plan_form_is_form_image(scenes):
    ph = scenes["spherical"]
    for method in ("direct", "backprojection", "ffbp", "subimage"):
        plan = FORMERS[method].make(ph, GRID, Settings(window="hann"))
        assert np.array_equal(plan.form().image, form_image(ph, method, window="hann").image), method
        assert plan.bytes > 0 and plan.seconds > 0 and plan.predicted_error >= 0
    with pytest.raises(SarcliInputError, match="samples of shape"):
        plan.form(ph.data[1:])
    # other samples of the same shape: the plan's image of them
    assert np.array_equal(plan.form(2 * ph.data).image, 2 * plan.form().image)


def test_one_memory_model(scenes):
    """sar plan's memory column and form_image's memory check read the same model."""
    ph = scenes["spherical"]
    for row in plan_rows(ph, GRID, 1e-3):
        plan = FORMERS[row.method].plan(ph, GRID, row.options, Settings(), None)
        assert row.memory == pytest.approx(plan.bytes), row.method
    smp = Samples.of(ph)
    bp = FORMERS["backprojection"].make(ph, GRID)
    assert bp.bytes == form_image_bytes("backprojection", smp, GRID, upsample=DEFAULT_UPSAMPLE, precision="float32")


def test_flags_write_numbers_that_read_back():
    from sarcli.formers.former import flag_text

    for v in (1e-9, 0.1 + 0.2, np.float64(1.5), np.float32(0.3), np.int64(16), 16):
        assert float(flag_text(v)) == float(v) and "np." not in flag_text(v)


def test_pfa_has_no_error_model(scenes):
    plan = FORMERS["pfa"].make(scenes["farfield"], GRID)
    assert math.isnan(plan.predicted_error) and plan.bytes > 0


def test_unknown_knob_is_refused_by_name(scenes):
    ph = scenes["spherical"]
    with pytest.raises(SarcliInputError, match=r"method 'nufft' has no knob 'upsample' \(its knobs: eps\)"):
        form_image(ph, "nufft", upsample=8)
    with pytest.raises(SarcliInputError, match="backprojection: interp must be one of linear, cubic, lanczos"):
        form_image(ph, "backprojection", interp="optimal")
    with pytest.raises(SarcliInputError, match=r"ffbp: base must be >= 1, got 0"):
        OPTIONS["ffbp"](base=0)
    # None is "not given": the default, as the keyword arguments of form_image always read it
    assert OPTIONS["backprojection"].from_knobs({"upsample": None, "interp": "linear"}) == \
        OPTIONS["backprojection"](interp="linear")
    with pytest.raises(SarcliInputError, match="upsample must be given a value"):
        OPTIONS["backprojection"](upsample=None)


def test_cli_refuses_a_knob_of_another_method(tmp_path, scenes):
    from sarcli.io.hdf5 import write_phase_history

    write_phase_history(tmp_path / "ph.h5", scenes["spherical"])
    res = CliRunner().invoke(cli, ["form-image", str(tmp_path / "ph.h5"), "-o", str(tmp_path / "i.h5"),
                                   "--method", "nufft", "--upsample", "8"])
    assert res.exit_code == 2 and "--upsample is no option of --method nufft (its options: --eps)" in res.output
    assert not (tmp_path / "i.h5").exists()
    res = CliRunner().invoke(cli, ["form-image", str(tmp_path / "ph.h5"), "-o", str(tmp_path / "i.h5"),
                                   "--tile", "8"])
    assert res.exit_code == 2 and "--tile sets a knob of one method" in res.output


def test_cli_forms_with_lagrange_interpolation(tmp_path, scenes):
    """``--interp lagrange`` parses to its options and runs them: the image is the library's with
    the same knobs, and nearer the exact matched filter than Keys' at the same upsampling."""
    from sarcli.io.hdf5 import read_image, write_phase_history

    ph = scenes["spherical"]
    assert parse_flags(["--method", "backprojection", "--interp", "lagrange", "--upsample", "6"]) == \
        OPTIONS["backprojection"](interp="lagrange", upsample=6)
    write_phase_history(tmp_path / "ph.h5", ph)
    out = tmp_path / "i.h5"
    res = CliRunner().invoke(cli, ["-q", "form-image", str(tmp_path / "ph.h5"), "-o", str(out), "--method",
                                   "backprojection", "--interp", "lagrange", "--upsample", "6"])
    assert res.exit_code == 0, res.output
    img = read_image(out)
    assert img.parameters["interp"] == "lagrange" and img.parameters["upsample"] == 6
    ref = form_image(ph, "direct").image
    lag = form_image(ph, "backprojection", interp="lagrange", upsample=6).image
    keys = form_image(ph, "backprojection", interp="cubic", upsample=6).image
    np.testing.assert_array_equal(img.image, lag)
    assert image_error(lag, ref) < 0.8 * image_error(keys, ref)
