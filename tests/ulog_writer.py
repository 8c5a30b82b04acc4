"""A minimal ULog writer for tests (the format is public and simple): a file header, format ('F'),
information ('I'), parameter ('P'), subscription ('A') and data ('D') messages, little endian, packed fields.
A topic logged in several instances is one Topic per instance (same name and fields, its own multi_id);
its format is written once."""
from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path

_TYPES = {"uint64_t": "Q", "int64_t": "q", "uint32_t": "I", "int32_t": "i", "uint16_t": "H", "int16_t": "h",
          "uint8_t": "B", "int8_t": "b", "float": "f", "double": "d", "bool": "?", "char": "c"}


@dataclass
class Topic:
    name: str
    fields: list[tuple[str, str]]  # (type, name), e.g. ("float[4]", "q"); the first must be uint64_t timestamp
    rows: list[dict] = field(default_factory=list)
    multi_id: int = 0


def _message(kind: str, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def _pack(fields: list[tuple[str, str]], formats: dict[str, list[tuple[str, str]]], row: dict, prefix: str = "") -> bytes:
    out = b""
    for ftype, fname in fields:
        base, count = (ftype.split("[")[0], int(ftype.split("[")[1][:-1])) if "[" in ftype else (ftype, None)
        for i in range(count or 1):
            key = f"{prefix}{fname}[{i}]" if count else f"{prefix}{fname}"
            if base in _TYPES:
                code = _TYPES[base]
                value = row.get(key, 0)
                out += struct.pack("<" + code, int(round(value)) if code in "QqIiHhBb" else value)
            else:  # a nested type
                out += _pack(formats[base], formats, row, key + ".")
    return out


def _info(key: str, value: str | int) -> bytes:
    """An 'I' message: a string as char[N], an int as int32_t (PX4's ver_sw_release is one)."""
    raw = value.encode() if isinstance(value, str) else struct.pack("<i", value)
    field = f"char[{len(raw)}] {key}" if isinstance(value, str) else f"int32_t {key}"
    return _message("I", bytes([len(field)]) + field.encode() + raw)


def write_ulog(path: Path, topics: list[Topic], parameters: dict[str, float] | None = None,
               nested: dict[str, list[tuple[str, str]]] | None = None, truncate_at: int | None = None,
               info: dict[str, str | int] | None = None, int_parameters: dict[str, int] | None = None) -> Path:
    """``parameters`` are written as float, ``int_parameters`` as int32_t (PX4's integer parameters)."""
    nested = nested or {}
    blob = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 0))  # appends in place: linear time
    for name, flds in nested.items():
        blob += _message("F", f"{name}:{''.join(f'{t} {n};' for t, n in flds)}".encode())
    for topic in {t.name: t for t in topics}.values():  # one format per topic, whatever its instances
        blob += _message("F", f"{topic.name}:{''.join(f'{t} {n};' for t, n in topic.fields)}".encode())
    for key, text in (info or {}).items():
        blob += _info(key, text)
    for name, value in (parameters or {}).items():
        key = f"float {name}".encode()
        blob += _message("P", bytes([len(key)]) + key + struct.pack("<f", value))
    for name, number in (int_parameters or {}).items():
        key = f"int32_t {name}".encode()
        blob += _message("P", bytes([len(key)]) + key + struct.pack("<i", number))
    formats = dict(nested)
    for msg_id, topic in enumerate(topics):
        blob += _message("A", struct.pack("<BH", topic.multi_id, msg_id) + topic.name.encode())
    rows = sorted(((row["timestamp"], msg_id, row) for msg_id, t in enumerate(topics) for row in t.rows),
                  key=lambda r: (r[0], r[1]))
    for _, msg_id, row in rows:
        blob += _message("D", struct.pack("<H", msg_id) + _pack(topics[msg_id].fields, formats, row))
    path.write_bytes(blob[:truncate_at] if truncate_at else blob)
    return path
