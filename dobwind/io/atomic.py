"""Write-then-rename, so a failure never leaves a half-written file in place of a good one.

Every temporary dobwind creates is named ``.dobwind-tmp-<pid>-...``: the prefix says whose it is and
the pid says which run made it, so a later run can remove what a killed run (SIGKILL) left behind
without ever touching anything else.
"""
from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Callable, TextIO

from dobwind.core.interrupts import signals_deferred

TEMP_PREFIX = ".dobwind-tmp-"


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def public_mode(path: str | Path, directory: bool = False) -> None:
    """The permissions a plain open()/mkdir() would have given (mkstemp/mkdtemp's are owner-only)."""
    os.chmod(path, (0o777 if directory else 0o666) & ~_umask())


def temp_prefix() -> str:
    return f"{TEMP_PREFIX}{os.getpid()}-"


def new_temp_file(folder: Path, name: str) -> Path:
    """An empty temporary in ``folder`` whose name ends like ``name`` (matplotlib reads the extension)."""
    fd, tmp = tempfile.mkstemp(prefix=temp_prefix(), suffix=f"-{name}", dir=folder)
    os.close(fd)
    return Path(tmp)


def write_file_atomically(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Calls write(temporary path) beside ``path`` and renames the result into place."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = None
    try:
        with signals_deferred():  # a signal between creating and remembering the name would strand it
            tmp = new_temp_file(target.parent, target.name)
        write(tmp)
        public_mode(tmp)
        os.replace(tmp, target)
    except BaseException:
        if tmp is not None:
            tmp.unlink(missing_ok=True)
        raise
    return target


def write_text_atomically(path: str | Path, write: Callable[[TextIO], None]) -> Path:
    """Calls write(handle) on a temporary file beside ``path`` and renames it into place."""
    def fill(tmp: Path) -> None:
        with open(tmp, "w", newline="\n") as handle:
            write(handle)

    return write_file_atomically(path, fill)


def _process_start_time() -> float:
    """Wall-clock start of this process (Linux /proc, centisecond resolution); now elsewhere."""
    try:
        with open("/proc/self/stat") as handle:
            start_ticks = int(handle.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/uptime") as handle:
            uptime = float(handle.read().split()[0])
    except (OSError, ValueError, IndexError):
        return time.time()
    return time.time() - uptime + start_ticks / os.sysconf("SC_CLK_TCK")


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's live process
        return True
    return True


def remove_stale(folder: str | Path) -> list[Path]:
    """Removes temporaries a killed dobwind run left in ``folder``: only names with our prefix, whose
    run is gone and that are older than this process. Returns what it removed."""
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return []
    started = _process_start_time()
    removed = []
    for entry in entries:
        if not entry.name.startswith(TEMP_PREFIX):
            continue
        pid_text = entry.name[len(TEMP_PREFIX):].split("-", 1)[0]
        if not pid_text.isdigit() or int(pid_text) == os.getpid() or _running(int(pid_text)):
            continue
        try:
            if entry.stat(follow_symlinks=False).st_mtime >= started:
                continue
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path)
            else:
                os.unlink(entry.path)
        except OSError:
            continue  # not ours to fight over: a permission problem leaves it in place
        removed.append(Path(entry.path))
    return removed
