"""The generated self-test (what a port runs with ctest) must fail a build that outputs NaN.

The generated C is patched in a temporary folder so that one output is NaN on every row, then built
and run the way the self-test's header comment tells a porter to.
"""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from dobwind.codegen.generate import generate_code, write_files
from dobwind.harness.build import system_compiler
from dobwind.model.airframe import load_airframe
from dobwind.model.step import build_step
from tests.helpers import M300


@pytest.fixture(scope="module")
def m300_model():
    return build_step(load_airframe(M300))


def _run_selftest(model, precision: str, folder: Path, patch=None) -> subprocess.CompletedProcess:
    files = dict(generate_code(model.airframe, precision, model).files)
    if patch is not None:
        files["m300_wind.c"] = patch(files["m300_wind.c"])
    write_files(files, folder)
    exe = folder / "selftest"
    subprocess.run([system_compiler(), "-std=c99", "-O2", str(folder / "m300_wind.c"),
                    str(folder / "m300_wind_selftest.c"), "-o", str(exe), "-lm"], check=True, capture_output=True)
    return subprocess.run([str(exe)], capture_output=True, text=True)


def _nan_output(local: str, precision: str):
    """Replace the assignment of one output local with NaN (`<local> = t12;` -> `<local> = NAN;`)."""
    nan = "NAN" if precision == "single" else "(double)NAN"

    def patch(source: str) -> str:
        patched, count = re.subn(rf"^(\s+){local} = t\d+;$", rf"\g<1>{local} = {nan};", source, flags=re.M)
        assert count == 1, f"expected one assignment of {local} in the generated C"
        return patched
    return patch


@pytest.mark.parametrize("precision", ["single", "double"])
def test_the_unpatched_selftest_passes(m300_model, precision, tmp_path):
    done = _run_selftest(m300_model, precision, tmp_path)
    assert done.returncode == 0 and done.stdout.strip().splitlines()[-1].startswith("PASS"), done.stdout[-500:]


@pytest.mark.parametrize("precision", ["single", "double"])
def test_a_nan_wind_direction_fails_the_selftest(m300_model, precision, tmp_path):
    done = _run_selftest(m300_model, precision, tmp_path, _nan_output("wind_from_deg", precision))
    assert done.returncode == 1
    assert done.stdout.strip().splitlines()[-1].startswith("FAIL")
    assert "wind_from_deg = nan" in done.stdout

