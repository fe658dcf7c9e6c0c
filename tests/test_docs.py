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


def test_the_own_data_page_runs_as_a_doctest(tmp_path, monkeypatch):
    """docs/own-data.md: numpy arrays -> phase-history file -> image -> GeoTIFF, every line as printed."""
    import doctest

    page = REPO / "docs" / "own-data.md"
    monkeypatch.chdir(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = doctest.testfile(str(page), module_relative=False, encoding="utf-8", report=True,
                                  optionflags=doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS)
    assert result.attempted > 20 and result.failed == 0, result
    assert {p.name for p in tmp_path.iterdir()} >= {"my-collect.h5", "my-image.h5", "my-image.tif"}
    assert "own-data.md" in (REPO / "README.md").read_text()


def test_the_geolocation_example_in_formats_runs_as_a_doctest():
    """docs/formats.md's geolocation example: every printed number as the library gives it."""
    import doctest

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = doctest.testfile(str(REPO / "docs" / "formats.md"), module_relative=False, encoding="utf-8",
                                  report=True, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted >= 15 and result.failed == 0, result


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


# -- facts a test can check: commands and flags, files, modules, machine paths, history ----------------
#: pages written by hand (docs/cli.md is --help itself; docs/stability.md lists deliberately wrong
#: commands, generated from the cases in tests/stability/)
HAND_WRITTEN = [p for p in PAGES if p.name not in ("cli.md", "stability.md")]


def _code_spans(page: Path) -> tuple[list[str], list[str]]:
    """(lines of fenced code blocks, backslash continuations joined; inline code spans of the prose)."""
    text = page.read_text()
    blocks = [ln for m in re.finditer(r"```[^\n]*\n(.*?)```", text, flags=re.S)
              for ln in m.group(1).replace("\\\n", " ").splitlines()]
    return blocks, re.findall(r"`([^`\n]+)`", re.sub(r"```.*?```", "", text, flags=re.S))


def _sar_invocations(span: str):
    """``(command words, flags)`` of each ``sar ...`` in a line or code span (comments dropped)."""
    for part in re.split(r";|&&", span.split(" #")[0]):
        words = part.replace("[", " ").replace("]", " ").split()
        if "sar" not in words:
            continue
        words = words[words.index("sar") + 1:]
        while words and words[0].startswith("-"):  # the group's options come before the command
            words = words[2:] if words[0] == "--max-memory" else words[1:]
        if not words or not re.fullmatch(r"[a-z-]+", words[0]):
            continue
        cmd = words[:2] if words[0] == "import" and len(words) > 1 and words[1] in ("gotcha", "cphd") else words[:1]
        flags = {w.split("=")[0].rstrip(",.:)") for w in words[len(cmd):] if re.match(r"--?[a-zA-Z]", w)}
        yield tuple(cmd), flags


_HELP: dict = {}


def _help_flags(cmd: tuple) -> set | None:
    """The flags `sar CMD --help` shows (None when CMD is not a command)."""
    from click.testing import CliRunner

    from sarcli.cli.main import cli

    if cmd not in _HELP:
        res = CliRunner().invoke(cli, [*cmd, "--help"])
        _HELP[cmd] = set(re.findall(r"(?<![\w-])(--?[a-zA-Z][\w-]*)", res.output)) if res.exit_code == 0 else None
    return _HELP[cmd]


@pytest.mark.parametrize("page", HAND_WRITTEN, ids=lambda p: str(p.relative_to(REPO)))
def test_every_sar_command_and_flag_named_in_the_docs_is_in_its_help(page):
    blocks, inline = _code_spans(page)
    bad = []
    for span in blocks + inline:
        for cmd, flags in _sar_invocations(span):
            known = _help_flags(cmd)
            if known is None:
                bad.append(f"`sar {' '.join(cmd)}` is not a command")
                continue
            bad += [f"`sar {' '.join(cmd)} {f}`: no such option in its --help"
                    for f in sorted(flags - known)]  # the group's -q, -v go before CMD
    assert not bad, f"{page.relative_to(REPO)}: " + "; ".join(sorted(set(bad)))


def test_the_flag_check_catches_a_wrong_flag():
    found = list(_sar_invocations("sar -q export IMG.h5 -o OUT.png --annotate [--bare]; sar import gotcha F -o X"))
    assert found == [(("export",), {"-o", "--annotate", "--bare"}), (("import", "gotcha"), {"-o"})]
    assert "--annotate" not in _help_flags(("export",)) and "--bare" in _help_flags(("export",))
    assert _help_flags(("simulat",)) is None
    assert "-v" not in _help_flags(("regularize",))  # `sar -v regularize`, never `sar regularize -v`


@pytest.mark.parametrize("page", HAND_WRITTEN, ids=lambda p: str(p.relative_to(REPO)))
def test_repository_files_and_modules_named_in_the_prose_exist(page):
    import importlib

    bad = []
    for span in _code_spans(page)[1]:
        for path in re.findall(r"(?<![\w./-])((?:sarcli|tests|docs|scripts|configs|bench|src|\.ci)/[\w./*-]*)", span):
            where = path.split("::")[0].rstrip("/")
            if not ((REPO / where).exists() or ("*" in where and list(REPO.glob(where)))):
                bad.append(f"{path} does not exist")
        for name in re.findall(r"(?<![\w.])(sarcli(?:\.\w+)+)", span):
            parts = name.split(".")
            for n in range(len(parts), 0, -1):  # the longest importable prefix, then attributes
                try:
                    obj = importlib.import_module(".".join(parts[:n]))
                    break
                except ImportError:
                    continue
            for attr in parts[n:]:
                if not hasattr(obj, attr):
                    bad.append(f"{name}: {'.'.join(parts[:n])} has no {attr!r}")
                    break
                obj = getattr(obj, attr)
    assert not bad, f"{page.relative_to(REPO)}: " + "; ".join(sorted(set(bad)))


#: absolute paths of a machine (a user's data sits wherever they put it: docs name it by a placeholder)
MACHINE_PATH = re.compile(r"(?<![\w.~$-])/(?:work|home|root|Users|tmp|mnt|scratch|shared|data|opt|srv)/")
#: words that tell what used to be rather than what is
HISTORY = re.compile(r"\b(?:used to (?:be|say|give|take|write|read|run|pick|have)|earlier runs?|earlier versions?|"
                     r"previous(?:ly| versions?| runs?)|no longer|formerly|was changed|has changed|"
                     r"until recently|(?:this|last|previous) (?:session|round)|round \d|issue \d+|"
                     r"now\b[^.\n]{0,60}\binstead of)\b", re.I)


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(REPO)))
def test_no_machine_paths_and_no_history(page):
    text = page.read_text()
    assert not MACHINE_PATH.findall(text), f"{page.relative_to(REPO)}: machine paths {MACHINE_PATH.findall(text)}"
    words = [m.group(0) for m in HISTORY.finditer(text)]
    assert not words, f"{page.relative_to(REPO)} tells history: {words}"


