"""Reading an input file safely: refuse special files by type before opening them, and bound the size.

A FIFO given as an input blocks `open` until a writer appears (forever, from a careless command line),
and a device such as /dev/zero or /dev/urandom never ends, so a reader runs out of memory. Neither is a
flight log, an airframe or a folder of generated C. ``os.stat`` neither opens nor blocks: a path is
refused unless it is a regular file or a folder; a path that does not exist is left to the reader, which
names it in its own error.
"""
from __future__ import annotations

import os
import stat

from dobwind.model.errors import InputError

# Regular-file reads are bounded too: no airframe, vehicle file or header is anywhere near this.
MAX_TEXT_INPUT_BYTES = 64 * 1024 * 1024


def _kind(mode: int) -> str | None:
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def refuse_special(path: str) -> None:
    """InputError if ``path`` exists and is neither a regular file nor a folder (symlinks followed)."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):  # missing, unreadable, or a name with a NUL: the reader says so
        return
    kind = _kind(mode)
    if kind is not None:
        raise InputError(path, None, f"is {kind}, not a regular file: refusing to read it")


def read_bounded(path: str, limit: int = MAX_TEXT_INPUT_BYTES) -> bytes:
    """A regular file's bytes, refused (InputError) when it is special or larger than ``limit``."""
    refuse_special(path)
    with open(path, "rb") as handle:
        data = handle.read(limit + 1)
    if len(data) > limit:
        raise InputError(path, None, f"is larger than {limit // (1024 * 1024)} MiB: not an input of this kind")
    return data
