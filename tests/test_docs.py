"""The documentation a newcomer reads: every relative link resolves inside the repository, nothing
points outside it, the contract page names everything the shared contract names, and the README's
Python example runs without a warning."""

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
