"""tests/compile_cache.py: a repeated self-test build is copied, any change in what is built is built again,
and a test's fake compiler or patched subprocess.run always runs."""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.compile_cache import CompileCache

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="no host C compiler")

PROGRAM = '#include "answer.h"\n#include <stdio.h>\nint main(void) { printf("%d\\n", ANSWER + %d); return 0; }\n'


def _sources(folder: Path, offset: int, answer: int = 40) -> list[str]:
    folder.mkdir(exist_ok=True)
    (folder / "answer.h").write_text(f"#define ANSWER {answer}\n")
    (folder / "main.c").write_text(PROGRAM.replace("+ %d", f"+ {offset}"))
    return [str(folder / "main.c")]


def _build_and_run(cache: CompileCache, folder: Path, compiler: str = "cc") -> str:
    program = folder / "program"
    program.unlink(missing_ok=True)
    built = cache([compiler, "-std=c99", "-O1", *[str(folder / "main.c")], "-o", str(program), "-lm"], 60.0, "cc")
    assert built.returncode == 0, built.stderr
    return subprocess.run([str(program)], capture_output=True, text=True, check=True).stdout.strip()


def test_the_same_build_twice_runs_the_compiler_once(shared_selftest_builds, tmp_path):
    cache = CompileCache(shared_selftest_builds.run, tmp_path / "cache")
    (tmp_path / "cache").mkdir()
    _sources(tmp_path / "a", 2)
    _sources(tmp_path / "b", 2)
    assert _build_and_run(cache, tmp_path / "a") == "42"
    assert _build_and_run(cache, tmp_path / "b") == "42"  # other folder, same bytes: copied
    assert (cache.built, cache.reused) == (1, 1)


def test_a_changed_source_or_header_or_flag_is_built_again(shared_selftest_builds, tmp_path):
    cache = CompileCache(shared_selftest_builds.run, tmp_path / "cache")
    (tmp_path / "cache").mkdir()
    _sources(tmp_path / "a", 2)
    assert _build_and_run(cache, tmp_path / "a") == "42"
    _sources(tmp_path / "a", 3)  # one byte of the source
    assert _build_and_run(cache, tmp_path / "a") == "43"
    _sources(tmp_path / "a", 3, answer=50)  # only the header the source includes
    assert _build_and_run(cache, tmp_path / "a") == "53"
    program = tmp_path / "a" / "program"
    cache(["cc", "-std=c99", "-O2", str(tmp_path / "a" / "main.c"), "-o", str(program), "-lm"], 60.0, "cc")
    assert (cache.built, cache.reused) == (4, 0)


def test_a_fake_compiler_or_a_patched_subprocess_run_is_never_served(shared_selftest_builds, tmp_path, monkeypatch):
    cache = CompileCache(shared_selftest_builds.run, tmp_path / "cache")
    (tmp_path / "cache").mkdir()
    fake = tmp_path / "fakecc"
    fake.write_text(f"#!/bin/sh\nexec {shutil.which('cc')} \"$@\"\n")
    fake.chmod(0o755)
    _sources(tmp_path / "a", 2)
    for _ in range(2):
        assert _build_and_run(cache, tmp_path / "a", str(fake)) == "42"
    assert (cache.built, cache.reused) == (0, 0) and not os.listdir(tmp_path / "cache")
    assert _build_and_run(cache, tmp_path / "a") == "42"  # stored now
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: subprocess.CompletedProcess(a, 7, "", "patched"))
    program = tmp_path / "a" / "program"
    done = cache(["cc", "-std=c99", "-O1", str(tmp_path / "a" / "main.c"), "-o", str(program), "-lm"], 60.0, "cc")
    assert done.returncode == 7 and cache.reused == 0


def test_the_session_cache_serves_check_then_generate(shared_selftest_builds, tmp_path, capsys):
    """The suite's own use: `check` builds the self-test, `generate` of the same airframe reuses it."""
    from dobwind.cli.app import main
    from tests.helpers import M300

    def counts() -> tuple[int, int]:
        return shared_selftest_builds.built, shared_selftest_builds.reused

    before = counts()
    assert main(["check", str(M300)]) == 0
    assert main(["generate", str(M300), "-o", str(tmp_path / "c")]) == 0
    first = counts()
    assert first[1] > before[1]  # generate's gate took a program check had built
    assert main(["generate", str(M300), "-o", str(tmp_path / "d")]) == 0
    assert counts()[0] == first[0] and counts()[1] > first[1]  # and the same airframe again builds nothing
