"""`make test` runs the suite on two pytest-xdist workers, whole modules each, longest module first (issue #34).

What is checked: the make targets' pytest command lines (as make expands them, so a renamed variable or a
dropped flag fails), the dev extra that installs xdist, and tests/conftest.py's module order: its table
names only modules that exist, and the order it produces keeps each module whole and puts the long ones
first."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.conftest import MODULE_SECONDS, longest_first
from tests.helpers import ROOT
from tools.module_seconds import module_of, module_seconds, table_lines


def _pytest_lines(*args: str) -> list[str]:
    """The pytest command lines `make -n` would run for ``args`` (nothing is run)."""
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    # Without the variables of a make that runs this suite (`make test PYTEST_WORKERS=0` passes its command
    # line to sub-makes through MAKEFLAGS) or of the caller's environment: the Makefile's own defaults.
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL", "PYTEST_WORKERS")}
    done = subprocess.run(["make", "-n", "-s", *args], cwd=ROOT, env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    return [line for line in done.stdout.splitlines() if "-m pytest" in line]


@pytest.mark.parametrize("target", ["test", "test-fast"])
def test_the_make_targets_run_two_workers_by_whole_module(target):
    (line,) = _pytest_lines(target)
    assert re.search(r"(^| )-n 2( |$)", line), line
    assert "--dist loadfile" in line, line
    assert "--no-loadscope-reorder" in line, line  # else xdist reorders by test count, not by seconds


@pytest.mark.parametrize("target", ["test", "test-fast"])
def test_zero_workers_is_the_serial_run(target):
    (line,) = _pytest_lines(target, "PYTEST_WORKERS=0")
    assert " -n " not in line and "--dist" not in line, line
    (line,) = _pytest_lines(target, "PYTEST_WORKERS=3")
    assert re.search(r" -n 3 --dist loadfile", line), line


@pytest.mark.parametrize("target", ["test", "test-fast"])
def test_the_make_targets_let_python_cache_bytecode(target):
    """PYTHONDONTWRITEBYTECODE in the environment made every `dobwind` child compile the project again
    (about 0.07 s a child): the targets run pytest without it."""
    (line,) = _pytest_lines(target)
    assert line.startswith("env -u PYTHONDONTWRITEBYTECODE "), line


@pytest.mark.parametrize("target", ["test", "test-fast"])
def test_the_make_targets_run_blas_on_one_thread(target):
    """OpenBLAS starts a thread per core in each process: two workers on two cores then wait on each other's
    threads (two test_thrustscale runs side by side: 15-17 s each, 4.7 s with one thread; the Makefile)."""
    (line,) = _pytest_lines(target)
    assert re.search(r"(^| )OPENBLAS_NUM_THREADS=1 ", line), line


def test_the_fast_target_still_skips_slow_and_fuzz():
    (line,) = _pytest_lines("test-fast")
    assert '-m "not slow and not fuzz"' in line or "-m not slow and not fuzz" in line, line


def test_the_dev_extra_installs_xdist():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    assert any(re.match(r"pytest-xdist\b", req) for req in extras["dev"]), extras["dev"]


# The first pytest-xdist with --no-loadscope-reorder (its CHANGELOG, 3.8.0: "Add --no-loadscope-reorder");
# an older one refuses the Makefile's command line as an unknown option.
XDIST_WITH_NO_REORDER = (3, 8)


def test_the_dev_extra_asks_for_an_xdist_that_knows_the_makefiles_options():
    from packaging.requirements import Requirement
    from packaging.version import Version

    extras = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    (xdist,) = [Requirement(req) for req in extras["dev"] if re.match(r"pytest-xdist\b", req)]
    older = Version(f"{XDIST_WITH_NO_REORDER[0]}.{XDIST_WITH_NO_REORDER[1] - 1}.99")
    assert not xdist.specifier.contains(older), f"{xdist} allows {older}, which lacks --no-loadscope-reorder"
    assert xdist.specifier.contains(Version("{}.{}.0".format(*XDIST_WITH_NO_REORDER)))


def test_the_order_table_names_only_existing_modules():
    missing = [name for name in MODULE_SECONDS if not (ROOT / "tests" / name).is_file()]
    assert not missing, f"tests/conftest.py MODULE_SECONDS names modules that do not exist: {missing}"
    assert all(name.startswith("test_") and seconds >= 0 for name, seconds in MODULE_SECONDS.items())


@dataclass(frozen=True)
class _Item:
    """Just what longest_first reads of a pytest item."""
    path: Path
    name: str


def test_longest_first_keeps_modules_whole_and_in_order(monkeypatch):
    monkeypatch.setattr("tests.conftest.MODULE_SECONDS", {"test_b.py": 5.0, "test_c.py": 50.0})
    items = [_Item(Path(f"/x/tests/{module}"), f"t{i}") for i, module in
             enumerate(["test_a.py", "test_a.py", "test_b.py", "test_b.py", "test_c.py", "test_d.py", "test_c.py"])]
    ordered = longest_first(items)
    assert [(item.path.name, item.name) for item in ordered] == [
        ("test_c.py", "t4"), ("test_c.py", "t6"),   # 50 s first, its tests in their own order
        ("test_b.py", "t2"), ("test_b.py", "t3"),   # then 5 s
        ("test_a.py", "t0"), ("test_a.py", "t1"),   # the unlisted ones in collection order
        ("test_d.py", "t5"),
    ]


def test_the_collected_suite_is_in_table_order(pytestconfig):
    """The live session's own order: the listed modules come first, longest first."""
    session_modules = [name for name in dict.fromkeys(
        Path(str(item.path)).name for item in pytestconfig.pluginmanager.get_plugin("session").items)]
    listed = [name for name in session_modules if name in MODULE_SECONDS]
    assert listed == session_modules[:len(listed)]
    assert [MODULE_SECONDS[name] for name in listed] == sorted((MODULE_SECONDS[n] for n in listed), reverse=True)


