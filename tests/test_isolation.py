"""Tests leave the repository tree alone and do not depend on the current directory (issue #34).

Two pytest-xdist workers run modules side by side in one checkout, so a test that writes into the tree
(an output, a regenerated file, a cache) can race the other worker's reads of it, and a test that reads
or writes relative to the current directory passes only where it happens to be started. A representative
set of modules that run commands writing files is run in a child pytest, started from an empty folder
outside the checkout:
- it passes there (no test needs the checkout as its current directory);
- the checkout's files are byte-for-byte and mtime-for-mtime what they were (nothing written into it;
  caches Python and pytest keep for themselves are left out);
- the empty folder is still empty (nothing written relative to the current directory, which on CI is
  the checkout)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from tests.helpers import ROOT

# Modules whose tests write files through the command line or the library (generated C beside its checked-in
# copy, every output path and its temporary name, the README's example, the commands run from --help);
# their quick tests (-m "not slow"), about 10 s of CPU.
REPRESENTATIVE = ("test_codegen.py", "test_outputs.py", "test_readme.py", "test_help.py")
# Kept by Python, pytest and pip for themselves, not written by a test: left out of the snapshot.
OWN_CACHES = {".git", ".venv", "__pycache__", ".pytest_cache"}


def tree_snapshot(root: Path) -> dict[str, tuple[int, int]]:
    """Relative path -> (size, mtime in ns) for every file under ``root`` outside OWN_CACHES and egg-info."""
    found = {}
    for folder, subfolders, files in os.walk(root):
        subfolders[:] = [s for s in subfolders if s not in OWN_CACHES and not s.endswith(".egg-info")]
        for name in files:
            path = Path(folder) / name
            try:
                stat = path.lstat()
            except FileNotFoundError:  # removed while walking: a change the comparison reports anyway
                continue
            found[str(path.relative_to(root))] = (stat.st_size, stat.st_mtime_ns)
    return found


def changes(before: dict[str, tuple[int, int]], after: dict[str, tuple[int, int]]) -> list[str]:
    """``added``, ``removed`` or ``changed`` and the path, for each difference, sorted by path."""
    out = [f"added {p}" for p in after.keys() - before.keys()]
    out += [f"removed {p}" for p in before.keys() - after.keys()]
    out += [f"changed {p}" for p in before.keys() & after.keys() if before[p] != after[p]]
    return sorted(out, key=lambda line: line.split(" ", 1)[1])


def _child_env() -> dict[str, str]:
    """This environment without the parent pytest's and xdist's variables (the child is a plain run)."""
    return {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST_", "PYTHONPATH"))}


def test_representative_modules_write_nothing_into_the_checkout_and_run_from_elsewhere(tmp_path):
    cwd = tmp_path / "elsewhere"
    cwd.mkdir()
    before = tree_snapshot(ROOT)
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist", "-m", "not slow",
         f"--basetemp={tmp_path / 'basetemp'}", *(str(ROOT / "tests" / name) for name in REPRESENTATIVE)],
        cwd=cwd, env=_child_env(), capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert changes(before, tree_snapshot(ROOT)) == [], "tests wrote into the checkout"
    assert sorted(p.name for p in cwd.iterdir()) == [], "tests wrote relative to the current directory"


def test_the_representative_modules_exist():
    assert all((ROOT / "tests" / name).is_file() for name in REPRESENTATIVE)


def test_the_snapshot_sees_a_write_a_touch_and_a_removal(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "kept.txt").write_text("x")
    (tmp_path / "a" / "gone.txt").write_text("y")
    (tmp_path / "__pycache__").mkdir()
    before = tree_snapshot(tmp_path)
    assert set(before) == {"a/kept.txt", "a/gone.txt"}
    (tmp_path / "__pycache__" / "m.pyc").write_bytes(b"\0")  # Python's own cache: not a test's write
    assert changes(before, tree_snapshot(tmp_path)) == []
    os.utime(tmp_path / "a" / "kept.txt", ns=(1, before["a/kept.txt"][1] + 1_000_000))  # same bytes, rewritten
    (tmp_path / "a" / "gone.txt").unlink()
    (tmp_path / "new.txt").write_text("z")
    assert changes(before, tree_snapshot(tmp_path)) == ["removed a/gone.txt", "changed a/kept.txt", "added new.txt"]
