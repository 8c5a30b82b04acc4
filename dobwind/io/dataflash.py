"""ArduPilot DataFlash logs (`.bin`) onto the estimator's inputs, read with pymavlink's DFReader
(optional dependency group `ardupilot`).

Messages (EKF3 names; EKF2 logs use the older names in brackets):
- ground velocity NED: XKF1.VN/VE/VD of the primary core [NKF1, core 0 by name]. EKF3 runs one core per
  IMU and may switch which one the vehicle flies on: every core logs the primary's index in XKF4.PI,
  and each XKF1/XKQ/XKF2 row is taken from the core that was primary at its time (core 0 when the log
  has no XKF4.PI);
- attitude: XKQ.Q1..Q4 = (w, x, y, z), primary core [NKQ1 or NKQ]. XKQ excludes AHRS_TRIM, unlike ATT and
  XKF1's angles (1.06 deg apart on a real ArduCopter 4.6.2 log): the force must be rotated by the
  attitude the EKF fused, not the trimmed one;
- specific force (body FRD): IMU.AccX/Y/Z, instance I = 0 (older logs: the message IMU), with XKQ;
- NED acceleration: PSCN.AN/PSCE.AE/PSCD.AD where the position controller logs them, else the IMU's
  specific force rotated by XKQ plus gravity (said in a note);
- rotor speeds: ESC.RPM per Instance. Instance k is servo output k + 1, so with ArduPilot's default
  output mapping (SERVOn_FUNCTION = Motor n) it is motor k + 1, and it becomes the airframe's rotor
  k + 1. Reports are interpolated and may be up to ROTOR_MAX_GAP_S apart (as for PX4);
- collective thrust: CTUN.ThO / CTUN.ThH (the learned hover throttle) times m g;
- heading frame: ATT.DesYaw (deg), else the vehicle's own yaw;
- ArduPilot's wind, for comparison: XKF2.VWN/VWE, primary core [NKF2];
- a SITL log's simulated wind, for comparison: PARM SIM_WIND_* and the barometer altitude (BARO, else
  CTUN.BAlt, POS, XKF1), evaluated by dobwind/io/sitlwind.py.
On the ground: EV events (LAND_COMPLETE 18, LAND_COMPLETE_MAYBE 17 and DISARMED 11 start it,
NOT_LANDED 28 ends it; a log starts on the ground); without EV messages, rows where CTUN.ThO is 0
(motors at idle or stopped). Rows are resampled onto a uniform clock at the observer's rate as the ULog
reader does (gaps beyond each message's own tolerance, resample.GapPolicy: NO_DATA; ESCs at 0 rpm while
airborne: NO_DATA, named).
"""
from __future__ import annotations

import contextlib
import math
import os
import tempfile
from dataclasses import dataclass
from typing import Iterator

import numpy as np

from dobwind.core.errors import InputError
from dobwind.io.quietfd import quiet_fds
from dobwind.io.dfwalk import DATAFLASH_MAGIC, Undeclared, readable, undeclared_headers
from dobwind.io.logs import FlightLog
from dobwind.model.airframe import Airframe
from dobwind.io.bridge import blanked, bridge, largest_silences
from dobwind.io.resample import (ROTOR_MAX_GAP_S, AutopilotFlight, blank, bracketing, count_note, hold,
                              interp, quaternions, source_gaps, topic_tolerances, truncated_note, uniform_clock)
from dobwind.io.vehiclekind import MULTIROTORS_ONLY, ardupilot_not_multirotor, firmware
from dobwind.io.densitystep import DensityStep, find_step
from dobwind.io.sitlwind import MESSAGES as SITL_MESSAGES, SitlLog, describe as describe_sitl, sitl_from_messages
from dobwind.io.aplayout import OLD_NAMES, logged_name, relabel
from dobwind.io.escrpm import FORMAT_MESSAGES, in_rpm
from dobwind.model.signals import log_signals

