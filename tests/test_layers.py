"""The layers import only downwards: model <- codegen <- harness <- the application's subpackages
(dobwind/<package>/), whose own arrows are APPLICATION below (drawn in docs/architecture.md).

Reads every import statement with ``ast`` (lazy imports inside functions included; imports under
``if TYPE_CHECKING:`` are annotations only and never run), so an import against the flow, or one that
closes a cycle, fails here before it reaches a reader of the code."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# The application's subpackages -> the subpackages each may import (besides itself and the package
# root, dobwind/__init__.py, which only carries the version). Derived from the import graph of the move
# (issue #34); every arrow points down the list, so the arrows cannot close a cycle between packages.
APPLICATION = {
    "core": (),
    "io": ("core",),
    "simulate": ("core", "io"),
    "analysis": ("core", "io"),
    "replay": ("core", "io"),
    "generate": ("core", "io"),
    "calibrate": ("core", "io", "replay"),
    "atmos": ("core", "io", "replay"),
    "inspect": ("core", "io", "analysis"),
    "report": ("core", "io", "analysis", "replay"),
    "cli": ("core", "io", "simulate", "analysis", "replay", "generate", "calibrate", "atmos", "inspect", "report"),
}
# What every application subpackage may use of the lower layers.
LOWER = ("dobwind.model", "dobwind.codegen", "dobwind.harness")

# folder -> (its package, the packages it may import from the project)
LAYERS = {
    "model": ("dobwind.model", ("dobwind.model",)),
    "codegen": ("dobwind.codegen", ("dobwind.model", "dobwind.codegen")),
    "harness": ("dobwind.harness", ("dobwind.model", "dobwind.codegen", "dobwind.harness")),
    **{f"dobwind/{name}": (f"dobwind.{name}", (*LOWER, f"dobwind.{name}", *(f"dobwind.{d}" for d in deps)))
       for name, deps in APPLICATION.items()},
}


def _type_checking_only(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING"


def _import_nodes(tree: ast.AST):
    """Every import statement that can run, at any depth (not those under ``if TYPE_CHECKING:``)."""
    for node in ast.iter_child_nodes(tree):
        if _type_checking_only(node):
            yield from (n for child in node.orelse for n in _import_nodes(child))
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        yield from _import_nodes(node)


def project_imports(path: Path, package: str) -> list[tuple[int, str]]:
    """Absolute names of the project modules a file imports, with line numbers."""
    found = []
    for node in _import_nodes(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif node.level:  # relative: resolve against the file's own package
            base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
            found.append((node.lineno, f"{base}.{node.module}" if node.module else base))
        elif node.module:
            found += [(node.lineno, f"{node.module}.{alias.name}") for alias in node.names]
    return [(line, name) for line, name in found if name == "dobwind" or name.startswith("dobwind.")]


def violations(folder: str, root: Path = ROOT) -> list[str]:
    package, allowed = LAYERS[folder]
    bad = []
    for path in sorted((root / folder).rglob("*.py")):
        for line, name in project_imports(path, package):
            if folder.startswith("dobwind/") and name in ("dobwind", "dobwind.__version__"):
                continue  # the package root: its version
            if not any(name == a or name.startswith(a + ".") for a in allowed):
                bad.append(f"{path.relative_to(root)}:{line} imports {name}")
    return bad


@pytest.mark.parametrize("folder", sorted(LAYERS))
def test_no_import_against_the_flow(folder):
    assert violations(folder) == []


def test_the_check_sees_a_violation(tmp_path):
    """The checker itself: a lazy import of the applications from the model is reported."""
    fake = tmp_path / "model"
    fake.mkdir()
    (fake / "bad.py").write_text("def f():\n    from dobwind.calibrate.fit import fit_airframe\n    return fit_airframe\n")
    (fake / "good.py").write_text("from dobwind.model.errors import InputError\nimport numpy\n")
    assert violations("model", tmp_path) == ["model/bad.py:2 imports dobwind.calibrate.fit.fit_airframe"]


def test_the_check_sees_an_arrow_upwards_between_subpackages(tmp_path):
    """io below calibrate: a reader that imports the fit is reported; the CLI importing it is not."""
    for name in ("io", "cli"):
        (tmp_path / "dobwind" / name).mkdir(parents=True)
    (tmp_path / "dobwind" / "io" / "reader.py").write_text(
        "from dobwind.core.errors import InputError\nfrom dobwind import __version__\n"
        "def f():\n    from dobwind.calibrate import fit\n")
    (tmp_path / "dobwind" / "cli" / "fit.py").write_text("from dobwind.calibrate import fit\n")
    assert violations("dobwind/io", tmp_path) == ["dobwind/io/reader.py:4 imports dobwind.calibrate.fit"]
    assert violations("dobwind/cli", tmp_path) == []


def test_the_arrows_point_down_the_list():
    """Each subpackage imports only subpackages listed before it: the package graph has no cycle."""
    order = list(APPLICATION)
    assert {name: [d for d in deps if order.index(d) >= order.index(name)] for name, deps in APPLICATION.items()} \
        == {name: [] for name in APPLICATION}


def test_every_application_module_sits_in_a_subpackage():
    assert sorted(p.name for p in (ROOT / "dobwind").glob("*.py")) == ["__init__.py"]
    subpackages = {p.parent.name for p in (ROOT / "dobwind").glob("*/__init__.py")}
    assert subpackages == set(APPLICATION)  # a new subpackage needs its arrows drawn above


# --- import cycles between modules ---------------------------------------------------------------

def module_name(rel: Path) -> str:
    parts = list(rel.with_suffix("").parts)
    if parts[0] != "dobwind":
        parts.insert(0, "dobwind")  # model/, codegen/, harness/ install as dobwind.model ...
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """module -> the project modules it imports (a name imported from a module counts as the module)."""
    files = {module_name(p.relative_to(root)): p for folder in ("dobwind", "model", "codegen", "harness")
             for p in (root / folder).rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in files.items():
        package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
        targets = set()
        for _, imported in project_imports(path, package):
            while imported not in files and "." in imported:
                imported = imported.rsplit(".", 1)[0]
            if imported in files and imported != name:
                targets.add(imported)
        graph[name] = targets
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_no_import_cycles():
    assert cycles(import_graph()) == []


def test_the_cycle_check_sees_a_lazy_cycle(tmp_path):
    """Two modules importing each other, one of them inside a function, are a cycle; an import under
    ``if TYPE_CHECKING:`` is not."""
    (tmp_path / "dobwind" / "io").mkdir(parents=True)
    (tmp_path / "dobwind" / "io" / "a.py").write_text("from dobwind.io.b import g\n")
    (tmp_path / "dobwind" / "io" / "b.py").write_text("def g():\n    from dobwind.io import a\n")
    (tmp_path / "dobwind" / "io" / "c.py").write_text(
        "from typing import TYPE_CHECKING\nfrom dobwind.io.a import x\nif TYPE_CHECKING:\n    from dobwind.io.d import y\n")
    (tmp_path / "dobwind" / "io" / "d.py").write_text("from dobwind.io.c import z\n")
    assert cycles(import_graph(tmp_path)) == [["dobwind.io.a", "dobwind.io.b"]]
