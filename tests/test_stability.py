"""Nothing lost, nothing hung: hostile input, interruption and resource exhaustion.

Runs every case of :mod:`tests.stability.faults` once (real ``sar`` processes where signals, file
size limits or concurrent writers are involved) and asserts each family; checks that
``docs/stability.md`` (written by ``python -m tests.stability.report``) lists exactly these cases.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.stability import extreme, faults

DOC = Path(__file__).resolve().parents[1] / "docs" / "stability.md"

# real processes, signals and 1 s bounds: `make test` runs these alone, after the parallel run,
# so a worker busy with other tests does not blur the timings
pytestmark = pytest.mark.faults


@pytest.fixture(scope="module")
def rows(tmp_path_factory):
    return faults.run_all(tmp_path_factory.mktemp("faults"))


def test_at_least_40_cases_across_every_family(rows):
    assert len(rows) >= 40
    assert {r.key.rstrip("0123456789") for r in rows} == set(faults.FAMILIES)
    assert len({r.key for r in rows}) == len(rows)


@pytest.mark.parametrize("family", sorted(faults.FAMILIES))
def test_family_holds(rows, family):
    failing = [r for r in rows if r.key.rstrip("0123456789") == family and not r.passed]
    assert not failing, "; ".join(f"{r.key} ({r.case}): expected {r.expected}; observed {r.observed}" for r in failing)


def test_limitations_say_why_and_lose_nothing(rows):
    for r in rows:
        if r.limitation:
            assert r.passed and len(r.note) > 40 and "untouched" in r.observed, r


def test_docs_list_every_case(rows):
    text = DOC.read_text()
    documented = set(re.findall(r"^\| ([A-Z]\d+) \|", text, re.MULTILINE))
    assert documented == {r.key for r in rows}, "docs/stability.md is stale: run python -m tests.stability.report"
    for case in extreme.CASES:
        assert f"| {case.key} `{case.config}`" in text
    assert "**FAIL**" not in text
