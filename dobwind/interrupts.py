"""SIGINT and SIGTERM end a command cleanly: the signal becomes an exception, so every ``with`` block
and ``except BaseException`` on the way out removes its temporaries, and the command line prints one
line and exits 128 + the signal number (no KeyboardInterrupt traceback).
"""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterator

HANDLED = (signal.SIGINT, signal.SIGTERM)


class Interrupted(BaseException):
    """Raised by the signal handler; a BaseException so that ``except Exception`` cannot swallow it."""

    def __init__(self, signo: int) -> None:
        self.signo = signo
        super().__init__(signal.Signals(signo).name)


@dataclass
class Caught:
    """Which signal arrived, if any: an exception raised inside a C extension (CasADi) can come back
    wrapped as SystemError, so the command line asks this rather than the exception's type."""
    signo: int | None = None

    @property
    def name(self) -> str:
        return signal.Signals(self.signo).name if self.signo else ""


@contextmanager
def signals_raise() -> Iterator[Caught]:
    """Within the block, SIGINT/SIGTERM raise Interrupted (once: a second signal during the cleanup is
    ignored so that the cleanup finishes). Outside the main thread, signals stay as they are."""
    caught = Caught()
    if threading.current_thread() is not threading.main_thread():
        yield caught
        return

    def handler(signo: int, _frame) -> None:
        caught.signo = signo
        for s in HANDLED:
            signal.signal(s, signal.SIG_IGN)
        raise Interrupted(signo)

    previous = {s: signal.signal(s, handler) for s in HANDLED}
    try:
        yield caught
    finally:
        for s, old in previous.items():
            signal.signal(s, old)


@contextmanager
def signals_deferred() -> Iterator[None]:
    """Holds SIGINT/SIGTERM back while a group of renames runs, so they all happen or none do; a
    signal that arrived meanwhile is delivered when the block ends."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, HANDLED)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