# (role, candidates as (message, instance field or None, instance value)), first found wins.
# Older layouts (per-core names, ESC1..ESC8) are relabelled to these first (aplayout.py); a row without C
# is core 0's. EKF2's names follow the primary core as EKF3's do (NKF4.PI).
VELOCITY = (("XKF1", "C", 0), ("NKF1", "C", 0))
ATTITUDE = (("XKQ", "C", 0), ("NKQ", "C", 0))  # NKQ1 (EKF2 before 4.1) is relabelled NKQ C 0
AP_WIND = (("XKF2", "C", 0), ("NKF2", "C", 0))
IMU = (("IMU", "I", 0), ("IMU", None, 0))
EV_GROUND = {11: True, 17: True, 18: True, 28: False}  # DISARMED, LAND_COMPLETE_MAYBE/_COMPLETE, NOT_LANDED
WANTED = ("XKF1", "NKF1", "XKQ", "NKQ1", "NKQ", "XKF2", "NKF2", "IMU", "ESC", "CTUN", "ATT", "EV",
          "PSCN", "PSCE", "PSCD", "XKF4")
CORE_MESSAGES = ("XKF1", "XKQ", "XKF2")  # logged per EKF3 core (field C)
# (the message whose PI names the primary core, the messages logged per core, the estimator)
EKF_FAMILIES = (("XKF4", CORE_MESSAGES, "EKF3"), ("NKF4", ("NKF1", "NKQ", "NKF2"), "EKF2"))
# Read besides WANTED: older layouts' names, and EKF2's primary-core marker.
LAYOUT_EXTRA = OLD_NAMES + ("NKF4",)
# Read besides those for in_one_layout: the formats and multipliers that say what ESC RPM holds (escrpm.py).
LAYOUT_FORMATS = LAYOUT_EXTRA + FORMAT_MESSAGES


@dataclass(frozen=True)
class FileNotes:
    """What the walk that load_messages makes anyway says of the file: cut short, damaged (None: neither)."""
    truncated: str | None = None
    damaged: str | None = None


def load_messages(path: str, wanted: tuple[str, ...] = WANTED) -> dict[str, list[dict]]:
    """Every wanted message as a list of field dicts; DFReader prints to stdout, which --json needs."""
    return read_messages(path, wanted)[0]


def read_messages(path: str, wanted: tuple[str, ...] = WANTED) -> tuple[dict[str, list[dict]], FileNotes]:
    """load_messages, with the notes on the file from the same walk (truncation() and damage() walk it
    again: 60 ms for a 3.5 MB log)."""
    try:
        from pymavlink import DFReader
    except ImportError:  # pragma: no cover - the ardupilot extra is part of `make setup`
        raise InputError(path, None, "reading DataFlash needs pymavlink (pip install 'dobwind[ardupilot]')") from None
    _require_magic(path)
    blob = _read(path)
    undeclared = undeclared_headers(path, blob)
    notes = _notes(undeclared, len(blob))
    out: dict[str, list[dict]] = {name: [] for name in wanted}
    try:
        # DFReader prints a line per skipped byte of a corrupt log ("bad header ...", partly from compiled
        # code, to the descriptors themselves): hundreds of thousands for a damaged file. The outcome is
        # judged from the messages found instead.
        with quiet_fds(), _readable_copy(blob, undeclared, path) as source:
            reader = DFReader.DFReader_binary(source, zero_time_base=False)
            while True:
                msg = reader.recv_match(type=list(wanted))
                if msg is None:
                    break
                row = _with_time_us(msg.to_dict())
                if _placeable(msg.get_type(), row):
                    out[msg.get_type()].append(row)
            _close(reader)
    except OSError as exc:
        raise InputError(path, None, f"cannot read: {exc.strerror}") from None
    except Exception as exc:  # DFReader raises many kinds on corrupt files
        raise InputError(path, None, f"not a readable DataFlash log ({type(exc).__name__}: {str(exc)[:80]})") from None
    return out, notes


def _notes(undeclared: Undeclared, size: int) -> FileNotes:
    return FileNotes(truncated_note(size) if undeclared.ends_inside else None, undeclared.note(size))


