"""A minimal ArduPilot DataFlash writer for tests (the format is public and simple): every message is
0xA3 0x95, a type byte and packed little-endian fields; FMT messages (type 128) declare the others."""
from __future__ import annotations

import struct
from pathlib import Path

# DataFlash format characters used here -> struct codes (Q uint64 TimeUS, B uint8, f float, d double,
# i int32, H uint16, h int16, I uint32, b int8, N char[16], Z char[64]); the scaled ones ArduPilot logs
# angles and altitudes in (c int16 and C uint16 in hundredths, e int32 and E uint32 in hundredths, L int32
# degrees in 1e-7) take the value in its own unit and store it scaled, as pymavlink's DFReader reads them.
_CODES = {"Z": "64s", "N": "16s", "Q": "Q", "B": "B", "f": "f", "d": "d", "i": "i", "I": "I", "H": "H", "h": "h", "b": "b",
          "c": "h", "C": "H", "e": "i", "E": "I", "L": "i"}
_SCALES = {"c": 100.0, "C": 100.0, "e": 100.0, "E": 100.0, "L": 1e7}
_FMT_TYPE = 128
_FIRST_TYPE = 130  # the type of the first message write_dataflash declares; the others follow in order


class Raw(int):
    """A value stored as this very integer, whatever scale its format character implies (firmware that
    logged rpm / 10 in a format c field, say)."""


def _fmt_message(msg_type: int, name: str, fmt: str, columns: list[str]) -> bytes:
    length = 3 + struct.calcsize("<" + "".join(_CODES[c] for c in fmt))
    body = struct.pack("<BB4s16s64s", msg_type, length, name.encode(), fmt.encode(), ",".join(columns).encode())
    return bytes([0xA3, 0x95, _FMT_TYPE]) + body


def _value(code: str, value):
    """A column's value as its struct code takes it (a missing one is 0 or empty text)."""
    if code in "NZ":  # char[16] text (PARM.Name), char[64] text (MSG.Message)
        return str(value or "").encode()
    if code in "fd":
        return float(value if value is not None else 0.0)
    if isinstance(value, Raw):
        return int(value)
    if code in _SCALES:
        return int(round(_SCALES[code] * (value if value is not None else 0)))
    return int(round(value if value is not None else 0))


def write_dataflash(path: Path, messages: dict[str, tuple[str, list[str]]], rows: list[tuple[str, dict]]) -> Path:
    """messages: name -> (format characters, column names; the first is TimeUS with format Q);
    rows: (name, {column: value}) in log order."""
    # FMT describing FMT itself, as ArduPilot writes it first (DFReader knows it anyway).
    parts = [bytes([0xA3, 0x95, _FMT_TYPE]) + struct.pack("<BB4s16s64s", _FMT_TYPE, 89, b"FMT", b"BBnNZ",
                                                          b"Type,Length,Name,Format,Columns")]
    # Each message type's header and one Struct for its whole body; the parts are joined once at the end
    # (adding to one bytes object copied the whole log at every row: 0.9 s for a 4 s flight).
    layouts = {}
    for k, (name, (fmt, cols)) in enumerate(messages.items()):
        parts.append(_fmt_message(_FIRST_TYPE + k, name, fmt, cols))
        layouts[name] = (bytes([0xA3, 0x95, _FIRST_TYPE + k]), struct.Struct("<" + "".join(_CODES[c] for c in fmt)),
                         list(zip(fmt, cols)))
    for name, values in rows:
        header, body, fields = layouts[name]
        parts.append(header + body.pack(*[_value(c, values.get(col)) for c, col in fields]))
    path.write_bytes(b"".join(parts))
    return path


def with_multipliers(messages: dict[str, tuple[str, list[str]]], rows: list[tuple[str, dict]],
                     mult_ids: dict[str, str], mults: dict[str, float]) -> tuple[dict, list]:
    """``messages`` and ``rows`` with the MULT and FMTU messages ArduPilot writes at a log's start (since
    3.6): ``mults`` id -> multiplier, ``mult_ids`` message name -> one multiplier id per column. For
    write_dataflash, whose type numbers FMTU names (the messages keep their order, MULT and FMTU follow)."""
    types = {name: _FIRST_TYPE + k for k, name in enumerate(messages)}
    out = dict(messages, MULT=("Qbd", ["TimeUS", "Id", "Mult"]), FMTU=("QBNN", ["TimeUS", "FmtType", "UnitIds", "MultIds"]))
    head = [("MULT", {"TimeUS": 0, "Id": ord(k), "Mult": v}) for k, v in mults.items()]
    head += [("FMTU", {"TimeUS": 0, "FmtType": types[name], "UnitIds": "", "MultIds": ids}) for name, ids in mult_ids.items()]
    return out, head + rows
