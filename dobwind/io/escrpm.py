"""ESC rotor speeds of an ArduPilot DataFlash log in rpm, whatever number the firmware stored (the
survey behind it: docs/autopilot-logs.md, *Versions the readers accept*).

pymavlink's DFReader returns a field by its format character alone: c, C, e and E (integers "times
100") divided by 100, every other number as stored; it uses an FMTU multiplier only to label the unit.
ArduPilot's rule, stated beside its multiplier table in AP_Logger/LogStructure.h, is the other way round:
the FMTU multiplier applies to the stored number, and the "times 100" of the format is ignored. What
ArduPilot stored in the RPM field:
- ESC1..ESC8, format c (int16), no FMTU (older DataFlash/LogStructure.h; the ArduPlane 3.8.2 log here):
  the PX4 esc_status rpm divided by 10 (DataFlash/LogFile.cpp Log_Write_ESC), which DFReader returns
  as rpm / 1000;
- ESC1..ESC8, format e (int32), FMTU multiplier B = 0.01, and 4.1's ESC alike (the 4.1 SITL log here):
  rpm times 100 (AP_BLHeli, AP_Logger::Write_ESC "rpm * 100"), which DFReader returns as rpm;
- ESC, format f, multiplier 0 = 1 (the 4.6.2 log here): rpm, returned as it is.
So a log's FMTU multiplier is applied to the stored number where the log has one, and an RPM of format c
without one is read as ten times the stored integer.
"""
from __future__ import annotations

from dobwind.io.aplayout import ESC_PER_MOTOR

# The messages that describe the others: formats, their multiplier ids, and the ids' values.
FORMAT_MESSAGES = ("FMT", "FMTU", "MULT")
RPM_MESSAGES = ("ESC",) + tuple(ESC_PER_MOTOR)
RPM_FIELD = "RPM"
_CENTI = "cCeE"  # DFReader divides these by 100 (pymavlink DFReader.py, FORMAT_TO_STRUCT)
_SAYS_NOTHING = "-?"  # FMTU ids for "no multiplier" (a string) and "not worked out yet"
_INT16_RPM_PER_UNIT = 10.0  # ESC1..ESC8 of format c: the stored integer is rpm / 10


def rpm_factor(fmt: str, mult_id: str | None, mults: dict[str, float]) -> tuple[float, str]:
    """The factor from DFReader's value of an RPM field of format character ``fmt`` (FMTU multiplier id
    ``mult_id``, None without FMTU) to rpm, and how it was decided ("" when it is 1)."""
    undo = 100.0 if fmt in _CENTI else 1.0  # DFReader's value back to the stored number
    if mult_id and mult_id not in _SAYS_NOTHING and mult_id in mults:
        factor = mults[mult_id] * undo
        return factor, "" if factor == 1.0 else f"format {fmt} times its FMTU multiplier {mults[mult_id]:g}"
    if fmt == "c":
        return _INT16_RPM_PER_UNIT * undo, "format c without an FMTU multiplier, where ArduPilot logged rpm / 10"
    return 1.0, ""


def _layouts(loaded: dict[str, list[dict]]) -> tuple[dict[str, tuple[str, str | None]], dict[str, float]]:
    """Each RPM message's format character of RPM and FMTU multiplier id, and the log's MULT ids."""
    mult_ids = {r.get("FmtType"): str(r.get("MultIds", "")) for r in loaded.get("FMTU", [])}
    # MULT logs a double cast from a float: rounded as DFReader rounds it, so 0.01 is 0.01.
    mults = {(chr(r["Id"]) if isinstance(r.get("Id"), int) else str(r.get("Id"))): float(f"{r['Mult']:.7g}")
             for r in loaded.get("MULT", []) if isinstance(r.get("Mult"), (int, float))}
    out: dict[str, tuple[str, str | None]] = {}
    for r in loaded.get("FMT", []):
        columns = str(r.get("Columns", "")).split(",")
        if r.get("Name") in RPM_MESSAGES and RPM_FIELD in columns:
            k = columns.index(RPM_FIELD)
            ids = mult_ids.get(r.get("Type"))
            out[r["Name"]] = (str(r.get("Format", ""))[k:k + 1], ids[k] if ids and k < len(ids) else None)
    return out, mults


def in_rpm(loaded: dict[str, list[dict]], notes: list[str]) -> dict[str, list[dict]]:
    """``loaded`` without its format messages, every ESC message's RPM in rpm (new rows where it was
    scaled; ``loaded`` is left as it was), and a note naming what was scaled and why."""
    layouts, mults = _layouts(loaded)
    out = {name: rows for name, rows in loaded.items() if name not in FORMAT_MESSAGES}
    said: dict[str, list[str]] = {}
    for name, (fmt, mult_id) in layouts.items():
        factor, why = rpm_factor(fmt, mult_id, mults)
        if factor != 1.0 and out.get(name):
            out[name] = [dict(r, RPM=r[RPM_FIELD] * factor) if RPM_FIELD in r else r for r in out[name]]
            said.setdefault(f"x {factor:g} ({why})", []).append(name)
    notes += [f"ESC rpm: {', '.join(names)} {RPM_FIELD} read {how}" for how, names in said.items()]
    return out
