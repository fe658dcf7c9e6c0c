"""docs/cli.md must be exactly what the commands' --help says (regenerate with scripts/cli_reference.py)."""

from __future__ import annotations

import importlib.util

from click.testing import CliRunner

from sarcli.cli.main import COMMANDS, cli

from .conftest import REPO


def _render():
    spec = importlib.util.spec_from_file_location("cli_reference", REPO / "scripts" / "cli_reference.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.render()


def test_cli_reference_in_sync(monkeypatch):
    import difflib

    monkeypatch.setenv("COLUMNS", "80")
    want, got = (REPO / "docs" / "cli.md").read_text(), _render()
    diff = "".join(list(difflib.unified_diff(want.splitlines(True), got.splitlines(True), n=1))[:12])
    assert want == got, f"docs/cli.md is stale: run .venv/bin/python scripts/cli_reference.py docs/cli.md\n{diff}"


def test_every_command_has_help():
    for name in COMMANDS:
        res = CliRunner().invoke(cli, [name, "--help"])
        assert res.exit_code == 0, (name, res.output)
        assert "Usage: " in res.output


def test_version_and_quiet():
    from sarcli import __version__

    res = CliRunner().invoke(cli, ["--version"])
    assert res.exit_code == 0 and __version__ in res.output
    res = CliRunner().invoke(cli, ["-q", "info", str(REPO / "configs" / "three-points.yaml")])
    assert res.exit_code == 0 and "alias_free_radius_m" in res.output
