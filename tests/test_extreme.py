"""The stability suite: every case of ``configs/extreme/`` and the bad-input table.

The measurements live in :mod:`tests.stability.extreme` (``python -m tests.stability.report``
writes them into ``docs/stability.md``); each test runs one case and asserts every criterion it
states, so the document stays true.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from tests.stability import extreme as report

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("case", report.CASES, ids=[c.key for c in report.CASES])
def test_case_meets_its_criteria(case):
    outcomes = case.run()
    assert outcomes, "a case must measure something"
    failing = [(o.method, o.measured, o.value, o.criterion) for o in outcomes if not o.passed]
    assert not failing, failing


def test_every_config_is_a_case():
    used = {c.config for c in report.CASES}
    assert used == {p.name for p in (REPO / "configs" / "extreme").glob("*.yaml")}


def test_long_range_float32_phase_error_bound():
    """Case 5 in numbers: the naive float32 range loses > 1e-3 m, backprojection keeps < 0.05 rad."""
    rows = {(o.method, o.measured.split(":")[0]): o.value for o in report.case_long_range()}
    naive = [v for (m, what), v in rows.items() if m == "-"][0]
    assert naive > 1e-3
    assert rows[("backprojection float32", "phase error at the targets (rad)")] < 0.05


def test_aliasing_warning_class_and_ghost_position():
    import sarcli
    from sarcli.errors import AliasingWarning

    with pytest.warns(AliasingWarning, match=r"alias-free radius is 7\.57"):
        sarcli.load_acquisition(REPO / "configs" / "extreme" / "13-aliasing.yaml")
    ghosts = [o for o in report.case_aliasing() if o.method == "nufft"]
    assert ghosts[0].value < 0.25


def test_dynamic_range_hann_within_one_db():
    rows = {o.method: o.value for o in report.case_dynamic_range()}
    assert abs(rows["direct hann"] + 100) < 1.0
    assert abs(rows["nufft hann"] + 100) < 1.0


@pytest.fixture(scope="module")
def bad_rows(tmp_path_factory):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return report.run_bad_inputs(tmp_path_factory.mktemp("bad"))


def test_bad_inputs_one_line_exit_2(bad_rows):
    contract = [r for r in bad_rows if r[0] not in report.BAD_INPUT_EXCEPTIONS]
    assert len(contract) >= 12  # NaN, Inf, zero, negative, mismatched, 2 dtypes, empty: x 2 commands
    failing = [r for r in contract if not r[5]]
    assert not failing, failing
    assert all(r[4].startswith("error: ") for r in contract)


def test_bad_inputs_known_gaps_are_as_documented(bad_rows):
    """Integer frequencies are accepted on purpose: they are exact values in Hz, converted to float64."""
    for label, (code, _, _) in report.BAD_INPUT_EXCEPTIONS.items():
        rows = [r for r in bad_rows if r[0] == label]
        assert rows and all(r[2] == code for r in rows), rows


def test_duplicated_pulses_rejected(bad_rows):
    rows = [r for r in bad_rows if r[0] == "duplicated pulses"]
    assert rows and all(r[2] == 2 and "duplicated pulses" in r[4] for r in rows), rows


def test_report_renders_every_case(tmp_path):
    out = tmp_path / "stability.md"
    from tests.stability.report import main

    assert main(["-o", str(out), "--only", "08", "13", "--no-faults"]) == 0
    text = out.read_text()
    assert "| 08 `08-one-pulse.yaml`" in text and "| 13 `13-aliasing.yaml`" in text
    assert "## Bad input" in text and "duplicated pulses" in text and "accepted" in text
    assert "**FAIL**" not in text
    assert np.isfinite(float(text.split("Total run time of the suite: ")[1].split(" s")[0]))
