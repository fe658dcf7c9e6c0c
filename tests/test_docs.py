"""The documentation a newcomer reads: every relative link resolves inside the repository, nothing
points outside it, the file contract (docs/conventions.md) names exactly what sarcli writes (and,
where the project's shared contract sits beside the checkout, everything that one names), and the
README's Python example runs without a warning."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import pytest

from .conftest import REPO

PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
SHARED_CONVENTIONS = REPO.parent / "shared" / "CONVENTIONS.md"


def _links(page: Path):
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)  # code blocks hold no links
    return LINK.findall(text)


def _anchors(page: Path) -> set[str]:
    """GitHub-style heading anchors of a Markdown page."""
    out = set()
    for line in page.read_text().splitlines():
        m = re.match(r"#+\s+(.*)", line)
        if m:
            slug = re.sub(r"[^\w\- ]", "", m.group(1).strip().lower()).replace(" ", "-")
            out.add(slug)
    return out


def test_pages_found():
    assert len(PAGES) > 5 and all(p.exists() for p in PAGES)


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(REPO)))
def test_relative_links_resolve_inside_the_repository(page):
    bad = []
    for target in _links(page):
        if re.match(r"[a-z]+:", target):  # http:, https:, mailto: are not files
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if REPO.resolve() not in dest.parents and dest != REPO.resolve():
            bad.append(f"{target} leaves the repository")
        elif not dest.exists():
            bad.append(f"{target} does not exist")
        elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
            bad.append(f"{target}: no heading #{anchor} in {dest.name}")
    assert not bad, f"{page.relative_to(REPO)}: " + "; ".join(bad)


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(REPO)))
def test_no_page_points_into_the_shared_folder(page):
    # users never have ../shared: a path into it in prose is as broken as a link
    text = page.read_text()
    assert "../shared/" not in text.replace("`../shared/data/gotcha` beside the repository", "")


@pytest.mark.skipif(not SHARED_CONVENTIONS.exists(), reason="the shared contract is not beside this checkout")
def test_conventions_copy_names_everything_the_contract_names():
    ours = (REPO / "docs" / "conventions.md").read_text()
    theirs = SHARED_CONVENTIONS.read_text()
    names = set(re.findall(r"`(/[a-z_/]+)`", theirs)) | set(re.findall(r"`(format|version|model|method|"
                                                                          r"parameters|runtime_s)\b", theirs))
    names |= set(re.findall(r'"(sarcli-[a-z-]+)"', theirs))
    assert len(names) > 10
    missing = sorted(n for n in names if n not in ours)
    assert not missing, f"docs/conventions.md lacks {missing}"


def _contract_section() -> str:
    text = (REPO / "docs" / "conventions.md").read_text()
    start = text.index("## Files (HDF5)")
    return text[start:text.index("\n## ", start + 1)]


def _everything_sarcli_writes(tmp_path):
    """A phase history with every optional part (bistatic positions, autofocus, points and an
    extended scene) and an image with a history, written by the library."""
    import dataclasses

    import numpy as np

    import sarcli
    from sarcli.core.types import Image
    from sarcli.io.hdf5 import write_image, write_phase_history

    from .conftest import small_config

    cfg = small_config(frequencies={"center_frequency_ghz": 10.0, "bandwidth_mhz": 600.0, "count": 32},
                       azimuths={"center_deg": 50.0, "extent_deg": 3.0, "count": 32},
                       image={"half_width_m": 4.0, "pixels": 16},
                       scene={"points": [{"position_m": [0.0, 0.0]}],
                              "phantom": {"name": "disks", "half_width_m": 1.0}})
    ph = sarcli.simulate(sarcli.parse_acquisition(cfg), seed=0)
    a = ph.acquisition
    offset = np.array([0.0, 40.0, 0.0])
    ph = dataclasses.replace(ph, acquisition=a.with_(transmit_position_m=a.antenna_position_m - offset,
                                                     receive_position_m=a.antenna_position_m + offset),
                             attrs={**ph.attrs, "autofocus_phase_rad": np.zeros(a.n_pulses), "autofocus_method": "pga"})
    write_phase_history(tmp_path / "ph.h5", ph)
    g = a.grid
    img = Image(np.ones(g.shape, np.complex64), g.x, g.y, method="admm", parameters={"prior": "tv"},
                history={"objective": [2.0, 1.0], "relative_change": [1.0, 0.1]})
    write_image(tmp_path / "img.h5", img)
    return tmp_path / "ph.h5", tmp_path / "img.h5"


def test_the_file_contract_names_exactly_what_sarcli_writes(tmp_path):
    """docs/conventions.md is the contract users have (on any clone): its format names and version are
    the library's, each dataset in its tables is written by sarcli, and sarcli writes nothing it omits."""
    import h5py

    from sarcli.io import hdf5

    section = _contract_section()
    for name in (hdf5.PH_FORMAT, hdf5.IMAGE_FORMAT):
        assert f'`format = "{name}"`, `version = {hdf5.FILE_VERSION}`' in section
    rows = [line.split("|")[1] for line in section.splitlines() if line.startswith("| `/")]
    named = {n for cell in rows for n in re.findall(r"`(/[a-z_/]+)`", cell)}
    assert {"/phase_history", "/image", "/grid", "/truth/scene"} <= named
    prose = set(re.findall(r"group `(/[a-z_]+)`", section))  # `/history`: one dataset per logged quantity
    assert prose == {"/history"}
    written = set()
    for path in _everything_sarcli_writes(tmp_path):
        with h5py.File(path, "r") as f:
            assert f.attrs["format"] in (hdf5.PH_FORMAT, hdf5.IMAGE_FORMAT) and f.attrs["version"] == hdf5.FILE_VERSION
            f.visititems(lambda n, o: written.add("/" + n))
    groups = {"/truth", "/autofocus"}  # named through their datasets
    unnamed = sorted(n for n in written - named - prose - groups if not any(n.startswith(p + "/") for p in prose))
    assert not unnamed, f"sarcli writes {unnamed}, which docs/conventions.md does not name"
    assert not named - written, f"docs/conventions.md names {sorted(named - written)}, which sarcli never writes"


def _readme_python() -> str:
    blocks = re.findall(r"```python\n(.*?)```", (REPO / "README.md").read_text(), flags=re.S)
    assert blocks, "the README has a Python example"
    return blocks[0]


def test_readme_python_example_runs_without_warnings(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code = _readme_python().replace('"configs/', f'"{REPO}/configs/')
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        exec(compile(code, "README.md", "exec"), {})
    assert (tmp_path / "ph.h5").exists() and (tmp_path / "img.h5").exists()
