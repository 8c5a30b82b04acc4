"""Silence a library that prints to the process's stdout and stderr below Python.

pymavlink's DataFlash reader prints a line per skipped byte of a damaged log ("bad header 0x9b91 at
200012"), partly from compiled code that writes to file descriptors 1 and 2 directly: Python's
``contextlib.redirect_stderr`` does not see those. 4 kB of garbage in a log gave 4,132 lines on stderr,
which breaks the one-line error, and lines on stdout would break ``--json``. Here descriptors 1 and 2
themselves point at /dev/null while the library runs, and are restored afterwards, whatever happens.
"""
from __future__ import annotations

import contextlib
import os
import sys
from typing import Iterator


@contextlib.contextmanager
def quiet_fds(fds: tuple[int, ...] = (1, 2)) -> Iterator[None]:
    """Descriptors ``fds`` (and Python's sys.stdout/sys.stderr) go to /dev/null inside the block."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError, AttributeError):
            stream.flush()  # what was printed before the block must not be lost with it
    saved: list[tuple[int, int]] = []
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        for fd in fds:
            try:
                saved.append((fd, os.dup(fd)))
            except OSError:  # a closed descriptor: nothing to silence there
                continue
            os.dup2(null, fd)
        with open(os.devnull, "w") as sink, contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
            yield
    finally:
        for fd, copy in reversed(saved):
            os.dup2(copy, fd)
            os.close(copy)
        os.close(null)
