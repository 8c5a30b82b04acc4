"""Structure the style rules ask for, read from the source with ``ast``: no function over 60 lines.

The independent transcription (tests/transcription.py) is exempt: it is a line-by-line reading of the
paper's equations, kept apart from the model on purpose, and splitting it would hide that."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MAX_FUNCTION_LINES = 60
EXEMPT = {Path("tests/transcription.py")}
# Not project sources: the virtual environment, build output, the generated C's folder.
SKIPPED_FOLDERS = {".venv", "build", "dist", "generated_c", "out", "node_modules"}


def project_sources(root: Path = ROOT) -> list[Path]:
    """Every .py file of the project, relative to ``root``."""
    found = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if any(part in SKIPPED_FOLDERS or part.startswith(".") for part in rel.parts[:-1]):
            continue
        found.append(rel)
    return found


def long_functions(root: Path = ROOT, limit: int = MAX_FUNCTION_LINES) -> list[str]:
    """``path:line name (N lines)`` for each function or method longer than ``limit`` lines, nested ones
    included (a closure counts toward its own length and toward its enclosing function's)."""
    out = []
    for rel in project_sources(root):
        if rel in EXEMPT:
            continue
        tree = ast.parse((root / rel).read_text(encoding="utf-8"), filename=str(rel))
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1  # decorators excluded, docstring included
                if length > limit:
                    out.append(f"{rel}:{node.lineno} {node.name} ({length} lines)")
    return sorted(out)


def test_no_function_over_60_lines():
    assert long_functions() == []


def test_the_sources_are_found():
    """The walk sees the four layers and the tests, and not the virtual environment."""
    sources = project_sources()
    folders = {rel.parts[0] for rel in sources}
    assert {"model", "codegen", "harness", "dobwind", "tests"} <= folders
    assert Path("model/step.py") in sources and Path("tests/test_structure.py") in sources
    assert not any(".venv" in rel.parts for rel in sources)


def test_the_check_sees_a_long_function(tmp_path):
    """61 lines fail, 60 pass, a long method and a long closure are found, the exemption holds."""
    (tmp_path / "pkg").mkdir()
    body = "\n".join(f"    x{i} = {i}" for i in range(59))
    (tmp_path / "pkg" / "ok.py").write_text(f"def fits():\n{body}\n")                 # 60 lines
    (tmp_path / "pkg" / "long.py").write_text(f"def too_long():\n{body}\n    return x0\n")  # 61 lines
    method = "\n".join(f"        y{i} = {i}" for i in range(61))
    (tmp_path / "pkg" / "cls.py").write_text(f"class C:\n    def method(self):\n{method}\n")
    closure = "\n".join(f"        z{i} = {i}" for i in range(61))
    (tmp_path / "pkg" / "nested.py").write_text(f"def outer():\n    def inner():\n{closure}\n    return inner\n")
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "transcription.py").write_text(f"def step():\n{body}\n    return x0\n")
    (tmp_path / ".venv").mkdir()
    (tmp_path / ".venv" / "lib.py").write_text(f"def vendored():\n{body}\n    return x0\n")
    assert long_functions(tmp_path) == [
        "pkg/cls.py:2 method (62 lines)",
        "pkg/long.py:1 too_long (61 lines)",
        "pkg/nested.py:1 outer (64 lines)",
        "pkg/nested.py:2 inner (62 lines)",
    ]
