"""Edit one value of a TOML file in its text, so that everything else (comments, order, spacing) stays
as the user wrote it: `analyze --bandwidth -o` rewrote the whole airframe from the parsed values and
lost every comment (issue #33). A key written in a form this does not edit (an inline table, a dotted
key) returns None and the caller falls back to the full dump.

The edit is checked by the caller: parsing the edited text must give the intended airframe."""
from __future__ import annotations

import re

_HEADER = re.compile(r"^\s*\[\s*([A-Za-z0-9_.\- ]+?)\s*\]\s*(#.*)?$")
_ARRAY_OF_TABLES = re.compile(r"^\s*\[\[")


def _table_lines(lines: list[str], table: str) -> tuple[int, int] | None:
    """[start, end) line indexes of the body of ``[table]``."""
    start = None
    for i, line in enumerate(lines):
        header = _HEADER.match(line)
        if header is None and not _ARRAY_OF_TABLES.match(line):
            continue
        if start is not None:
            return start, i
        if header is not None and header.group(1).replace(" ", "") == table:
            start = i + 1
    return None if start is None else (start, len(lines))


def _array_end(text: str, open_at: int) -> int | None:
    """Index just after the ']' closing the flat array opened at ``open_at`` (strings of numbers only)."""
    close = text.find("]", open_at)
    return None if close < 0 or "[" in text[open_at + 1:close] else close + 1


def replace_array(text: str, table: str, key: str, literal: str, comment: str | None = None) -> str | None:
    """``text`` with the array value of ``key`` in ``[table]`` replaced by ``literal`` (a TOML array);
    the line's trailing comment replaced by ``comment`` when given (it described the old value).
    None when the key is not written as ``key = [...]`` inside a ``[table]`` section."""
    lines = text.splitlines(keepends=True)
    span = _table_lines(lines, table)
    if span is None:
        return None
    key_line = re.compile(rf"^(\s*{re.escape(key)}\s*=\s*)\[")
    for i in range(*span):
        match = key_line.match(lines[i])
        if match is None:
            continue
        rest = "".join(lines[i:])
        end = _array_end(rest, match.end() - 1)
        if end is None:
            return None
        after = rest[end:]
        line_end = after.find("\n")
        tail = after if line_end < 0 else after[:line_end]
        if comment is not None and tail.lstrip().startswith("#"):
            spaces = tail[:len(tail) - len(tail.lstrip())] or " "
            after = spaces + "# " + comment + ("" if line_end < 0 else after[line_end:])
        return "".join(lines[:i]) + match.group(1) + literal + after
    return None
