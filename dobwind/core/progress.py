"""A progress bar on stderr for the long commands, shown only to a person watching a terminal.

Quiet when stderr is not a terminal (scripts, CI, pipes) and whenever the caller says so (``--json``):
the bar must never mix into machine-read output.
"""
from __future__ import annotations

import sys
from contextlib import contextmanager
from typing import Callable, Iterator

MIN_BYTES_FOR_BAR = 20 << 20  # about 5 s of replay on a loaded machine; smaller jobs finish before a bar helps


def wanted(quiet: bool = False) -> bool:
    return not quiet and sys.stderr.isatty()


@contextmanager
def byte_bar(total: int, label: str, enabled: bool) -> Iterator[Callable[[int], None] | None]:
    """Yields a function to call with each chunk's byte count, or None when no bar is shown."""
    if not enabled or total < MIN_BYTES_FOR_BAR:
        yield None
        return
    from tqdm import tqdm

    with tqdm(total=total, desc=label, unit="B", unit_scale=True, leave=False, file=sys.stderr) as bar:
        yield bar.update
