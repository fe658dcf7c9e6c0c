"""The house rules, checked: the packages' layering (no upward import, lazy imports count), no
import cycles, modules of a few hundred lines, a model layer (``sarcli.core``) that imports no I/O
library, and every figure in ``sarcli.viz``."""

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


#: The layers, bottom up: a module may import its own package and any package of a lower rank;
#: packages of one rank are peers and import neither each other nor anything above.
RANKS = {
    "errors": 0, "_version": 0,
    "_native": 1, "_util": 1,  # compiled kernels' loader; atomic files, progress, guards
    "core": 2,                 # the model: geometry, sampling, acquisition, grid, windows, data types
    "io": 3,                   # every file format
    "simulation": 4,
    "formers": 5,
    "linops": 6,
    "solvers": 7,
    "analysis": 8,             # measurements of images: IRW/PSLR, PSF, quality, speckle
    "regparam": 9,
    "regularize": 10, "autofocus": 10,
    "viz": 11,                 # every figure
    "batch": 12,
    "cli": 13,
    "": 14,                    # the package's lazy front door, sarcli/__init__.py
}
#: Upward imports not yet removed, as (importer, imported) module pairs.
PENDING: set = set()


def _layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _upward(graph):
    """(importer, imported) pairs that import a peer package or one of a higher rank."""
    bad = []
    for name, deps in graph.items():
        mine = _layer(name)
        for d in deps:
            theirs = _layer(d)
            if theirs != mine and RANKS[theirs] >= RANKS[mine]:
                bad.append((name, d))
    return sorted(bad)


def test_every_package_has_a_rank():
    assert {_layer(m) for m in MODULES} <= set(RANKS), "add the new package to RANKS"


def test_the_layer_checker_finds_an_upward_import():
    assert _upward({"sarcli.io.x": {"sarcli.core.grid"}, "sarcli.core.grid": {"sarcli.io.x"},
                    "sarcli.regularize.a": {"sarcli.autofocus.b"}}) == [
        ("sarcli.core.grid", "sarcli.io.x"), ("sarcli.regularize.a", "sarcli.autofocus.b")]


def test_no_upward_imports():
    bad = [e for e in _upward(GRAPH) if e not in PENDING]
    assert not bad, f"upward or sideways imports (see RANKS): {bad}"


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


#: Private modules every package may use: the version string, the compiled-kernel loader, helpers.
SHARED_PRIVATE = ("sarcli._version", "sarcli._native", "sarcli._util")


def _private_crossings(name: str, path: Path) -> list[str]:
    """Imports in ``name`` that take a private name (``_x``) from another module, or any name from a
    private module of another package (lazy imports count)."""
    is_pkg = path.name == "__init__.py"
    package = name if is_pkg else name.rsplit(".", 1)[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if not isinstance(node, ast.ImportFrom) or node.module == "__future__":
            continue
        base = package.split(".")
        base = base[:len(base) - (node.level - 1)] if node.level else []
        mod = ".".join(base + ([node.module] if node.module else []))
        for a in node.names:
            target = f"{mod}.{a.name}"
            private = [p for p in target.split(".") if p.startswith("_") and not p.startswith("__")]
            if not private or target.startswith(SHARED_PRIVATE):
                continue
            home = target.split("." + private[0])[0]   # the package that holds the private part
            if a.name.startswith("_") or not (package + ".").startswith(home + "."):
                out.append(f"{path.name}:{node.lineno} {target}")
        # a public name imported under a private alias reads as a private name taken from elsewhere
        out += [f"{path.name}:{node.lineno} {mod}.{a.name} as {a.asname}" for a in node.names
                if a.asname and a.asname.startswith("_") and not a.asname.startswith("__")
                and (node.level or mod.startswith("sarcli"))]
    return out


def test_the_private_checker_finds_a_crossing(tmp_path):
    p = tmp_path / "m.py"
    p.write_text("from ..linops._reduce import norm2\nfrom ._samples import _check\nfrom ._samples import ok\n"
                 "from ..linops import rdot as _rdot\nfrom scipy import fft as _fft\n")
    assert _private_crossings("sarcli.solvers.m", p) == ["m.py:1 sarcli.linops._reduce.norm2",
                                                         "m.py:2 sarcli.solvers._samples._check",
                                                         "m.py:4 sarcli.linops.rdot as _rdot"]


def test_no_private_name_crosses_a_module():
    bad = [c for name, path in MODULES.items() for c in _private_crossings(name, path)]
    assert not bad, bad


def test_the_facade_reaches_every_subpackage():
    """``import sarcli; sarcli.<subpackage>`` works for every subpackage on disk (lazily)."""
    import sarcli

    on_disk = {p.parent.name for p in PKG.glob("*/__init__.py") if not p.parent.name.startswith("_")}
    for name in sorted(on_disk):
        assert getattr(sarcli, name).__name__ == f"sarcli.{name}", name
        assert name in dir(sarcli), name
