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


# --- one home for each force-air equation ---------------------------------------------------------
# The simulator (simulate.py with its vehicle physics in vehicle.py) and the tilt-method baseline are
# independent of the model on purpose, and so is the test transcription: they may restate the physics.
# The mutation table quotes model source lines as its anchors; quoting is not defining.
INDEPENDENT = {Path("dobwind/simulate/simulate.py"), Path("dobwind/simulate/vehicle.py"), Path("dobwind/replay/baseline.py"),
               Path("tools/mutant_table.py")}
LAYER_FOLDERS = ("model", "codegen", "harness", "dobwind")

# equation -> (a regular expression that writes it out, the one file allowed to)
ONE_HOME = {
    # "wind from": atan2 of the negated wind components
    "wind from": (r"\b(arctan2|atan2)\(\s*-", "model/forceair.py"),
    # the heading-frame rotation, the -sin * x + cos * y row
    "heading frame": (r"-\s*(\w+\.)?(s|sn|sin_yaw|np\.sin\(\w+\))\s*\*\s*[\w.]+(\[[^\]]*\])?\s*\+\s*"
                      r"(\w+\.)?(c|cos_yaw|np\.cos\(\w+\))\s*\*", "model/forceair.py"),
    # the term variables: a table that defines "fh"
    "term variables": (r"[\"']fh[\"']\s*:", "model/forceair.py"),
    # force -> airflow direction: the guard against dividing by a vanishing horizontal force
    "force -> airflow direction": (r"FORCE_DIRECTION_EPS_N\s*\*\*|np\.maximum\(np\.hypot\(m, n\)", "model/forceair.py"),
    # the polynomial family's expression, built from an airframe's terms (the ramp once rebuilt it:
    # issue #33); its definition in model/terms.py is not a use
    "polynomial family": (r"(?<!def )\bpolynomial_expr\(", "model/forceair.py"),
    # yaw from a quaternion
    "yaw from quaternion": (r"arctan2\(2 \* \(w \* z", "model/attitude.py"),
    # the attitude that points the thrust: body axes built by cross products
    "attitude from thrust direction": (r"np\.cross\(", "model/attitude.py"),
}


def equation_sites(root: Path = ROOT) -> dict[str, list[str]]:
    """For each equation of ONE_HOME, the files (outside the independent ones) that write it out."""
    import re

    sites: dict[str, list[str]] = {name: [] for name in ONE_HOME}
    for rel in project_sources(root):
        if rel.parts[0] not in LAYER_FOLDERS or rel in INDEPENDENT:
            continue
        text = (root / rel).read_text(encoding="utf-8")
        for name, (pattern, _) in ONE_HOME.items():
            if re.search(pattern, text):
                sites[name].append(rel.as_posix())
    return sites


def test_each_force_air_equation_has_one_home():
    assert equation_sites() == {name: [home] for name, (_, home) in ONE_HOME.items()}


def test_the_one_home_check_sees_a_copy(tmp_path):
    """The copies the issue found, written back into an application module, are reported."""
    for folder in ("model", "dobwind"):
        (tmp_path / folder).mkdir()
    for home in {home for _, home in ONE_HOME.values()}:
        (tmp_path / home).write_text((ROOT / home).read_text(encoding="utf-8"))
    (tmp_path / "dobwind" / "copies.py").write_text(
        "raw = np.degrees(np.arctan2(-wind[:, 1], -wind[:, 0]))\n"
        "rel_c = [c * f[:, 0] + s * f[:, 1], -s * f[:, 0] + c * f[:, 1]]\n"
        "n = -samples.sin_yaw * f[:, 0] + samples.cos_yaw * f[:, 1] - offset[1]\n"
        'env = {"m": m, "n": n, "fh": ca.sqrt(m * m + n * n), "fz": fz}\n'
        "fh = np.maximum(np.hypot(m, n), 1e-6)\n"
        "h = ca.Function('h', [m, n, fz], [polynomial_expr(af.horizontal.terms, af.horizontal.coefficients, env)])\n"

        "yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))\n"
        "y = np.cross(z, heading)\n")
    (tmp_path / "dobwind" / "simulate").mkdir()
    (tmp_path / "dobwind" / "simulate" / "simulate.py").write_text("y = np.cross(z, heading)\n")  # independent: allowed
    sites = equation_sites(tmp_path)
    assert sites == {name: sorted([home, "dobwind/copies.py"]) for name, (_, home) in ONE_HOME.items()}


# --- the documents the code cites are in the repository --------------------------------------------

