"""The house rules, checked: no import cycles (lazy imports count), modules of a few hundred lines,
a model layer (``sarcli.core``) that imports no I/O library, and every figure in ``sarcli.viz``."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "sarcli"
MAX_LINES = 500


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PKG.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


MODULES = {_module_name(p): p for p in sorted(PKG.rglob("*.py"))}


def _imports(name: str, path: Path) -> set[str]:
    """Every sarcli module ``name`` imports, at the top or inside a function (lazy imports count)."""
    is_pkg = path.name == "__init__.py"
    package = name if is_pkg else name.rsplit(".", 1)[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            # `from pkg import sub` names a module; `from mod import name` names the module
            targets = [f"{mod}.{a.name}" if f"{mod}.{a.name}" in MODULES else mod for a in node.names]
        else:
            continue
        for t in targets:
            while t and t not in MODULES:
                t = t.rpartition(".")[0]
            # importing a submodule runs its package's __init__ first: that is not an edge back
            if t and t != name and not name.startswith(t + "."):
                out.add(t)
    return out


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _cycles(graph):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, comps, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))
    for v in graph:
        if v not in index:
            visit(v)
    return comps


def test_the_import_graph_is_read():
    # the checker must see real edges, or the cycle test below proves nothing
    assert "sarcli.core.geometry" in GRAPH["sarcli.core.acquisition"]
    assert "sarcli.formers.pfa" in GRAPH["sarcli.formers.formation"]  # a lazy import inside a function


def test_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycles():
    assert _cycles(GRAPH) == []


@pytest.mark.parametrize("name", sorted(MODULES))
def test_module_size(name):
    n = len(MODULES[name].read_text().splitlines())
    assert n <= MAX_LINES, f"{name} has {n} lines (house limit {MAX_LINES}): split it"


def test_core_depends_on_nothing_above_it():
    allowed = ("sarcli.core", "sarcli.errors", "sarcli._version")
    for name, deps in GRAPH.items():
        if name.startswith("sarcli.core"):
            bad = [d for d in deps if not d.startswith(allowed)]
            assert not bad, f"{name} imports {bad}: the model layer sits below everything else"


def test_core_imports_no_io_library():
    code = ("import sys, sarcli.core.types, sarcli.core.geometry, sarcli.core.grid, sarcli.core.windows, "
            "sarcli.core.acquisition; bad = [m for m in ('h5py', 'tifffile', 'sarkit', 'yaml', 'matplotlib', "
            "'scipy.io', 'PIL', 'finufft') if m in sys.modules]; print(','.join(bad))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "", f"sarcli.core pulled in {out}"


def test_figures_only_in_viz():
    for name, path in MODULES.items():
        if name == "sarcli.viz":
            continue
        text = path.read_text()
        assert "matplotlib.use(" not in text and "pyplot" not in text, f"{name} draws a figure: move it to sarcli.viz"
