"""Error types that the command line turns into one stderr line and an exit status.

A user mistake (bad airframe, bad log, bad usage) must never surface as a traceback: the code raises
``InputError`` naming the file and the key, column or line at fault; ``cli.main`` prints it and
exits 2. ``CheckFailed`` is a check that ran and said no (verify mismatch, unstable gains): exit 1.
"""
from __future__ import annotations

EXIT_OK = 0
EXIT_CHECK_FAILED = 1
EXIT_BAD_INPUT = 2


class InputError(Exception):
    """Bad input from the user: exit status 2, one line naming the file and where in it."""

    def __init__(self, source: str, where: str | None, message: str) -> None:
        self.source = source
        self.where = where
        self.message = message
        location = f"{source}: {where}" if where else source
        super().__init__(f"{location}: {message}")


class CheckFailed(Exception):
    """A check that ran and failed: exit status 1."""