def _with_time_us(row: dict) -> dict:
    """The row with TimeUS: older firmware stamped some messages (ESC1..ESC8 among them) in TimeMS."""
    if "TimeUS" not in row and isinstance(row.get("TimeMS"), (int, float)):
        row["TimeUS"] = row["TimeMS"] * 1000
    return row


# Messages read for what they say, not when: kept without a time (older firmware logs PARM and MSG
# without TimeUS; the format messages describe the others).
UNTIMED = ("PARM", "MSG") + FORMAT_MESSAGES


def _placeable(name: str, row: dict) -> bool:
    """Whether a row can be placed on the log's clock: a finite number in TimeUS. A damaged FMT (its
    column list emptied or renamed) gives rows without it, which every stream, the ground state and
    inspect's rates would otherwise look up and fail on (KeyError, a traceback); a message in UNTIMED
    is kept whatever its time."""
    stamp = row.get("TimeUS")
    number = isinstance(stamp, (int, float)) and not isinstance(stamp, bool)
    return name in UNTIMED or (number and math.isfinite(stamp))


def _read(path: str) -> bytes:
    try:
        with open(path, "rb") as handle:
            return handle.read()
    except OSError as exc:
        raise InputError(path, None, f"cannot read: {exc.strerror}") from None


@contextlib.contextmanager
def _readable_copy(blob: bytes, undeclared: Undeclared, path: str) -> Iterator[str]:
    """``path`` itself, or, when it holds headers of undeclared types (at which DFReader stops reading,
    dfwalk.py), a temporary copy with them blanked, removed afterwards."""
    if not undeclared.headers:
        yield path
        return
    handle, name = tempfile.mkstemp(suffix=".bin", prefix="dobwind-df-")
    try:
        with os.fdopen(handle, "wb") as out:
            out.write(readable(blob, undeclared))
        yield name
    finally:
        with contextlib.suppress(OSError):
            os.remove(name)


def _walk_notes(path: str) -> FileNotes:
    try:
        blob = _read(path)
        return _notes(undeclared_headers(path, blob), len(blob))
    except InputError:  # unreadable or a corrupt FMT: load_messages has said so already
        return FileNotes()


def damage(path: str) -> str | None:
    """The note on headers of undeclared types that load_messages skipped, or None (read_messages gives it
    without a second walk)."""
    return _walk_notes(path).damaged


def _require_magic(path: str) -> None:
    """A file that does not start like a DataFlash log (a CSV renamed .bin, say) is refused in one line
    before DFReader scans it byte by byte."""
    try:
        with open(path, "rb") as handle:
            head = handle.read(len(DATAFLASH_MAGIC))
    except OSError as exc:
        raise InputError(path, None, f"cannot read: {exc.strerror}") from None
    if not head:
        raise InputError(path, None, "is empty (0 bytes): not a DataFlash log (an interrupted copy or download?)")
    if head != DATAFLASH_MAGIC:
        raise InputError(path, None, "not a DataFlash log: it does not start with the 0xA3 0x95 message header")


def _close(reader) -> None:
    """DFReader keeps its file and a memory map open until close() (a leaked file per log read)."""
    try:
        reader.close()
    except Exception:  # noqa: BLE001 - closing is best effort; the messages are already read
        pass


def messages_found(path: str) -> dict[str, int]:
    """How many of each message the estimator could use are in the log (0: missing)."""
    return {name: len(rows) for name, rows in load_messages(path).items()}


def in_one_layout(loaded: dict[str, list[dict]], notes: list[str]) -> dict[str, list[dict]]:
    """The WANTED messages of ``loaded`` (read with WANTED + LAYOUT_FORMATS) in ArduPilot 4.1's layout
    (aplayout.relabel), ESC RPM in rpm (escrpm.in_rpm, which drops the format messages), reduced to the
    primary EKF core (follow_primary); other names pass through."""
    msgs, said = relabel(in_rpm(loaded, notes))  # new dicts: ``loaded`` is left as it was
    if said:
        notes.append(said)
    return follow_primary(msgs, notes)


