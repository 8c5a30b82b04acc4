"""The folder compiled host libraries are cached in, and publishing a library into it."""
from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path


def cache_dir() -> Path:
    """$DOBWIND_CACHE, else $XDG_CACHE_HOME/dobwind, else ~/.cache/dobwind."""
    if os.environ.get("DOBWIND_CACHE"):
        return Path(os.environ["DOBWIND_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "dobwind"


def publish(built: Path, target: Path) -> bool:
    """Puts a library into the cache under ``target`` (a hard link, else a copy renamed into place, so
    that no reader sees a partial file); False when the folder is not usable."""
    staged = None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        handle, name = tempfile.mkstemp(prefix=f".{target.name}.", dir=target.parent)
        os.close(handle)
        staged = Path(name)
        try:
            staged.unlink()
            os.link(built, staged)
        except OSError:
            shutil.copyfile(built, staged)
        os.replace(staged, target)
        # rename() does nothing when both names are links to one file (a concurrent publisher got there
        # first with the same library): the staged name is then still there.
        staged.unlink(missing_ok=True)
        return True
    except OSError:
        if staged is not None:
            staged.unlink(missing_ok=True)
        return False
