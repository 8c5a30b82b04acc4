"""Why a ULog topic the log subscribes to came out of pyulog empty: its format definition is damaged.

pyulog drops a topic whose format ('F' message) it cannot build (an unknown field type, a bad array
size, a format that nests itself) or whose data messages do not have the size the format defines (a
field dropped or retyped), printing at most one "corruption detected" line for the whole file. Replay
then said the topic was "missing from the log", which sends a user looking for a logger setting instead
of a damaged file. This module walks the file's messages itself (u16 size, u8 type, payload; the ULog
file format of PX4's docs) and says, per topic, what is wrong with its definition.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, field

# The ULog base types and their sizes in bytes (PX4 ULog file format, "Definitions section").
BASE_SIZES = {"int8_t": 1, "uint8_t": 1, "int16_t": 2, "uint16_t": 2, "int32_t": 4, "uint32_t": 4,
              "int64_t": 8, "uint64_t": 8, "float": 4, "double": 8, "bool": 1, "char": 1}
HEADER_BYTES = 16
MAX_NESTING = 16       # PX4's deepest nesting is 2 or 3; deeper is a format naming itself
MAX_ARRAY = 0xFFFF     # pyulog's own bound on an array size


class _Damaged(Exception):
    pass


@dataclass
class _Walk:
    """What the file declares: format text by name (the last one wins, as in pyulog), the subscription
    ids per topic name, and the payload sizes of the data messages per subscription id."""
    formats: dict[str, str] = field(default_factory=dict)
    subscribed: dict[str, set[int]] = field(default_factory=dict)
    sizes: dict[int, dict[int, int]] = field(default_factory=dict)


def _text(raw: bytes) -> str:
    return raw.decode("utf-8", errors="ignore")  # as pyulog decodes names


def _walk(blob: bytes) -> _Walk:
    out, pos, end = _Walk(), HEADER_BYTES, len(blob)
    while pos + 3 <= end:
        size, kind = struct.unpack_from("<HB", blob, pos)
        payload = blob[pos + 3:pos + 3 + size]
        pos += 3 + size
        if len(payload) < size:
            break
        if kind == ord("F"):
            name, _, body = _text(payload).partition(":")
            out.formats[name] = body
        elif kind == ord("A") and size > 3:
            msg_id = struct.unpack_from("<H", payload, 1)[0]
            out.subscribed.setdefault(_text(payload[3:]).rstrip("\x00"), set()).add(msg_id)
        elif kind == ord("D") and size >= 2:
            per = out.sizes.setdefault(struct.unpack_from("<H", payload)[0], {})
            per[size - 2] = per.get(size - 2, 0) + 1
    return out


def _fields(name: str, formats: dict[str, str]) -> list[tuple[str, int, str]]:
    """(type, array size or 0, name) of each field of format ``name``."""
    out = []
    for item in (f for f in formats[name].split(";") if f):
        kind, _, fname = item.partition(" ")
        if not fname:
            raise _Damaged(f"field '{item}' has no type and name")
        base, bracket, rest = kind.partition("[")
        count = 0
        if bracket:
            try:
                count = int(rest.partition("]")[0])
            except ValueError:
                raise _Damaged(f"field {fname}: array size '{rest.partition(']')[0]}' is no number") from None
            if not 0 <= count <= MAX_ARRAY:
                raise _Damaged(f"field {fname}: array size {count}")
        out.append((base, count, fname))
    return out


def _size(name: str, formats: dict[str, str], depth: int = 0) -> int:
    """The bytes one message of format ``name`` holds, nested formats included."""
    if depth > MAX_NESTING:
        raise _Damaged(f"format {name} nests itself")
    total = 0
    for base, count, fname in _fields(name, formats):
        if base in BASE_SIZES:
            one = BASE_SIZES[base]
        elif base in formats:
            one = _size(base, formats, depth + 1)
        else:
            raise _Damaged(f"field {fname}: type {base} is neither a ULog type nor a format in the log")
        total += one * max(count, 1)
    return total


def _reason(name: str, walk: _Walk) -> str | None:
    if name not in walk.formats:
        return "no format definition for it in the log, which subscribes to it (a damaged format message)"
    try:
        fields = _fields(name, walk.formats)
        full = _size(name, walk.formats)
    except _Damaged as exc:
        return str(exc)
    if not any(f[2] == "timestamp" for f in fields):
        return "no timestamp field"
    # pyulog also takes a message without the trailing padding fields
    padding = 0
    for base, count, fname in reversed(fields):
        if not fname.startswith("_padding") or base not in BASE_SIZES:
            break
        padding += BASE_SIZES[base] * max(count, 1)
    seen: dict[int, int] = {}
    for msg_id in walk.subscribed[name]:
        for size, n in walk.sizes.get(msg_id, {}).items():
            seen[size] = seen.get(size, 0) + n
    if seen and not any(full - padding <= size <= full for size in seen):
        held = ", ".join(f"{n} message{'s' * (n != 1)} of {size}" for size, n in sorted(seen.items()))
        return f"it defines {full} bytes a message, its data messages hold other sizes ({held} bytes)"
    return None


def damaged_formats(path: str, names=None) -> dict[str, str]:
    """For each of ``names`` (None: every topic) the log subscribes to whose format definition is damaged,
    why (a phrase); the others (logged fine, or not subscribed at all: really missing) are left out."""
    try:
        with open(path, "rb") as handle:
            walk = _walk(handle.read())
    except OSError:
        return {}
    out = {}
    for name in sorted(walk.subscribed) if names is None else names:
        if name in walk.subscribed:
            why = _reason(name, walk)
            if why:
                out[name] = why
    return out