def follow_primary(msgs: dict[str, list[dict]], notes: list[str]) -> dict[str, list[dict]]:
    """Each EKF's per-core messages (EKF_FAMILIES) reduced to the primary core's rows."""
    for marker, names, ekf in EKF_FAMILIES:
        msgs = _follow(msgs, marker, names, ekf, notes)
    return msgs


def _follow(msgs: dict[str, list[dict]], marker: str, names: tuple[str, ...], ekf: str,
            notes: list[str]) -> dict[str, list[dict]]:
    """The per-core messages reduced to the primary core's rows, relabelled core 0 (what VELOCITY,
    ATTITUDE and AP_WIND select). The primary at a row's time is the PI of the last marker (XKF4) at or
    before it (the first marker's before that), by the stamps' order, not the log's. Without the marker's
    PI the log is left as it is: core 0. A row without a stamp (load_messages has turned TimeMS into
    TimeUS) cannot be placed in time: left out, as pick_stream leaves it out."""
    marks = sorted((r["TimeUS"], int(r["PI"])) for r in msgs.get(marker, []) if "PI" in r and "C" in r and "TimeUS" in r)
    if not marks:
        return msgs
    t_mark = np.array([m[0] for m in marks], dtype=float)
    core = np.array([m[1] for m in marks])
    out = dict(msgs)
    for name in names:
        rows = [r for r in msgs.get(name, []) if "C" in r and "TimeUS" in r]
        if not rows:
            continue
        idx = np.clip(np.searchsorted(t_mark, [r["TimeUS"] for r in rows], side="right") - 1, 0, None)
        out[name] = [dict(r, C=0) for r, want in zip(rows, core[idx]) if r["C"] == want]
    used = np.unique(core)
    switches = int(np.count_nonzero(np.diff(core)))
    notes.append(f"{ekf} primary core from {marker}.PI: core {used[0]} throughout" if switches == 0 else
                 f"{ekf} primary core from {marker}.PI: {switches} switch(es) among cores {', '.join(map(str, used))}; "
                 f"{', '.join(names)} follow it")
    return out


def pick_stream(msgs: dict[str, list[dict]], candidates, fields: list[str]) -> tuple[str, dict] | None:
    for name, inst_field, inst in candidates:
        rows = [r for r in msgs.get(name, []) if (inst_field is None or r.get(inst_field, inst) == inst)
                and "TimeUS" in r]  # a row with no time cannot be placed on the clock
        if len(rows) >= 2 and all(f in rows[0] for f in fields):
            t = np.array([r["TimeUS"] for r in rows], dtype=float) * 1e-6
            order = np.argsort(t, kind="stable")
            keep = order[np.r_[True, np.diff(t[order]) > 0]]  # duplicated stamps carry no new instant
            return name, {"t": t[keep], **{f: np.array([rows[i][f] for i in keep], dtype=float) for f in fields}}
    return None


def _require(path: str, found, what: str, names: str):
    if found is None:
        raise InputError(path, f"message {names}", f"missing from the log ({what})")
    return found


def _pick(path: str, msgs, candidates, fields: list[str], what: str, names: str) -> tuple[str, dict]:
    """pick_stream, or exit 2 in one line: naming the fields when a candidate is logged without them (a
    layout this reader does not know), else the messages as missing."""
    found = pick_stream(msgs, candidates, fields)
    if found is not None:
        return found
    for name, _, _ in candidates:
        rows = msgs.get(name) or []
        lacking = [f for f in fields if rows and f not in rows[0]]
        if lacking:
            raise InputError(path, f"message {name}", f"logged without field {', '.join(lacking)} ({what}): a layout "
                             "this reader does not know")
    return _require(path, found, what, names)


def _esc_streams(path: str, msgs, rotors: int) -> list[dict]:
    streams = []
    for k in range(rotors):
        found = pick_stream({"ESC": [r for r in msgs["ESC"] if r.get("Instance") == k]}, (("ESC", None, 0),), ["RPM"])
        streams.append(_require(path, found, f"rotor speed of motor {k + 1}: ESC telemetry", f"ESC Instance {k}")[1])
    return streams


