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
MESSAGE_TYPES = set(b"FIMPQARDLCSOB")  # the ULog message types pyulog reads
MAX_NESTING = 16       # PX4's deepest nesting is 2 or 3; deeper is a format naming itself
MAX_ARRAY = 0xFFFF     # pyulog's own bound on an array size


class _Damaged(Exception):
    pass


@dataclass(frozen=True)
class Damage:
    """What pyulog lost without a word: the parse stopped before the end (``stopped``), data messages it
    skipped (``skipped``); each a note, or None."""
    stopped: str | None = None
    skipped: str | None = None


def silent_damage(path: str, stopped_at: int, size: int, corrupt: bool) -> Damage:
    """``stopped_at``: where pyulog's parse ended; ``corrupt``: it found the file corrupt and said nothing."""
    stopped = None
    if stopped_at < size:
        stopped = (f"damaged: the parse stopped at byte {stopped_at:,} of {size:,} (a message too short for its "
                   f"own fields: a damaged length or type); the rest ({100 * (size - stopped_at) / size:.0f} % of "
                   "the file) is not read")
    return Damage(stopped, skipped_data(path) if corrupt else None)


@dataclass
class _Walk:
    """What the file declares: format text by name (the last one wins, as in pyulog), the subscription
    ids per topic name, the payload sizes of the data messages per subscription id (size -> count), and
    the first offset of each (id, size)."""
    formats: dict[str, str] = field(default_factory=dict)
    subscribed: dict[str, set[int]] = field(default_factory=dict)
    sizes: dict[int, dict[int, int]] = field(default_factory=dict)
    first: dict[tuple[int, int], int] = field(default_factory=dict)
    unreadable: int = 0               # bytes stepped over one at a time: no message starts there
    first_unreadable: int = 1 << 62


def _text(raw: bytes) -> str:
    return raw.decode("utf-8", errors="ignore")  # as pyulog decodes names


def _walk(blob: bytes) -> _Walk:
    """The messages as pyulog steps through them: by their size, but past a header of no ULog type with a
    size of 0 or above 10000 (or a type 0) one byte at a time (pyulog's _check_packet_corruption)."""
    out, pos, end = _Walk(), HEADER_BYTES, len(blob)
    while pos + 3 <= end:
        size, kind = struct.unpack_from("<HB", blob, pos)
        if kind not in MESSAGE_TYPES and (kind == 0 or size == 0 or size > 10000):
            out.unreadable += 1
            out.first_unreadable = min(out.first_unreadable, pos)
            pos += 1
            continue
        payload = blob[pos + 3:pos + 3 + size]
        at, pos = pos, pos + 3 + size
        if len(payload) < size:
            break
        if kind == ord("F"):
            parts = _text(payload).split(":")  # as pyulog splits it: a stray ':' cuts the field list there
            out.formats[parts[0]] = parts[1] if len(parts) > 1 else ""
        elif kind == ord("A") and size > 3:
            msg_id = struct.unpack_from("<H", payload, 1)[0]
            out.subscribed.setdefault(_text(payload[3:]).rstrip("\x00"), set()).add(msg_id)
        elif kind == ord("D") and size >= 2:
            msg_id = struct.unpack_from("<H", payload)[0]
            per = out.sizes.setdefault(msg_id, {})
            per[size - 2] = per.get(size - 2, 0) + 1
            out.first.setdefault((msg_id, size - 2), at)
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


def _accepted_size(name: str, walk: _Walk) -> int:
    """The payload size pyulog takes for topic ``name``: its format's without the trailing padding fields
    (pyulog drops them, and its bounds, the numpy item size and max_data_size, are then both that size);
    raises _Damaged when the format cannot be built."""
    if name not in walk.formats:
        raise _Damaged("no format definition for it in the log, which subscribes to it (a damaged format message)")
    fields = _fields(name, walk.formats)
    full = _size(name, walk.formats)
    if not any(f[2] == "timestamp" for f in fields):
        raise _Damaged("no timestamp field")
    padding = 0
    for base, count, fname in reversed(fields):
        if not fname.startswith("_padding") or base not in BASE_SIZES:
            break
        padding += BASE_SIZES[base] * max(count, 1)
    return full - padding


def _reason(name: str, walk: _Walk) -> str | None:
    try:
        want = _accepted_size(name, walk)
    except _Damaged as exc:
        return str(exc)
    seen: dict[int, int] = {}
    for msg_id in walk.subscribed[name]:
        for size, n in walk.sizes.get(msg_id, {}).items():
            seen[size] = seen.get(size, 0) + n
    if seen and want not in seen:
        held = ", ".join(f"{n} message{'s' * (n != 1)} of {size}" for size, n in sorted(seen.items()))
        return f"it defines {want} bytes a message, its data messages hold other sizes ({held} bytes)"
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


def skipped_data(path: str) -> str | None:
    """The note on data messages pyulog skipped without a word: of a size their topic's format does not
    define (a damaged length or format: one length of 65535 swallows the 64 KiB after it), or of an id no
    topic subscribes to with a readable format. None when there are none."""
    try:
        with open(path, "rb") as handle:
            blob = handle.read()
    except OSError:
        return None
    walk = _walk(blob)
    accepted: dict[int, int | None] = {}
    for name, ids in walk.subscribed.items():
        try:
            want: int | None = _accepted_size(name, walk)
        except _Damaged:
            want = None
        accepted.update({msg_id: want for msg_id in ids})
    bad = [(walk.first[(msg_id, size)], n, size) for msg_id, per in walk.sizes.items() for size, n in per.items()
           if accepted.get(msg_id) != size]
    said = []
    if bad:
        count, spanned = sum(n for _, n, _ in bad), sum(n * (size + 5) for _, n, size in bad)
        said.append(f"{count} data message(s) of a size no format in the log defines for them, or of no readable "
                    f"topic (the first at byte {min(b[0] for b in bad):,}), skipped with the {spanned:,} bytes they "
                    f"span ({100 * spanned / max(len(blob), 1):.2g} % of the file)")
    if walk.unreadable:
        said.append(f"{walk.unreadable:,} bytes that start no message (the first at byte {walk.first_unreadable:,}), "
                    "skipped with the messages they overwrote")
    return "damaged: " + "; ".join(said) if said else None
