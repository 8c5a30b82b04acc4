"""`make test` installs the system packages the tests need, as CI does, through one script
(.ci/system-deps): a fresh clone's `make test` failed on the report test's chromium (issue #33)."""
from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

from tests.helpers import ROOT

SCRIPT = ROOT / ".ci" / "system-deps"


def _stub(folder: Path, name: str, body: str) -> None:
    path = folder / name
    path.write_text(f"#!/bin/sh\n{body}\n")
    path.chmod(0o755)


def test_make_test_and_ci_share_the_one_install_script():
    makefile = (ROOT / "Makefile").read_text()
    assert re.search(r"^test: system-deps\b", makefile, re.M)
    assert re.search(r"^\$\(STAMP\): pyproject.toml \| system-deps$", makefile, re.M)  # python3-venv first
    assert re.search(r"^system-deps:\n\tbash \.ci/system-deps$", makefile, re.M)
    ci = (ROOT / ".ci" / "run").read_text()
    assert "make test" in ci and "apt-get" not in ci  # no second copy of the package list


def test_script_installs_what_is_missing_with_apt_get(tmp_path):
    """On a machine with nothing (only a shell and the stubs), as root: every package, chromium too."""
    stubs = tmp_path / "bin"
    stubs.mkdir()
    log = tmp_path / "apt.log"
    _stub(stubs, "id", "echo 0")
    _stub(stubs, "apt-get", f'echo "$@" >> {log}')
    bash = shutil.which("bash")
    result = subprocess.run([bash, str(SCRIPT)], env={"PATH": str(stubs)}, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    calls = log.read_text().splitlines()
    assert calls[0] == "update -qq"
    installed = calls[1].split()
    for package in ("chromium", "gcc", "g++", "clang", "cmake", "valgrind", "python3-venv"):
        assert package in installed


def test_script_without_root_says_what_to_install(tmp_path):
    stubs = tmp_path / "bin"
    stubs.mkdir()
    _stub(stubs, "id", "echo 1000")
    _stub(stubs, "apt-get", "exit 3")  # never called
    result = subprocess.run([shutil.which("bash"), str(SCRIPT)], env={"PATH": str(stubs)}, capture_output=True,
                            text=True)
    assert result.returncode == 0
    assert "sudo apt-get install" in result.stderr and "chromium" in result.stderr