def ground_events(msgs) -> tuple[np.ndarray, np.ndarray]:
    """The EV events that change the ground state: their times (s) and whether each puts the vehicle on the
    ground, in time order (the lookups below are binary searches); among equal stamps in the log's order, so
    the last one written wins. A log may hold them out of order (a buffer flushed late, a damaged stamp)."""
    events = [(r["TimeUS"] * 1e-6, EV_GROUND[r["Id"]]) for r in msgs["EV"] if r.get("Id") in EV_GROUND]
    t_ev = np.array([e[0] for e in events], dtype=float)
    state = np.array([e[1] for e in events], dtype=bool)
    order = np.argsort(t_ev, kind="stable")
    return t_ev[order], state[order]


def _ground(msgs, clock: np.ndarray, notes: list[str]) -> np.ndarray:
    t_ev, state = ground_events(msgs)
    if len(t_ev):
        idx = np.searchsorted(t_ev, clock, side="right") - 1
        ground = np.where(idx >= 0, state[np.clip(idx, 0, None)], True)  # a log starts on the ground
        source = "EV landing events"
    elif msgs["CTUN"] and "ThO" in msgs["CTUN"][0]:
        ctun = pick_stream(msgs, (("CTUN", None, 0),), ["ThO"])[1]
        ground = hold(ctun, ["ThO"], clock)[:, 0] <= 0.0
        source = "CTUN.ThO at 0 (no EV events)"
    else:
        notes.append("no EV events and no CTUN.ThO: every instant is treated as airborne")
        return np.zeros(len(clock), dtype=bool)
    if ground.any():
        notes.append(count_note(ground, f"on the ground ({source})", "LANDED"))
    return ground


def read_dataflash(path: str, af: Airframe, rate_hz: float | None = None, bridge_gaps: bool = False) -> AutopilotFlight:
    loaded, said = read_messages(path, WANTED + LAYOUT_FORMATS + tuple(m for m in SITL_MESSAGES + ("MSG", "BARO")
                                                                      if m not in WANTED))
    _refuse_other_vehicles(path, loaded)
    sitl, sitl_notes = _sitl(path, loaded)
    notes = ["messages " + ", ".join(f"{n} {len(r)}" for n, r in loaded.items() if r and n in WANTED + LAYOUT_EXTRA)
             + "; not in the log: " + (", ".join(n for n in WANTED if not loaded[n]) or "none")] + sitl_notes
    msgs = in_one_layout({name: loaded[name] for name in WANTED + LAYOUT_FORMATS}, notes)
    msgs["BARO"] = loaded["BARO"]  # for the collective thrust's density step only (densitystep.py)
    vel_name, vel = _pick(path, msgs, VELOCITY, ["VN", "VE", "VD"], "ground velocity", "XKF1 (or NKF1)")
    att_name, att = _pick(path, msgs, ATTITUDE, ["Q1", "Q2", "Q3", "Q4"], "attitude", "XKQ (or NKQ1, NKQ)")
    used = {logged_name(msgs, vel_name): vel, logged_name(msgs, att_name): att}  # named as the log names them
    imu = None
    if log_signals(af).specific_force or (log_signals(af).ned_acceleration and not msgs["PSCN"]):
        imu = _require(path, pick_stream(msgs, IMU, ["AccX", "AccY", "AccZ"]), "specific force", "IMU")[1]
        used["IMU"] = imu
    psc = None
    if log_signals(af).ned_acceleration and msgs["PSCN"]:
        psc = [_require(path, pick_stream(msgs, ((m, None, 0),), [f]), "NED acceleration", m)[1]
               for m, f in (("PSCN", "AN"), ("PSCE", "AE"), ("PSCD", "AD"))]
        used.update(PSCN=psc[0], PSCE=psc[1], PSCD=psc[2])
    escs, ctun = [], None
    if log_signals(af).rotor_speeds:
        escs = _esc_streams(path, msgs, af.thrust.rotors)
    else:
        ctun = _pick(path, msgs, (("CTUN", None, 0),), ["ThO", "ThH"], "collective thrust", "CTUN (ThO, ThH)")[1]
        used["CTUN"] = ctun
    streams = list(used.values()) + escs
    clock = uniform_clock(path, [s["t"] for s in streams], rate_hz or 1.0 / af.observer.sample_time_s)
    esc_names = {f"ESC {k}": s["t"] for k, s in enumerate(escs)}
    tolerances, slow = topic_tolerances({**{name: s["t"] for name, s in used.items()}, **esc_names},
                                        af.limits.max_dt_s, {name: ROTOR_MAX_GAP_S for name in esc_names})
    notes += slow
    no_data, culprits = source_gaps(tolerances, clock)
    gappy = no_data.copy()
    if no_data.any():
        notes.append(count_note(no_data, f"with a message gap (longer than max_dt {af.limits.max_dt_s:g} s or, for a "
                                         f"slow message, than its own tolerance; ESC: {ROTOR_MAX_GAP_S:g} s; by "
                                         f"message: {culprits})", "NO_DATA"))
    cols = _columns(af, vel, att, imu, psc, escs, ctun, msgs, clock, notes)
    landed = _ground(msgs, clock, notes)
    if escs:
        dead = [bracketing(s["t"], s["RPM"] == 0, clock) & ~landed & ~no_data for s in escs]
        bad = np.any(dead, axis=0)
        if bad.any():
            names = ", ".join(f"ESC {k + 1} (0 rpm)" for k, d in enumerate(dead) if d.any())
            notes.append(count_note(bad, f"airborne without rotor speeds from ESC telemetry: {names}", "NO_DATA"))
            no_data |= bad
    wind = pick_stream(msgs, AP_WIND, ["VWN", "VWE"])
    ap_wind = None if wind is None else (f"ArduPilot {wind[0]}", wind[1]["t"] - clock[0],
                                         np.column_stack([wind[1]["VWN"], wind[1]["VWE"], np.zeros(len(wind[1]["t"]))]))
    bridged = None
    if bridge_gaps:
        bridged, note = bridge(af, tolerances, clock, gappy, landed | (no_data & ~gappy), ("CTUN",))
        notes += note
    return AutopilotFlight(FlightLog(path, blank(cols, blanked(no_data, landed, bridged))), no_data, landed, ap_wind,
                           tuple(notes), float(clock[0]), bridged=bridged,
                           silences=largest_silences(tolerances, clock), sitl=sitl, warnings=_cut(path, clock, said))




