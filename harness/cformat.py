"""CSV rows formatted by a small compiled library: the bytes of Python's `%` at a fraction of its time.

Formatting the estimate rows with `%` was a third of a replay (0.58 s of 1.66 s for an hour at 100 Hz).
The library (templates/format_rows.c.j2) handles "%.Pf", "%.Pg" and "%d" on float64 blocks; it is
compiled once and cached (harness/libcache.py) under a key of what it is made from. Without a
compiler, or for any other format, ``row_formatter`` returns None and the caller keeps using `%`.
"""
from __future__ import annotations

import ctypes
import re
from dataclasses import dataclass

import numpy as np

from dobwind.harness.libcache import load_template_library

MAX_PRECISION = 9           # one digit in the format; the scaled values stay below 2^52 (every half exact)
_FORMAT = re.compile(r"%(?:\.([0-9])([fg])|d)")
_KINDS = {"f": 0, "g": 1, "d": 2}
FIELD_BYTES = 48            # room per value the library insists on (its FIELD_ROOM) before each value
_TEMPLATE = "format_rows.c.j2"
_DOUBLE_P = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
_INT_P = np.ctypeslib.ndpointer(dtype=np.int32, flags="C_CONTIGUOUS")
_CHAR_P = np.ctypeslib.ndpointer(dtype=np.uint8, flags="C_CONTIGUOUS")


@dataclass(frozen=True)
class RowLayout:
    """Per column: the conversion (0 f, 1 g, 2 d) and its precision."""
    kinds: tuple[int, ...]
    precisions: tuple[int, ...]


def row_layout(formats: list[str]) -> RowLayout | None:
    """The layout of printf formats the library prints exactly, or None."""
    kinds, precisions = [], []
    for fmt in formats:
        match = _FORMAT.fullmatch(fmt)
        if match is None:
            return None
        kind = match.group(2) or "d"
        precision = int(match.group(1) or 0)
        if kind == "g" and precision == 0:  # Python's %.0g means %.1g; not worth a special case
            return None
        kinds.append(_KINDS[kind])
        precisions.append(precision)
    return RowLayout(tuple(kinds), tuple(precisions))


def format_library() -> ctypes.CDLL | None:
    """The compiled formatter from the cache, built on a miss; None when no compiler can build it."""
    return load_template_library(_TEMPLATE, {
        "max_precision": MAX_PRECISION, "field_room": FIELD_BYTES,
        "pow10": [f"1e{k}" for k in range(23)],  # 10^22 is the largest power of ten a double holds exactly
        "ipow10": [str(10 ** k) for k in range(MAX_PRECISION + 1)]})


class RowFormatter:
    """Formats float64 row blocks; ``format`` returns None when the caller must use `%` instead."""

    def __init__(self, lib: ctypes.CDLL, layout: RowLayout) -> None:
        lib.dobwind_format_rows.argtypes = [_DOUBLE_P, ctypes.c_long, ctypes.c_long, _INT_P, _INT_P, _CHAR_P,
                                            ctypes.c_long]
        lib.dobwind_format_rows.restype = ctypes.c_long
        self._run = lib.dobwind_format_rows
        self._kinds = np.array(layout.kinds, dtype=np.int32)
        self._precisions = np.array(layout.precisions, dtype=np.int32)
        self._buffer = np.empty(0, dtype=np.uint8)

    def format(self, block: np.ndarray) -> bytes | None:
        if block.dtype.kind != "f" or block.ndim != 2 or block.shape[1] != len(self._kinds):
            return None  # integers beyond 2^53 and other types: `%` prints them as they are
        data = np.ascontiguousarray(block, dtype=np.float64)  # float32 widens exactly, as `%` sees it
        need = data.size * FIELD_BYTES + 1
        if len(self._buffer) < need:
            self._buffer = np.empty(need, dtype=np.uint8)
        written = self._run(data, data.shape[0], data.shape[1], self._kinds, self._precisions, self._buffer,
                            len(self._buffer))
        return None if written < 0 else self._buffer[:written].tobytes()


def row_formatter(formats: list[str]) -> RowFormatter | None:
    """A compiled formatter for these column formats, or None (another format, or no compiler)."""
    layout = row_layout(formats)
    if layout is None:
        return None
    lib = format_library()
    return None if lib is None else RowFormatter(lib, layout)
