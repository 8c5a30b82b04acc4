"""The self-test programs `generate` and `check` build, compiled once per source in a test process (issue #34).

`check` runs generate's self-test gate (dobwind/generate/selftest_gate.py) on both precisions and `generate`
runs it again on one, so a test that asks both about one airframe compiles the same two files with the same
compiler and flags twice (0.15-0.3 s each): test_range_walk.py does so at each of its 49 edges,
test_airframe_ranges.py at each corner, and every `check` of the same shipped airframe in a process builds
what the first one built. The program is a pure function of the compiler, its flags and the sources' bytes,
so every test process keeps the programs it built, keyed by exactly those (with the headers beside the
sources), and a repeated build copies the program in place of running the compiler. The program itself
always runs, and its output is the test's to judge.

Only builds that cannot be told apart from a real one are shared: the compiler must resolve to a program
under /usr or /bin (a test's fake compiler lives in its tmp_path and always runs), the build must have
succeeded and written its program (a failure is never stored), and ``subprocess.run`` must be the genuine
one (a test that patches it to simulate a hang or a missing compiler gets its patch).
"""
from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
from pathlib import Path

import pytest

GENUINE_RUN = subprocess.run
SYSTEM_PREFIXES = ("/usr/", "/bin/")


def _system_compiler(program: str) -> str | None:
    """The compiler's resolved path when it is an installed program, else None (never shared)."""
    found = shutil.which(program)
    if found is None:
        return None
    real = os.path.realpath(found)
    return real if real.startswith(SYSTEM_PREFIXES) else None


class CompileCache:
    """selftest_gate._run with its builds shared: ``built`` counts real compiler runs, ``reused`` copies."""

    def __init__(self, run, folder: Path):
        self.run, self.folder, self.built, self.reused = run, folder, 0, 0

    def key(self, argv: list[str]) -> tuple[str, Path] | None:
        """(the content key, the program's path) for a build the cache may serve, else None."""
        if "-o" not in argv or argv.index("-o") + 1 >= len(argv) or subprocess.run is not GENUINE_RUN:
            return None
        compiler = _system_compiler(argv[0])
        if compiler is None:
            return None
        out = argv.index("-o") + 1
        digest = hashlib.sha256(compiler.encode())
        for position, word in enumerate(argv[1:], start=1):
            if position == out:
                digest.update(b"\0<program>")
            elif word.endswith(".c") and Path(word).is_file():
                # a source by its name and bytes, not its folder (check and generate write to different
                # ones), and every header beside it (the step's own, which the sources include)
                for path in [Path(word), *sorted(Path(word).parent.glob("*.h"))]:
                    digest.update(b"\0" + path.name.encode() + b"\0" + path.read_bytes())
            else:
                digest.update(b"\0" + word.encode())
        return digest.hexdigest(), Path(argv[out])

    def __call__(self, argv: list[str], timeout_s: float, what: str) -> subprocess.CompletedProcess:
        found = self.key(argv)
        if found is None:
            return self.run(argv, timeout_s, what)
        key, program = found
        stored = self.folder / key
        if stored.is_file():
            self.reused += 1
            shutil.copy2(stored, program)
            return subprocess.CompletedProcess(argv, 0, "", "")
        self.built += 1
        done = self.run(argv, timeout_s, what)
        if done.returncode == 0 and program.is_file():
            shutil.copy2(program, stored)
        return done


@pytest.fixture(scope="session", autouse=True)
def shared_selftest_builds(tmp_path_factory: pytest.TempPathFactory):
    """The process's CompileCache in place of selftest_gate._run for the whole session (a test that
    patches _run itself still gets its own)."""
    from dobwind.generate import selftest_gate

    cache = CompileCache(selftest_gate._run, tmp_path_factory.mktemp("selftest_builds"))
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(selftest_gate, "_run", cache)
        yield cache