def truncation(path: str) -> str | None:
    """How the file ends, when its last message is cut off (DFReader stops there silently, as pyulog does
    for a ULog): the message headers (0xA3 0x95, type) walked with the lengths the FMT messages declare
    (dfwalk.undeclared_headers). None for a file that ends on a message boundary, and for one whose
    messages cannot be walked (a corrupt byte mid-file: that is not a cut end). read_messages gives it
    without a second walk."""
    return _walk_notes(path).truncated


def _cut(path: str, clock: np.ndarray, said: FileNotes) -> tuple[str, ...]:
    cut, damaged = said.truncated, said.damaged
    return ((f"{path}: {cut} ({clock[-1] - clock[0]:.2f} s readable)",) if cut else ()) + \
        ((f"{path}: {damaged}",) if damaged else ())


def _refuse_other_vehicles(path: str, loaded: dict[str, list[dict]]) -> None:
    """A plane's log failed on a missing CTUN.ThO, or (one that logs it) would be replayed as a copter."""
    params = {str(r.get("Name")): float(r["Value"]) for r in loaded["PARM"] if isinstance(r.get("Value"), (int, float))}
    why = ardupilot_not_multirotor(firmware(loaded["MSG"]), params)
    if why:
        raise InputError(path, "vehicle", f"{why}; {MULTIROTORS_ONLY}")


def _sitl(path: str, msgs: dict[str, list[dict]]) -> tuple[SitlLog | None, list[str]]:
    """An ArduPilot SITL log's simulated wind (dobwind/io/sitlwind.py), for replay to compare with; a SITL
    log without an altitude to evaluate its profile at is replayed all the same, and a note says why
    there is no comparison."""
    try:
        sitl = sitl_from_messages(path, msgs)
    except InputError as exc:
        return None, [f"SIM_WIND_* parameters but no simulator wind to compare with: {exc.message}"]
    if sitl is None:
        return None, []
    note = f"ArduPilot SITL: the simulator's wind from its parameters ({describe_sitl(sitl)})"
    if sitl.turbulent():
        note += "; SIM_WIND_TURB > 0: its turbulence is not in the log, the comparison is with its mean wind"
    return sitl, [note]


