"""The layers import only downwards: model <- codegen <- harness <- applications (dobwind/*).

Reads every import statement with ``ast`` (lazy imports inside functions included), so an import against
the flow fails here before it reaches a reader of the code."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# folder -> (its package, the packages it may import from the project)
LAYERS = {
    "model": ("dobwind.model", ("dobwind.model",)),
    "codegen": ("dobwind.codegen", ("dobwind.model", "dobwind.codegen")),
    "harness": ("dobwind.harness", ("dobwind.model", "dobwind.codegen", "dobwind.harness")),
}


def project_imports(path: Path, package: str) -> list[tuple[int, str]]:
    """Absolute names of the project modules a file imports, with line numbers."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against the file's own package
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
    (fake / "bad.py").write_text("def f():\n    from dobwind.fit import fit_airframe\n    return fit_airframe\n")
    (fake / "good.py").write_text("from dobwind.model.errors import InputError\nimport numpy\n")
    assert violations("model", tmp_path) == ["model/bad.py:2 imports dobwind.fit.fit_airframe"]