def test_the_table_tool_sums_each_module(tmp_path):
    report = tmp_path / "suite.xml"
    report.write_text(
        '<testsuites><testsuite name="pytest">'
        '<testcase classname="tests.test_a" name="t1" time="1.25"/>'
        '<testcase classname="tests.test_b.TestX" name="t2" time="7.5"/>'
        '<testcase classname="tests.test_a" name="t3" time="2.5"/>'
        '<testcase classname="tests.test_c" name="t4" time="0.2"/>'
        '<testcase classname="conftest" name="t5" time="9"/>'
        "</testsuite></testsuites>", encoding="utf-8")
    assert module_seconds(report) == {"test_b.py": 7.5, "test_a.py": 3.75, "test_c.py": 0.2}
    assert table_lines(module_seconds(report)) == ['    "test_b.py": 8,', '    "test_a.py": 4,']
    assert module_of("tests.test_codegen.TestX") == "test_codegen.py"


@pytest.mark.parametrize("given, expected", [(None, "1"), ("3", "3")])
def test_benchmark_children_run_blas_on_one_thread_unless_told(tmp_path, monkeypatch, given, expected):
    """The benchmarks (accuracy, fieldcross, realdata) run their `dobwind` children side by side, as the
    suite's workers do: each child gets OPENBLAS_NUM_THREADS=1 unless the caller set it. The child here is a
    script standing in for the interpreter that prints what it was given."""
    from benchmarks import accuracy_run

    fake = tmp_path / "python"
    fake.write_text('#!/bin/sh\necho "threads=$OPENBLAS_NUM_THREADS"\n')
    fake.chmod(0o755)
    monkeypatch.setattr(accuracy_run.sys, "executable", str(fake))
    if given is None:
        monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    else:
        monkeypatch.setenv("OPENBLAS_NUM_THREADS", given)
    child = accuracy_run.run_child(["--version"], tmp_path)
    assert child.exit_code == 0
    assert child.stdout.strip() == f"threads={expected}"
