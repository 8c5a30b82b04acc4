"""Older ArduPilot DataFlash layouts onto the one dataflash.py reads (the survey behind the names:
docs/autopilot-logs.md, *Versions the readers accept*).

Up to ArduPilot 4.0 each EKF core logged under its own message names: EKF3 core 0 as XKF1..XKF5 and XKQ1,
core 1 as XKF6..XKF10 and XKQ2 (EKF2 likewise: NKF1..NKF5 and NKQ1, NKF6..NKF10 and NKQ2), with the same
fields as 4.1's one name per message and the core in field C. ESC telemetry came as one message per motor,
ESC1..ESC8, where 4.1 logs ESC with the motor in field Instance. The rows are the same measurements under
other names, so they are relabelled, nothing else: an old log is read exactly as its 4.1 twin would be.
"""
from __future__ import annotations

# old name -> (the 4.1 name, its core C). A name that 4.1 still uses (XKF1) is relabelled only on rows
# that have no C field, so a 4.1 log is left as it is.
PER_CORE = {
    "XKF1": ("XKF1", 0), "XKF6": ("XKF1", 1), "XKF2": ("XKF2", 0), "XKF7": ("XKF2", 1),
    "XKF4": ("XKF4", 0), "XKF9": ("XKF4", 1), "XKQ1": ("XKQ", 0), "XKQ2": ("XKQ", 1),
    "NKF1": ("NKF1", 0), "NKF6": ("NKF1", 1), "NKF2": ("NKF2", 0), "NKF7": ("NKF2", 1),
    "NKF4": ("NKF4", 0), "NKF9": ("NKF4", 1), "NKQ1": ("NKQ", 0), "NKQ2": ("NKQ", 1),
}
ESC_PER_MOTOR = {f"ESC{k}": k - 1 for k in range(1, 9)}
# Key kept on every relabelled row: the message name it had in the log, so that inspect and replay can
# name what the log holds (logged_name) while reading it under the 4.1 name.
ORIGIN = "_logged_as"
# How the note on a relabelled log starts (init repeats it in its starter's header).
LAYOUT_NOTE = "an older ArduPilot layout (one message name per EKF core or per ESC, before 4.1)"
# Names an older log may hold that the 4.1 layout has not: load_messages must ask for them.
OLD_NAMES = tuple(sorted({n for n in PER_CORE if n not in ("XKF1", "XKF2", "XKF4", "NKF1", "NKF2", "NKF4")}
                         | set(ESC_PER_MOTOR)))


def relabel(msgs: dict[str, list[dict]]) -> tuple[dict[str, list[dict]], str | None]:
    """``msgs`` (name -> rows) in the 4.1 layout, and a note naming what was relabelled (None: nothing).
    Rows keep their order within each name; merged names are sorted by TimeUS (stable)."""
    out = dict(msgs)  # every list changed below is a new one: ``msgs``'s lists are never touched
    moved: list[str] = []
    filled: set[str] = set()  # the names that gained rows: only these need sorting (a 4.1 log has none)
    for old, (new, core) in PER_CORE.items():
        rows = [r for r in msgs.get(old, []) if "C" not in r]
        if not rows:
            continue
        out[old] = [r for r in out.get(old, []) if "C" in r]
        out[new] = out.get(new, []) + [dict(r, C=core, **{ORIGIN: old}) for r in rows]
        filled.add(new)
        moved.append(f"{old} as {new} C {core}" if old != new else f"{old} as C {core}")
    esc = [(k, r) for name, k in ESC_PER_MOTOR.items() for r in msgs.get(name, [])]
    if esc:
        out["ESC"] = out.get("ESC", []) + [dict(r, Instance=k, **{ORIGIN: f"ESC{k + 1}"}) for k, r in esc]
        for name in ESC_PER_MOTOR:
            out[name] = []
        filled.add("ESC")
        names = [n for n in ESC_PER_MOTOR if msgs.get(n)]
        moved.append(f"{', '.join(names)} as ESC Instance {', '.join(str(ESC_PER_MOTOR[n]) for n in names)}")
    for name in filled:
        out[name].sort(key=lambda r: r.get("TimeUS", 0))
    if not moved:
        return out, None
    return out, f"{LAYOUT_NOTE}: read " + "; ".join(moved)


def logged_name(msgs: dict[str, list[dict]], name: str) -> str:
    """What the log called the rows read under ``name`` (core 0's, which follow_primary made the primary
    core's): the old names joined by "/" ("XKQ1", or "XKQ1/XKQ2" when the primary core moved between them),
    or ``name`` itself for rows that were not relabelled."""
    seen = sorted({r[ORIGIN] for r in msgs.get(name, []) if ORIGIN in r and r.get("C", 0) == 0})
    return "/".join(seen) if seen else name
