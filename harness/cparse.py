"""CSV blocks parsed by a small compiled library (templates/parse_rows.c.j2) instead of pandas.

pandas' C parser and its import were 0.5 s of an hour's replay, and the field-count check before it
0.1 s more. The library checks every line's field count and converts every cell in one pass, each
number to the double nearest it (what float() gives). It is compiled once and cached
(harness/libcache.py); without a compiler ``block_parser`` returns None and the reader keeps pandas.
Any block it does not take whole (a blank or comment line, a short or long row, a cell that is not a
plain number) is left to the reader's line-by-line pass, which names the line and column.
"""
from __future__ import annotations

import ctypes

import numpy as np

from dobwind.harness.libcache import load_template_library

_TEMPLATE = "parse_rows.c.j2"
_DOUBLE_P = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")


class BlockParser:
    def __init__(self, lib: ctypes.CDLL) -> None:
        lib.dobwind_parse_rows.argtypes = [ctypes.c_char_p, ctypes.c_long, ctypes.c_long, _DOUBLE_P, ctypes.c_long]
        lib.dobwind_parse_rows.restype = ctypes.c_long
        lib.dobwind_count_lines.argtypes = [ctypes.c_char_p, ctypes.c_long]
        lib.dobwind_count_lines.restype = ctypes.c_long
        self._run = lib.dobwind_parse_rows
        self._count = lib.dobwind_count_lines

    def count_lines(self, piece: bytes, end: int) -> int:
        """The lines of piece[:end], the last one with or without its newline."""
        return self._count(piece, end)

    def parse(self, piece: bytes, ncols: int, lines: int, end: int | None = None) -> np.ndarray | None:
        """(lines, ncols) float64 when every one of the ``lines`` lines of piece[:end] is a row of ncols
        numbers, else None."""
        out = np.empty((lines, ncols), dtype=np.float64)
        rows = self._run(piece, len(piece) if end is None else end, ncols, out, lines)
        return out if rows == lines else None


def block_parser() -> BlockParser | None:
    """The compiled parser, or None when no compiler can build it."""
    lib = load_template_library(_TEMPLATE, {"pow10": [f"1e{k}" for k in range(23)]})
    return None if lib is None else BlockParser(lib)
