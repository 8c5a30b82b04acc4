"""Generated C: checked in and current, deterministic, strictly single precision, readable."""
from __future__ import annotations

import difflib
import os
import re
import subprocess

import pytest

from dobwind.cli.app import main
from dobwind.codegen.generate import generate_code
from dobwind.codegen.printer import CPrinter
from dobwind.model.airframe import load_airframe
from dobwind.model.airframe_toml import dumps
from tests.helpers import M300, ROOT, airframe_dict, make_airframe

GOLDEN = ROOT / "generated_c" / "m300"
UPDATE = os.environ.get("DOBWIND_UPDATE_GOLDEN") == "1"


def test_checked_in_code_is_current():
    """Fails with a diff when generated_c/m300 is stale; `make regen` (or DOBWIND_UPDATE_GOLDEN=1) refreshes."""
    code = generate_code(load_airframe(M300), "single")
    problems = []
    for name, text in code.files.items():
        path = GOLDEN / name
        if UPDATE:
            path.write_text(text)
            continue
        current = path.read_text() if path.exists() else ""
        if current != text:
            diff = "".join(difflib.unified_diff(current.splitlines(True), text.splitlines(True), str(path), "generated", n=1))
            problems.append(diff[:3000])
    assert sorted(p.name for p in GOLDEN.iterdir()) == sorted(code.files)
    assert not problems, "generated_c/m300 is stale; run `make regen`:\n" + "\n".join(problems)


@pytest.mark.parametrize("precision", ["single", "double"])
def test_generation_is_deterministic_and_has_no_paths_or_times(precision, tmp_path):
    af = make_airframe()
    first = generate_code(af, precision).files
    second = generate_code(af, precision).files
    assert first == second
    blob = "\n".join(first.values())
    assert str(ROOT) not in blob and "/tmp" not in blob
    assert not re.search(r"\d{4}-\d{2}-\d{2}|\d{2}:\d{2}:\d{2}", blob)  # no dates or times
    assert af.content_sha256 in first["testcraft_wind.h"]
    assert "DO NOT EDIT" in first["testcraft_wind.c"]


def _code_lines(text: str) -> list[str]:
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return [line for line in text.splitlines() if line.strip()]


def test_single_precision_has_no_double_anywhere():
    files = generate_code(load_airframe(M300), "single").files
    code = "\n".join(_code_lines(files["m300_wind.c"]) + _code_lines(files["m300_wind.h"]))
    assert "double" not in code
    literals = re.findall(r"(?<![\w.])(\d+\.\d*(?:e[-+]?\d+)?|\d+e[-+]?\d+)(f?)", code)
    assert literals and all(suffix == "f" for _, suffix in literals), [lit for lit in literals if not lit[1]][:5]
    calls = set(re.findall(r"\b(sin|cos|tan|exp|expm1|log|sqrt|atan2|atan|fmod|pow|fabs|fmin|fmax|floor|hypot)\s*\(", code))
    assert not calls, f"double-precision libm calls: {calls}"


def test_printer_literals():
    single, double = CPrinter("single"), CPrinter("double")
    assert single.literal(2.0) == "2.0f" and double.literal(2.0) == "2.0"
    assert single.literal(-0.5) == "(-0.5f)"
    assert float(double.literal(0.1)) == 0.1
    assert float(single.literal(1e-7)[:-1]) == pytest.approx(1e-7)


def test_header_documents_fields_units_and_status_bits():
    header = generate_code(load_airframe(M300), "single").files["m300_wind.h"]
    for text in ("float vel_ned[3]; /* m/s", "float rotor_rpm[4]; /* rev/min", "M300_WIND_STATUS_NONFINITE",
                 "M300_WIND_STATUS_BAD_DT", "M300_WIND_STATUS_TILT", "extern \"C\"", "mass            8.0 kg",
                 "typedef struct", "m300_wind_output_t last;", "int m300_wind_step("):
        assert text in header, text
    assert "acc_ned" in header and "specific_force" not in header and "float thrust;" not in header


def test_source_has_labelled_sections_with_op_counts():
    source = generate_code(load_airframe(M300), "single").files["m300_wind.c"]
    for stage in ("validate", "attitude", "thrust", "external_force", "observer", "low_pass", "force_air", "wind",
                  "check_result", "commit"):
        assert re.search(rf"/\* ---- {stage}:.*---- \*/", source), stage
    assert re.search(r"Total ops per accepted step: \d+", source)
    assert "malloc" not in source and "printf" not in source
    assert not re.search(r"\bstatic\b[^(;{]*;", source)  # no static objects (state); static functions are fine


def test_unused_mode_fields_are_absent():
    collective = airframe_dict(thrust={"source": "collective"})
    collective["observer"]["acceleration"] = "velocity"
    from dobwind.model.airframe import parse_airframe
    header = generate_code(parse_airframe(dumps(collective), "<c>"), "single").files["testcraft_wind.h"]
    assert "float thrust;" in header and "rotor_rpm" not in header
    assert "acc_ned" not in header and "specific_force[3]" not in header