def _columns(af: Airframe, vel, att, imu, psc, escs, ctun, msgs, clock: np.ndarray, notes: list[str]) -> dict:
    cols: dict[str, np.ndarray] = {"t": clock - clock[0]}
    v = interp(vel, ["VN", "VE", "VD"], clock)
    cols.update(vel_n=v[:, 0], vel_e=v[:, 1], vel_d=v[:, 2])
    q = quaternions(att["t"], np.column_stack([att[f"Q{i}"] for i in range(1, 5)]), clock)
    cols.update(q_w=q[:, 0], q_x=q[:, 1], q_y=q[:, 2], q_z=q[:, 3])
    sf = interp(imu, ["AccX", "AccY", "AccZ"], clock) if imu is not None else None
    if log_signals(af).specific_force:
        cols.update(sf_x=sf[:, 0], sf_y=sf[:, 1], sf_z=sf[:, 2])
    elif log_signals(af).ned_acceleration and psc is not None:
        cols.update(acc_n=np.interp(clock, psc[0]["t"], psc[0]["AN"]), acc_e=np.interp(clock, psc[1]["t"], psc[1]["AE"]),
                    acc_d=np.interp(clock, psc[2]["t"], psc[2]["AD"]))
    elif log_signals(af).ned_acceleration:
        acc = _rotate(q, sf) + np.array([0.0, 0.0, af.gravity_mps2])
        cols.update(acc_n=acc[:, 0], acc_e=acc[:, 1], acc_d=acc[:, 2])
        notes.append("no PSCN/PSCE/PSCD: NED acceleration is the IMU's specific force rotated by XKQ, plus gravity")
    for k, s in enumerate(escs):
        cols[f"rpm_{k + 1}"] = np.interp(clock, s["t"], s["RPM"])
    if ctun is not None:
        cols["thrust"] = af.mass_kg * af.gravity_mps2 * _collective(ctun, msgs, clock, notes)
    des = pick_stream(msgs, (("ATT", None, 0),), ["DesYaw"])
    if des is not None:
        cols["yaw_ref"] = np.radians(hold(des[1], ["DesYaw"], clock)[:, 0])
    else:
        notes.append("no ATT.DesYaw: the heading frame follows the vehicle's own yaw")
    return cols


def density_step(msgs, ctun: dict) -> tuple[DensityStep | None, list[str]]:
    """ArduCopter's density step in ``ctun`` (CTUN's t, ThO, ThH) by the primary barometer of ``msgs``
    (its BARO rows), judged against the thrust its IMU felt, and what to say of it
    (dobwind/io/densitystep.py)."""
    baro = pick_stream(msgs, (("BARO", "I", 0),), ["Alt", "Press", "GndTemp"]) if msgs.get("BARO") else None
    imu = pick_stream(msgs, IMU, ["AccZ"]) if msgs.get("IMU") else None
    return find_step(None if baro is None else baro[1], ctun, None if imu is None else imu[1])


def _collective(ctun: dict, msgs, clock: np.ndarray, notes: list[str]) -> np.ndarray:
    """CTUN.ThO / CTUN.ThH on the clock, with ArduCopter's density step undone where the log shows it."""
    tho, thh = hold(ctun, ["ThO"], clock)[:, 0], hold(ctun, ["ThH"], clock)[:, 0]
    notes.append("collective thrust from CTUN.ThO / CTUN.ThH times m g")
    step, said = density_step(msgs, ctun)
    notes += said
    if step is not None:
        tho, thh = step.thrust_terms(clock, tho, thh)
    return tho / thh


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Body vectors to NED by unit quaternions (w, x, y, z), row by row."""
    w, x, y, z = q.T
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    return np.einsum("ijk,kj->ki", r, v)