def test_the_history_and_path_patterns_catch_what_they_are_for():
    for s in ("1.70 (1.82-1.95 in two earlier runs)", "it now reads the file instead of the cache",
              "the default used to be nufft", "fixed in round 2", "as issue 38 asks"):
        assert HISTORY.search(s), s
    for s in ("the estimate is used to form the image", "pixel instead of the grid", "now `sar --help` works"):
        assert not HISTORY.search(s), s
    assert MACHINE_PATH.search("(`/work/shared/data/gotcha/x.mat`)") and MACHINE_PATH.search("input: /shared/gotcha")
    assert not MACHINE_PATH.search("`out/img.h5`, ~/.cache/sarcli, `/truth/scene`, `$HOME/data/`")


def _table_rows_with_the_wrong_width(text: str) -> list[str]:
    """Rows of Markdown tables whose cell count differs from the header's (an unescaped `|`)."""
    cells = lambda line: len(re.split(r"(?<!\\)\|", line.strip()))  # noqa: E731
    lines = re.sub(r"```.*?```", "", text, flags=re.S).splitlines()
    bad = []
    for i, line in enumerate(lines[1:], 1):
        if re.fullmatch(r"\|[-: |]+\|", line.strip()):
            j = i + 1
            while j < len(lines) and lines[j].startswith("|"):
                if cells(lines[j]) != cells(lines[i - 1]):
                    bad.append(lines[j][:80])
                j += 1
    return bad


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(REPO)))
def test_every_table_row_has_its_header_s_cells(page):
    # a `|` inside a cell, even in code, splits it on GitHub: it is written \|
    bad = _table_rows_with_the_wrong_width(page.read_text())
    assert not bad, f"{page.relative_to(REPO)}: rows with an unescaped |: {bad}"


def test_the_table_check_sees_an_unescaped_bar():
    good = "| a | b |\n|---|---|\n| `x\\|y` | 1 |\n"
    assert _table_rows_with_the_wrong_width(good) == []
    assert _table_rows_with_the_wrong_width(good.replace("\\|", "|")) == ["| `x|y` | 1 |"]


def test_the_code_names_the_repository_s_contract():
    """Docstrings and comments point to docs/conventions.md, the contract a clone has; the shared
    CONVENTIONS.md it is kept identical to is not in the repository."""
    named = [str(p.relative_to(REPO)) for p in sorted((REPO / "sarcli").rglob("*.py"))
             if "CONVENTIONS.md" in p.read_text()]
    assert named == [], named