def test_generate_writes_atomically_and_refuses_unstable_gains(tmp_path, capsys):
    good = tmp_path / "good.toml"
    good.write_text(dumps(airframe_dict()))
    out = tmp_path / "out"
    assert main(["generate", str(good), "-o", str(out)]) == 0
    before = {p.name: p.read_text() for p in out.iterdir()}
    assert not [p for p in out.iterdir() if p.name.startswith(".")]
    # Paper form: pole 1 - dt*lambda/(2m) = 1 - 0.02*300/5 = -0.2 is fine; 600 gives -1.4: unstable.
    bad = tmp_path / "bad.toml"
    bad.write_text(dumps(airframe_dict(**{"observer.gains": [20.0, 600.0, 30.0]})))
    capsys.readouterr()
    assert main(["generate", str(bad), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "observer.gains" in err and "axis y" in err and "unit circle" in err
    assert {p.name: p.read_text() for p in out.iterdir()} == before


def test_cmake_builds_the_library_and_runs_the_selftest(tmp_path):
    if subprocess.run(["cmake", "--version"], capture_output=True).returncode != 0:
        pytest.fail("cmake is required (installed by .ci/run)")
    build = tmp_path / "build"
    subprocess.run(["cmake", "-S", str(GOLDEN), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release"], check=True,
                   capture_output=True)
    subprocess.run(["cmake", "--build", str(build)], check=True, capture_output=True)
    done = subprocess.run(["ctest", "--output-on-failure"], cwd=build, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert (build / "libm300_wind.a").exists()


def test_single_precision_trig_helper_is_accurate(tmp_path):
    """The generated file's own sincos (single precision, no libm trig) against numpy in double, over the
    whole validated range |x| <= 1e6 (issue #16: the reduction used to lose 0.031 near 5e5 rad)."""
    import numpy as np

    from dobwind.harness.build import run

    files = generate_code(load_airframe(M300), "single").files
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    (tmp_path / "probe.c").write_text(
        '#include <stdio.h>\n#include <stdlib.h>\n#include "m300_wind.c"\n'
        "int main(int argc, char **argv) { int i; for (i = 1; i < argc; ++i) { float x = strtof(argv[i], NULL);\n"
        "  m300_wind_sincos_t r = m300_wind_sincos(x);\n"
        '  printf("%.9g %.9g %.9g\\n", (double)x, (double)r.s, (double)r.c); }\n'
        "  return 0; }\n")
    exe = tmp_path / "probe"
    run(["cc", "-std=c99", "-O2", f"-I{tmp_path}", str(tmp_path / "probe.c"), "-o", str(exe), "-lm"])
    rng = np.random.default_rng(0)
    near = np.r_[np.linspace(-7, 7, 301), [0.0, np.pi / 4, np.pi / 2, np.pi, -np.pi, 3 * np.pi / 4]]
    far = rng.uniform(-1e4, 1e4, 200)
    huge = np.r_[rng.uniform(-1e6, 1e6, 300), 5e5, -5e5, 1e6, -1e6, 999999.9375]
    # Multiples of pi/2 near the top of the range: the reduction's worst case (total cancellation).
    multiples = np.round(rng.uniform(-6.3e5, 6.3e5, 100)) * (np.pi / 2)
    for values in (near, far, huge, multiples):
        out = np.loadtxt(run([str(exe), *map(repr, values.astype(np.float32).astype(float))]).stdout.splitlines())
        x = out[:, 0]
        assert np.max(np.abs(out[:, 1] - np.sin(x))) < 2.5e-7
        assert np.max(np.abs(out[:, 2] - np.cos(x))) < 2.5e-7

@pytest.mark.parametrize("precision", ["single", "double"])
def test_the_test_vector_rows_print_each_value_as_alone(precision):
    """_fmt_rows prints each distinct value once: the rows must read as _fmt of every value, joined, with
    the values a shared print could confuse (0.0 and -0.0, NaNs of either sign, infinities, values that
    round to the same float) side by side."""
    import numpy as np

    from dobwind.codegen.generate import _fmt, _fmt_rows
    from dobwind.model.kinds import Precision

    p, printer = Precision(precision), CPrinter(Precision(precision))
    rows = np.array([[0.0, -0.0, 1.0, -1.0, np.nan, -np.nan, np.inf, -np.inf],
                     [-0.0, 0.0, 0.1, 0.1 + 1e-17, 1e-40, -1e-40, 3.0, 3.0],
                     [1.0000000001, 1.0, -0.0, -0.0, np.nan, 5e-324, 1e30, -1e30]])
    want = [", ".join(_fmt(v, p, printer) for v in row) for row in rows]
    assert _fmt_rows(rows, p, printer) == want
    assert want[0].split(", ")[:2] == ["0.0f", "(-0.0f)"] if precision == "single" else ["0.0", "(-0.0)"]