def cited_documents(root: Path = ROOT) -> dict[str, list[str]]:
    """Documents named in the project's Python sources -> the files that name them: ``docs/<page>.md``
    paths and the bare names of the outside specification (MODEL.md, INTERFACES.md)."""
    import re

    cited: dict[str, list[str]] = {}
    for rel in project_sources(root):
        if rel == Path("tests/test_structure.py"):  # its own examples below are not citations
            continue
        text = (root / rel).read_text(encoding="utf-8")
        for name in sorted(set(re.findall(r"\b(?:docs/[\w.-]+\.md|(?<![\w/])(?:MODEL|INTERFACES)\.md)", text))):
            cited.setdefault(name, []).append(rel.as_posix())
    return cited


def test_the_code_cites_only_documents_in_the_repository():
    """A clone holds every page a docstring or comment points to; none points outside it."""
    cited = cited_documents()
    assert "docs/model.md" in cited and "docs/formats.md" in cited
    missing = {name: files for name, files in cited.items() if not (ROOT / name).is_file()}
    assert missing == {}


def test_the_citation_check_sees_an_outside_document(tmp_path):
    (tmp_path / "model").mkdir()
    (tmp_path / "model" / "a.py").write_text('"""Signs as in MODEL.md; formats in docs/formats.md."""\n')
    (tmp_path / "model" / "b.py").write_text("# the status bits (INTERFACES.md section 5), docs/gone.md\n")
    assert cited_documents(tmp_path) == {"INTERFACES.md": ["model/b.py"], "MODEL.md": ["model/a.py"],
                                         "docs/formats.md": ["model/a.py"], "docs/gone.md": ["model/b.py"]}


# --- the README's pipeline names real folders and modules ---------------------------------------------

def readme_layout_names(readme: str) -> list[str]:
    """Paths (``model/step.py``, ``dobwind/analysis/``) and bare module names (``fitfamily.py``) in the
    README's pipeline section, figure and folder table included."""
    import re

    section = readme.split("## The pipeline", 1)[1].split("\n## ", 1)[0]
    return sorted(set(re.findall(r"(?<![\w/.-])(?:[a-z_]+/)*[a-z_]+(?:\.py|/)(?![\w])", section)))


def missing_layout_names(root: Path = ROOT) -> list[str]:
    bare_modules = {p.name for folder in LAYER_FOLDERS for p in (root / folder).rglob("*.py")}
    missing = []
    for name in readme_layout_names((root / "README.md").read_text(encoding="utf-8")):
        if "/" in name.rstrip("/"):
            exists = (root / name).exists()
        elif name.endswith("/"):
            exists = (root / name).is_dir()
        else:
            exists = name in bare_modules
        if not exists:
            missing.append(name)
    return missing


def test_the_readme_pipeline_names_real_folders_and_modules():
    names = readme_layout_names((ROOT / "README.md").read_text(encoding="utf-8"))
    assert {"model/step.py", "model/forceair.py", "codegen/", "harness/", "dobwind/analysis/"} <= set(names)
    assert missing_layout_names() == []


def test_the_readme_check_sees_a_stale_name(tmp_path):
    for folder in LAYER_FOLDERS:
        (tmp_path / folder).mkdir()
    (tmp_path / "model" / "step.py").write_text("")
    (tmp_path / "dobwind" / "fit.py").write_text("")
    (tmp_path / "README.md").write_text("## The pipeline\n\n`model/step.py` -> fit.py, gone.py, model/old.py,"
                                        " analysis/\n\n## Next\n\nmodel/later.py\n")
    assert missing_layout_names(tmp_path) == ["analysis/", "gone.py", "model/old.py"]


# The analysis experiments see no force-air family: they go through forceair.airframe_force and
# forceair.airframe_airflow, so a family added to the step is analysed without touching them.
FAMILY_NAMES = r"\.drag\b|\bpolynomial_expr\(|\bdrag_force\(|\bbody_drag_\w+\(|\bdrag_airflow\w*\(|\bhorizontal\.terms\b"


def family_mentions(root: Path = ROOT) -> list[str]:
    import re

    found = []
    for path in sorted((root / "dobwind" / "analysis").glob("*.py")):
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if re.search(FAMILY_NAMES, line.split("#")[0]):
                found.append(f"{path.name}:{number}")
    return found


def test_analysis_names_no_force_air_family():
    assert family_mentions() == []


def test_the_family_check_sees_a_dispatch(tmp_path):
    (tmp_path / "dobwind" / "analysis").mkdir(parents=True)
    (tmp_path / "dobwind" / "analysis" / "ramp.py").write_text(
        "x = 1  # af.drag in a comment is fine\n"
        "if af.drag is not None and af.drag.frame == 'body':\n"
        "    h = polynomial_expr(af.horizontal.terms, af.horizontal.coefficients, env)\n")
    assert family_mentions(tmp_path) == ["ramp.py:2", "ramp.py:3"]
