"""SIGINT and SIGTERM end a command cleanly: the signal becomes an exception, so every ``with`` block
and ``except BaseException`` on the way out removes its temporaries, and the command line prints one
line and exits 128 + the signal number (no KeyboardInterrupt traceback).
"""
from __future__ import annotations

import os
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


# The one piece of process-wide state, as signals themselves are process-wide: CasADi's SWIG wrappers
# clear a Python exception raised while they try argument conversions, so a caught signal must stay
# visible to the places that make outputs permanent (raise_if_caught before every commit).
_ACTIVE: list[Caught] = []


def raise_if_caught() -> None:
    """Raises Interrupted if a signal arrived whose exception something swallowed on the way."""
    for caught in _ACTIVE:
        if caught.signo is not None:
            raise Interrupted(caught.signo)


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
    _ACTIVE.append(caught)
    try:
        yield caught
    finally:
        _ACTIVE.remove(caught)
        for s, old in previous.items():
            signal.signal(s, old)


@contextmanager
def signals_deferred() -> Iterator[None]:
    """Holds SIGINT/SIGTERM back while a group of renames runs, so they all happen or none do; a
    signal that arrived meanwhile goes to the earlier handler when the block ends. (Swapping the
    Python handler, not pthread_sigmask: the kernel hands a blocked signal to any other thread.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending: list[int] = []
    previous = {s: signal.signal(s, lambda signo, _frame: pending.append(signo)) for s in HANDLED}
    try:
        yield
    finally:
        for s, old in previous.items():
            signal.signal(s, old)
        if pending:
            _redeliver(pending[0], previous[pending[0]])


def _redeliver(signo: int, handler) -> None:
    if callable(handler):
        handler(signo, None)
    elif handler == signal.SIG_DFL:
        os.kill(os.getpid(), signo)
