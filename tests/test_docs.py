"""The documentation in docs/ stays true: the C++ example compiles and runs against the checked-in C,
the C snippets of the README, c-api.md and generated-c.md compile as C and as C++, and the format
reference names every column and key the code reads or writes."""
from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from dobwind.io.logs import ESTIMATE_COLUMNS, TRUTH_COLUMNS, required_columns
from dobwind.model import airframe as airframe_module
from dobwind.model.airframe import parse_airframe
from dobwind.model.airframe_toml import dumps
from tests.helpers import ROOT, airframe_dict, collective

DOCS = ROOT / "docs"
C_DIR = ROOT / "generated_c" / "m300"
SNIPPET_VARIABLES = ("float dt = 0.01f, vn = 0, ve = 0, vd = 0, an = 0, ae = 0, ad = 0, qw = 1, qx = 0, qy = 0, "
                     "qz = 0, r1 = 0, r2 = 0, r3 = 0, r4 = 0, psi_d = 0, yaw_setpoint = 0; float rpm[4] = {0, 0, 0, 0};")


def _compiler(name: str) -> str:
    found = shutil.which(name)
    assert found, f"{name} is needed (.ci/run installs it)"
    return found


def test_cpp_example_compiles_strictly_and_runs(tmp_path):
    obj = tmp_path / "m300_wind.o"
    subprocess.run([_compiler("cc"), "-std=c99", "-O2", "-c", str(C_DIR / "m300_wind.c"), "-o", str(obj)], check=True)
    exe = tmp_path / "example"
    subprocess.run([_compiler("c++"), "-std=c++11", "-Wall", "-Wextra", "-pedantic", "-Werror", f"-I{C_DIR}",
                    str(DOCS / "example.cpp"), str(obj), "-lm", "-o", str(exe)], check=True)
    done = subprocess.run([str(exe)], capture_output=True, text=True, timeout=30)
    assert done.returncode == 0, done.stdout + done.stderr
    # The hover in still air: the first sample is accepted but settling, the last trusted and calm.
    assert "first sample: status 0x40" in done.stdout
    horizontal = float(re.search(r"wind ([-0-9.]+) m/s horizontal", done.stdout).group(1))
    assert abs(horizontal) < 0.01


def _c_snippets(text: str) -> list[str]:
    return [block for block in re.findall(r"```c\n(.*?)```", text, re.S) if '#include "m300_wind.h"' in block]


@pytest.mark.parametrize("document", ["README.md", "docs/c-api.md", "docs/generated-c.md"])
@pytest.mark.parametrize("language", ["c", "c++"])
def test_c_snippets_compile_as_c_and_cpp(document, language, tmp_path):
    snippets = _c_snippets((ROOT / document).read_text())
    assert snippets, f"{document}: no C snippet using m300_wind.h"
    for i, block in enumerate(snippets):
        include, body = block.split("\n", 1)
        source = tmp_path / f"snippet{i}.{'c' if language == 'c' else 'cpp'}"
        source.write_text(f"{include}\nint use(void);\nint use(void) {{\n{SNIPPET_VARIABLES}\n{body}\nreturn 0;\n}}\n")
        standard = "-std=c99" if language == "c" else "-std=c++11"
        done = subprocess.run([_compiler("cc" if language == "c" else "c++"), standard, "-pedantic-errors", "-fsyntax-only",
                               f"-I{C_DIR}", str(source)], capture_output=True, text=True)
        assert done.returncode == 0, f"{document} snippet {i} as {language}:\n{done.stderr}"


@pytest.mark.parametrize("source, acceleration", [("rpm", "ned"), ("collective", "specific_force"), ("rpm", "velocity")])
def test_formats_page_names_every_log_column(source, acceleration):
    text = (DOCS / "formats.md").read_text()
    doc = airframe_dict(**{"observer.acceleration": acceleration})
    af = parse_airframe(dumps(collective(doc) if source == "collective" else doc), "<test>")
    for column, _ in required_columns(af):
        name = "rpm_1" if column.startswith("rpm_") else column
        assert f"`{name}`" in text, f"docs/formats.md does not name the log column {name}"
    for column in (*TRUTH_COLUMNS, "yaw_ref", "segment", *ESTIMATE_COLUMNS):
        assert f"`{column}`" in text, f"docs/formats.md does not name {column}"


def test_formats_page_names_every_airframe_key():
    text = (DOCS / "formats.md").read_text()
    tables = {name: getattr(airframe_module, name) for name in dir(airframe_module) if name.endswith("_KEYS")}
    assert len(tables) >= 8
    for table, keys in tables.items():
        for key in keys:
            if table == "TOP_KEYS" and key in ("thrust", "observer", "force_air", "filter", "limits", "envelope",
                                               "uncertainty"):
                assert f"[{key}]" in text or f"`{key}." in text, f"docs/formats.md: no [{key}] table"
                continue
            assert re.search(rf"`(\w+\.)?{re.escape(key)}`|\b{re.escape(key)}\b", text), f"docs/formats.md: key {key} ({table})"
