"""Numeric CSV in bounded chunks, every row with its true line number in the file.

The file is read as bytes in blocks cut at line ends. A block whose every line has the header's number
of fields, each a plain number or empty, is converted in one pass by a small compiled parser
(harness/cparse.py; each number the double nearest it, as float() gives), or by pandas' C parser where
no compiler is found (about twice as fast as ``np.loadtxt`` here); any other block (comment or blank lines inside the data, a bad cell, a
short row) is parsed line by line, which skips those lines but keeps counting them, so that an error
names the line an editor shows. Empty cells and the words nan/inf are values; other text is an error.
"""
from __future__ import annotations

import io
import math
from dataclasses import dataclass
from typing import BinaryIO, Iterator

import numpy as np

from dobwind.core.errors import InputError

BLOCK_BYTES = 1 << 23   # about 35,000 rows of a simulated log: small beside the imports, large per call
_BOM = b"\xef\xbb\xbf"


@dataclass(frozen=True)
class Block:
    data: np.ndarray   # (rows, columns) float64
    lines: np.ndarray  # (rows,) the 1-based file line of each row


@dataclass(frozen=True)
class Header:
    names: list[str]
    line: int          # its 1-based line number


_GZIP = b"\x1f\x8b"  # a gzip stream's first two bytes (RFC 1952)


def not_text(first: bytes) -> str:
    """Why a file whose bytes start with ``first`` is not read as CSV text."""
    if first.startswith(_GZIP):
        return "gzip-compressed, not CSV text: decompress it first (gunzip)"
    return "not UTF-8 text"


def _decode(raw: bytes, path: str, line: int) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(path, f"line {line}", not_text(raw) if line == 1 else "not UTF-8 text") from None


def _unquoted(name: str) -> str:
    return name[1:-1].strip() if len(name) >= 2 and name[0] == name[-1] == '"' else name


def read_header(handle: BinaryIO, path: str) -> Header:
    """Skips comment and blank lines before the header; a byte-order mark (a spreadsheet's) is not part
    of the first column's name."""
    line = 0
    for raw in handle:
        line += 1
        if line == 1 and raw.startswith(_BOM):
            raw = raw[len(_BOM):]
        text = _decode(raw, path, line).strip()
        if not text or text.startswith("#"):
            continue
        # A spreadsheet or pandas may quote the names ("t","vel_n"): the quotes are not part of them.
        names = [_unquoted(h.strip().lstrip("\ufeff")) for h in text.split(",")]
        if len(set(names)) != len(names):
            dup = next(h for h in names if names.count(h) > 1)
            raise InputError(path, f"line {line}, column {dup}", "appears twice in the header")
        return Header(names, line)
    raise InputError(path, None, "no header row")


def _pieces(handle: BinaryIO, block_bytes: int) -> Iterator[tuple[bytes, int]]:
    """Blocks of whole lines, as (buffer, end): the lines are buffer[:end] (the last may lack its
    newline). On a seekable file the bytes after the last line end are read again with the next block
    (a seek back) rather than copied into it: joining and slicing 8 MB blocks cost five times the read."""
    seekable = handle.seekable()
    rest = b""
    while True:
        block = handle.read(block_bytes)
        if not block:
            if rest:
                yield rest, len(rest)
            return
        if rest:
            block, rest = rest + block, b""
        cut = block.rfind(b"\n") + 1
        if cut == 0:  # one line longer than a block (or the last line, without its newline): keep reading
            rest = block
            continue
        if cut < len(block):
            if seekable:
                handle.seek(cut - len(block), io.SEEK_CUR)
            else:
                rest = block[cut:]
        yield block, cut


def _line_count(piece: bytes, end: int) -> int:
    return piece.count(b"\n", 0, end) + (0 if piece[end - 1] == ord("\n") else 1)


def _rows_if_regular(piece: bytes, ncols: int) -> int | None:
    """The number of lines when every line of the block has exactly ``ncols - 1`` commas, else None.

    Checked line by line (commas before each line end, by array search): a block-wide comma count let a
    long first row and a short later one through, which pandas then read with an implicit index column,
    silently shifted. A blank line (no commas) or a comment line without the row's commas fails here; a
    comment line that has them fails in the parser (its '#' is not a number)."""
    raw = np.frombuffer(piece, dtype=np.uint8)
    ends = np.flatnonzero(raw == ord("\n"))
    if not piece.endswith(b"\n"):
        ends = np.append(ends, len(piece))
    commas_before = np.searchsorted(np.flatnonzero(raw == ord(",")), ends)
    per_line = np.diff(commas_before, prepend=0)
    return len(ends) if bool(np.all(per_line == ncols - 1)) else None


def _parse_fast(piece: bytes, ncols: int) -> np.ndarray | None:
    import pandas as pd

    rows = _rows_if_regular(piece, ncols)
    if rows is None:
        return None  # a blank, comment, short or long line somewhere: the careful pass skips or names it
    try:
        frame = pd.read_csv(io.BytesIO(piece), header=None, names=range(ncols), dtype=np.float64, engine="c",
                            keep_default_na=False, na_values=["", "nan", "NaN"], skip_blank_lines=False,
                            index_col=False)
    except (ValueError, pd.errors.ParserError):
        return None
    data = frame.to_numpy(dtype=np.float64)
    return data if data.shape == (rows, ncols) else None


def _cell(text: str, path: str, line: int, column: str) -> float:
    text = text.strip()
    if text == "":
        return math.nan
    try:
        if "_" in text:  # float() takes "1_000"; the fast parser does not, and a log should not
            raise ValueError
        return float(text)
    except ValueError:
        raise InputError(path, f"line {line}, column {column}", f"not a number: {text[:40]!r}") from None


def _parse_slow(piece: bytes, first_line: int, names: list[str], path: str) -> Block:
    """Line by line: skips blank and comment lines, names the first bad cell with its file line."""
    rows: list[list[float]] = []
    lines: list[int] = []
    for k, raw in enumerate(piece.split(b"\n")):
        number = first_line + k
        text = _decode(raw, path, number).rstrip("\r")
        stripped = text.strip()
        if not stripped or stripped.startswith("#"):
            continue
        cells = text.split(",")
        if len(cells) != len(names):
            raise InputError(path, f"line {number}", f"has {len(cells)} fields, the header has {len(names)}")
        rows.append([_cell(c, path, number, names[i]) for i, c in enumerate(cells)])
        lines.append(number)
    data = np.array(rows, dtype=np.float64).reshape(len(rows), len(names))
    return Block(data, np.asarray(lines, dtype=np.int64))


def read_blocks(handle: BinaryIO, header: Header, path: str, block_bytes: int = BLOCK_BYTES,
                compiled: bool = True) -> Iterator[Block]:
    """The data rows after the header, block by block (blocks with no data rows are not yielded).
    ``compiled=False`` uses pandas even when the compiled parser is there."""
    from dobwind.harness.cparse import block_parser

    next_line = header.line + 1
    ncols = len(header.names)
    parser = block_parser() if compiled else None
    for buffer, end in _pieces(handle, block_bytes):
        count = parser.count_lines(buffer, end) if parser is not None else _line_count(buffer, end)
        data = parser.parse(buffer, ncols, count, end) if parser is not None else None
        if data is None:  # the slower passes take the lines as bytes of their own
            piece = buffer[:end] if end < len(buffer) else buffer
            data = _parse_fast(piece, ncols) if parser is None else None
        if data is not None:
            block = Block(data, np.arange(next_line, next_line + count, dtype=np.int64))
        else:
            block = _parse_slow(piece, next_line, header.names, path)
        next_line += count
        if len(block.lines):
            yield block
