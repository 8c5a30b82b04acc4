"""PX4 ULog flights onto the estimator's inputs (pyulog, optional dependency group `ulog`).

Topics: vehicle_local_position (vx vy vz, ax ay az), vehicle_attitude (q), esc_status (esc_rpm per
motor) for rpm airframes, the collective thrust (vehicle_thrust_setpoint xyz[2], or on older logs
vehicle_attitude_setpoint thrust_body[2] or thrust, or actuator_controls_0 control[3]: px4layout.py)
scaled by hover_thrust_estimate (or the MPC_THR_HOVER parameter) times m g for
collective airframes, sensor_combined (accelerometer) for specific force, and
vehicle_attitude_setpoint (yaw_body) for the heading frame, else the vehicle's own yaw.

Everything is resampled onto one uniform clock (the airframe's observer rate, 1/sample_time, or
--rate) inside the span all needed topics cover: continuous signals are interpolated (quaternions
sign-aligned, then normalised), setpoints are held. Where a topic has a gap around an instant (longer
than resample.GapPolicy allows that topic: a few of its own median intervals, at least max_dt;
esc_status: ROTOR_MAX_GAP_S, its reports are often 4 Hz), that row has no data: its inputs are NaN and
replay marks it with the NO_DATA status bit. So are airborne rows whose ESCs are offline or read 0 rpm.
Rows that vehicle_land_detected marks landed, maybe landed or in ground contact get LANDED. A file that
ends inside a message is replayed up to there, with a warning.
"""
from __future__ import annotations

import contextlib
import io
import os

import numpy as np

from dobwind.core.errors import InputError
from dobwind.io.logs import FlightLog
from dobwind.io.vehiclekind import MULTIROTORS_ONLY, px4_not_multirotor
from dobwind.model.airframe import Airframe
from dobwind.io.bridge import blanked, bridge, largest_silences
from dobwind.io.resample import (ROTOR_MAX_GAP_S, AutopilotFlight, blank, bracketing, count_note, hold, in_time_order,
                              interp, quaternions, source_gaps, topic_tolerances, truncated_note, uniform_clock,
                              wind_active)
from dobwind.io.ulogformat import Damage, damaged_formats, silent_damage
from dobwind.io.px4layout import NOT_COLLECTIVE, THRUST_SOURCES, ThrustSource, battery_scale_note, older_layout
from dobwind.model.signals import log_signals

PX4_WIND_TOPICS = (("wind", "windspeed_north", "windspeed_east"),
                   ("wind_estimate", "windspeed_north", "windspeed_east"),
                   ("estimator_states", "states[22]", "states[23]"))


# Every topic this module reads: pyulog parses only these (a flight log holds a hundred or more topics,
# and pyulog keeps each whole in memory; sensor and estimator topics at 100-1000 Hz are most of a log).
# Filtered, pyulog's clock advances only on these topics' messages, so its last_timestamp and dropout
# times differ from a full parse's: nothing here reads them; a new use must parse in full.
TOPICS_READ = ("vehicle_local_position", "vehicle_attitude", "sensor_combined", "esc_status",
               "vehicle_thrust_setpoint", "vehicle_attitude_setpoint", "actuator_controls_0", "hover_thrust_estimate",
               "vehicle_land_detected") + tuple(name for name, _, _ in PX4_WIND_TOPICS)

UlogFlight = AutopilotFlight  # the name this module's callers used first


class _NoProgress(Exception):
    pass


class _BudgetedFile:
    """The log file as pyulog reads it, with a budget of read calls: pyulog's corruption recovery can
    seek back and forth forever on some corrupt files (a pure-Python loop that no timeout thread can
    stop), so far more reads than the file has bytes ends the parse instead. Bytes are not counted:
    recovering from one corrupt header legitimately rereads up to 64 KiB per byte it advances."""

    def __init__(self, handle, size: int) -> None:
        self._handle = handle
        self._calls_left = READS_PER_BYTE * size + EXTRA_READS

    def read(self, n: int = -1) -> bytes:
        self._calls_left -= 1
        if self._calls_left < 0:
            raise _NoProgress
        return self._handle.read(n)

    def close(self) -> None:
        """pyulog closes the file when done: where it stopped tells a parse that ended early (struct.error
        on a message too short for its fields ends pyulog's loop without a word) from one that read it all."""
        self.stopped_at = self._handle.tell()
        self._handle.close()

    def __getattr__(self, name: str):
        return getattr(self._handle, name)


READS_PER_BYTE = 3    # resynchronising after corruption advances one byte per two reads
EXTRA_READS = 1 << 16


def open_ulog(path: str, topics: tuple[str, ...] | None = TOPICS_READ) -> tuple[object, str | None]:
    """pyulog's parse of ``path`` (only ``topics``; None: all) and its first complaint, if it printed
    one (pyulog prints to stdout, which must stay one JSON object under --json)."""
    ulog, complaint, _ = open_ulog_noted(path, topics)
    return ulog, complaint


def open_ulog_noted(path: str, topics: tuple[str, ...] | None = TOPICS_READ) -> tuple[object, str | None, Damage]:
    """open_ulog, with what pyulog lost without a word (ulogformat.py): a parse that stopped before the end,
    data messages it skipped."""
    try:
        from pyulog import ULog
    except ImportError:  # pragma: no cover - the ulog extra is part of `make setup`
        raise InputError(path, None, "reading ULog needs pyulog (pip install 'dobwind[ulog]')") from None
    printed = io.StringIO()
    try:
        with open(path, "rb") as handle, contextlib.redirect_stdout(printed):
            size = os.fstat(handle.fileno()).st_size
            if size == 0:  # pyulog says only "Header too short"
                raise InputError(path, None, "is empty (0 bytes): not a ULog file (an interrupted copy or download?)")
            budgeted = _BudgetedFile(handle, size)
            ulog = ULog(budgeted, None if topics is None else list(topics))
    except InputError:
        raise
    except _NoProgress:
        raise InputError(path, None, "not a readable ULog file (corrupt: the parser made no progress)") from None
    except OSError as exc:
        raise InputError(path, None, f"cannot read: {exc.strerror}") from None
    except RecursionError:  # pyulog flattens nested formats recursively: a format that names itself
        _refuse_damaged(path, None)
        raise InputError(path, None, "not a readable ULog file (a format definition nests without end)") from None
    except Exception as exc:  # pyulog raises many kinds on corrupt or truncated files
        raise InputError(path, None, f"not a readable ULog file ({type(exc).__name__}: {str(exc)[:80]})") from None
    complaints = [line.strip() for line in printed.getvalue().splitlines() if line.strip()]
    complaint = complaints[0][:120] if complaints else None
    return ulog, complaint, silent_damage(path, getattr(budgeted, "stopped_at", size), size,
                                          bool(getattr(ulog, "file_corruption", False)) and complaint is None)


def _topic(ulog, name: str, fields: list[str], optional: tuple[str, ...] = ()) -> dict[str, np.ndarray] | None:
    for data in ulog.data_list:
        if data.name == name and data.multi_id == 0 and all(f in data.data for f in fields):
            if len(data.data["timestamp"]) < 2:
                return None
            # A signalling NaN among a damaged file's float32 values raises "invalid" when widened; it
            # becomes a quiet NaN, which the step rejects (NONFINITE) like any other missing value.
            with np.errstate(invalid="ignore"):
                out = {f: np.asarray(data.data[f], dtype=float) for f in fields + [o for o in optional if o in data.data]}
            out["t"] = np.asarray(data.data["timestamp"], dtype=float) * 1e-6
            out = in_time_order(out)
            return out if len(out["t"]) >= 2 else None
    return None


def _hover_source(path: str, ulog, notes: list[str]) -> tuple[dict[str, np.ndarray] | None, float | None]:
    """(hover_thrust_estimate where valid, MPC_THR_HOVER) for a collective airframe; one of them at least."""
    hover_param = ulog.initial_parameters.get("MPC_THR_HOVER")
    logged = _topic(ulog, "hover_thrust_estimate", ["hover_thrust"], ("valid",))
    hover_topic = _converged_hover(logged, notes)
    if hover_topic is None and hover_param is None:
        what = "missing" if logged is None else "never valid"
        raise InputError(path, "topic hover_thrust_estimate", f"{what}, and no MPC_THR_HOVER parameter: collective "
                                                              "thrust cannot be scaled to newtons")
    if hover_topic is None:
        notes.append(f"hover thrust from the MPC_THR_HOVER parameter ({hover_param:.3f})")
    return hover_topic, hover_param


def _converged_hover(hover: dict[str, np.ndarray] | None, notes: list[str]) -> dict[str, np.ndarray] | None:
    """hover_thrust_estimate where PX4 calls it valid. The estimator starts at MPC_THR_HOVER (0.5 by default)
    and takes 10-20 s of flight to converge: an 8 kg octo's estimate rose from 0.50 to 0.62 before its
    `valid` flag came on, and a thrust setpoint of 0.64 divided by the unconverged 0.50 put its thrust 28 %
    above the weight, read as a 9 m/s downdraft. Before the first valid estimate, the first valid value
    holds (resample.hold clamps to the first sample); None when no estimate is valid (MPC_THR_HOVER then)."""
    if hover is None or "valid" not in hover:
        return hover
    keep = (hover["valid"] > 0) & np.isfinite(hover["hover_thrust"]) & (hover["hover_thrust"] > 0)
    if keep.sum() < 2:
        notes.append("hover_thrust_estimate never valid: the hover thrust from the MPC_THR_HOVER parameter")
        return None
    first = int(np.argmax(keep))
    if first > 0:
        notes.append(f"hover_thrust_estimate valid from {hover['t'][first]:.1f} s; before it, its first valid value "
                     f"{hover['hover_thrust'][first]:.3f} holds (the estimator was converging from "
                     f"{hover['hover_thrust'][0]:.3f})")
    later = ~keep[first:]
    if later.any():  # e.g. after landing: the valid values on either side are interpolated, the last one holds
        stretch = hover["t"][first:][later]
        when = f"at {stretch[0]:.1f} s" if len(stretch) == 1 else f"{stretch[0]:.1f}-{stretch[-1]:.1f} s"
        notes.append(f"hover_thrust_estimate not valid in {len(stretch)} later message(s), {when}: "
                     "the valid estimates around them are used")
    return {k: v[keep] for k, v in hover.items()}


def _own_yaw_note(ulog) -> str:
    """Why the heading frame follows the vehicle's own yaw: PX4 v1.15 and later log
    vehicle_attitude_setpoint without yaw_body, older logs may lack the topic."""
    logged = any(d.name == "vehicle_attitude_setpoint" for d in ulog.data_list)
    what = "vehicle_attitude_setpoint has no yaw_body" if logged else "no vehicle_attitude_setpoint"
    return f"{what}: the heading frame follows the vehicle's own yaw"


def truncation(path: str) -> str | None:
    """How the file ends, when its last message is cut off (pyulog reads such a file silently): walks
    the message headers (u16 size, u8 type) from the end of the 16-byte file header."""
    try:
        with open(path, "rb") as handle:
            blob = handle.read()
    except OSError:
        return None
    pos, size = 16, len(blob)
    while pos + 3 <= size:
        length = blob[pos] | (blob[pos + 1] << 8)
        if pos + 3 + length > size:
            break
        pos += 3 + length
    if pos == size:
        return None
    return truncated_note(size)


def esc_missing(esc: dict, rotors: int, clock: np.ndarray, airborne: np.ndarray) -> tuple[np.ndarray, str | None]:
    """Rows whose rotor speeds are not measurements: an ESC that is offline (beyond esc_count, or its
    esc_online_flags bit clear) or that reports exactly 0 rpm while the vehicle is airborne (a spinning
    rotor never reads 0; a log from ESCs without telemetry reads 0 throughout)."""
    offline = np.zeros((len(esc["t"]), rotors), dtype=bool)
    if "esc_count" in esc:
        offline |= np.arange(rotors)[None, :] >= esc["esc_count"][:, None]
    if "esc_online_flags" in esc:
        flags = esc["esc_online_flags"].astype(np.int64)
        offline |= ((flags[:, None] >> np.arange(rotors)[None, :]) & 1) == 0
    zero = np.column_stack([esc[f"esc[{i}].esc_rpm"] == 0 for i in range(rotors)])
    per_row = [bracketing(esc["t"], offline[:, i] | zero[:, i], clock) & airborne for i in range(rotors)]
    bad = np.any(per_row, axis=0)
    if not bad.any():
        return bad, None
    reasons = []
    for i in range(rotors):
        if per_row[i].any():
            off = (bracketing(esc["t"], offline[:, i], clock) & airborne).any()
            reasons.append(f"ESC {i + 1} ({'offline' if off else '0 rpm'})")
    return bad, count_note(bad, "airborne without rotor speeds from esc_status: " + ", ".join(reasons), "NO_DATA")


def _ground(ulog, clock: np.ndarray, notes: list[str]) -> np.ndarray:
    """Rows on the ground by vehicle_land_detected: landed, maybe_landed or ground_contact. With ground
    contact the ground carries part of the weight, which the observer would read as an updraft."""
    land = _topic(ulog, "vehicle_land_detected", ["landed"], ("maybe_landed", "ground_contact"))
    if land is None:
        notes.append("no vehicle_land_detected: every instant is treated as airborne")
        return np.zeros(len(clock), dtype=bool)
    flags = [f for f in ("landed", "maybe_landed", "ground_contact") if f in land]
    per_flag = {f: (hold(land, [f], clock)[:, 0] > 0.5) & (clock >= land["t"][0]) for f in flags}
    ground = np.any(list(per_flag.values()), axis=0)
    if ground.any():
        detail = ", ".join(f"{f} {int(m.sum())}" for f, m in per_flag.items())
        notes.append(count_note(ground, f"on the ground (vehicle_land_detected: {detail})", "LANDED"))
    return ground


def collective_source(ulog) -> tuple[ThrustSource, dict[str, np.ndarray]] | None:
    """The first of px4layout.THRUST_SOURCES the log has (instance 0, two messages at least), with its data."""
    for source in THRUST_SOURCES:
        data = _topic(ulog, source.topic, [source.field])
        if data is not None:
            return source, data
    return None


def _no_collective(ulog) -> str:
    """The missing-topic text for a collective airframe: every source tried, and the mixer outputs the log
    does have, named as not read (they are not the collective the hover thrust scales)."""
    tried = ", ".join(s.name for s in THRUST_SOURCES)
    logged = [name for name in NOT_COLLECTIVE if name in ulog.message_formats]  # type: ignore[attr-defined]
    unused = (f"; {' and '.join(logged)} {'is' if len(logged) == 1 else 'are'} logged but hold the mixer's "
              "per-motor outputs (after airmode, saturation and the thrust curve), not the collective: not read"
              if logged else "")
    return f"{tried} (collective thrust, one of them{unused})"


def _missing(ulog, name: str, fields: list[str], what: str) -> str:
    """A needed topic that is absent, too short, or logged with fields this reader does not know (a renamed
    field of another PX4 version): the text names which."""
    found = [d for d in ulog.data_list if d.name == name and d.multi_id == 0]
    lacking = [f for f in fields if found and f not in found[0].data]
    if lacking:
        return f"{name} ({what}: logged without field {', '.join(lacking)}, a layout this reader does not know)"
    return f"{name} ({what})"


def _refuse_damaged(path: str, names: list[str] | None) -> None:
    """Exit 2 in one line when a needed topic (``names``; None: any) came out of pyulog empty because its
    format definition is damaged (ulogformat.py): "missing from the log" would send a user to the logger's
    settings."""
    damaged = damaged_formats(path, names) if names is None or names else {}
    if len(damaged) == 1:
        (name, why), = damaged.items()
        raise InputError(path, f"topic {name}", f"its format definition in the log is damaged ({why}): none of its "
                         "messages can be read")
    if damaged:
        raise InputError(path, "topics " + ", ".join(damaged), "their format definitions in the log are damaged ("
                         + "; ".join(f"{name}: {why}" for name, why in damaged.items()) + "): none of their messages "
                         "can be read")


def _refuse_missing(path: str, ulog, need: dict, topics: dict, no_collective: bool, complaint: str | None) -> None:
    """One line naming every needed topic (or field) the log lacks, exit 2; a damaged definition first. In a
    file pyulog found corrupt, the line says so: the topics may be in the damaged part."""
    _refuse_damaged(path, [name for name, data in topics.items() if data is None]
                    + ([s.topic for s in THRUST_SOURCES] if no_collective else []))
    missing = [_missing(ulog, name, need[name][0], need[name][1]) for name, data in topics.items() if data is None]
    if no_collective:
        missing.append(_no_collective(ulog))
    if missing:
        damaged = (f"; the file is damaged (pyulog: {complaint or 'corrupt messages skipped'}): they may be in its "
                   "damaged part") if getattr(ulog, "file_corruption", False) else ""
        raise InputError(path, "topic" + ("s " if len(missing) > 1 else " ") + ", ".join(missing),
                         "missing from the log" + damaged)


def _needs(af: Airframe) -> dict[str, tuple[list[str], str]]:
    ned = log_signals(af).ned_acceleration
    need: dict[str, tuple[list[str], str]] = {
        "vehicle_local_position": (["vx", "vy", "vz"] + (["ax", "ay", "az"] if ned else []),
                                   "ground velocity" + (" and acceleration" if ned else "")),
        "vehicle_attitude": ([f"q[{i}]" for i in range(4)], "attitude"),
    }
    if log_signals(af).specific_force:
        need["sensor_combined"] = ([f"accelerometer_m_s2[{i}]" for i in range(3)], "specific force")
    if log_signals(af).rotor_speeds:
        need["esc_status"] = ([f"esc[{i}].esc_rpm" for i in range(af.thrust.rotors)],
                              f"rotor speeds of {af.thrust.rotors} motors (thrust.source = \"rpm\")")
    return need


def _multirotor_log(path: str) -> tuple[object, str | None, Damage]:
    """open_ulog_noted's parse, refused when the log is no multirotor's: a plane's log has every topic replay
    reads, and would be replayed as a copter's."""
    ulog, complaint, damage = open_ulog_noted(path)
    params = ulog.initial_parameters  # type: ignore[attr-defined]
    why = px4_not_multirotor({"MAV_TYPE": float(params["MAV_TYPE"])} if "MAV_TYPE" in params else {})
    if why:
        raise InputError(path, "vehicle", f"{why}; {MULTIROTORS_ONLY}")
    return ulog, complaint, damage


def read_ulog(path: str, af: Airframe, rate_hz: float | None = None, bridge_gaps: bool = False) -> UlogFlight:
    ulog, complaint, damage = _multirotor_log(path)
    need = _needs(af)
    topics = {name: _topic(ulog, name, fields, ("esc_count", "esc_online_flags") if name == "esc_status" else ())
              for name, (fields, _) in need.items()}
    thrust_src = collective_source(ulog) if af.thrust.source == "collective" else None
    _refuse_missing(path, ulog, need, topics, af.thrust.source == "collective" and thrust_src is None, complaint)
    notes = ([] if complaint is None else [f"pyulog: {complaint} (the parse went on past it)"]) + \
        ([damage.skipped] if damage.skipped else [])
    if thrust_src:
        notes += [n for n in (battery_scale_note(thrust_src[0], ulog.initial_parameters),) if n]
    cut = truncation(path)
    hover_topic, hover_param = _hover_source(path, ulog, notes) if thrust_src else (None, None)
    yaw_src = _topic(ulog, "vehicle_attitude_setpoint", ["yaw_body"])
    if yaw_src is None:
        notes.append(_own_yaw_note(ulog))

    used = {n: d for n, d in topics.items() if d is not None}
    if thrust_src:
        used[thrust_src[0].topic] = thrust_src[1]
    clock = uniform_clock(path, [d["t"] for d in used.values()], rate_hz or 1.0 / af.observer.sample_time_s)
    max_gap = af.limits.max_dt_s
    tolerances, slow = topic_tolerances({name: d["t"] for name, d in used.items()}, max_gap,
                                        {"esc_status": ROTOR_MAX_GAP_S})
    notes += slow
    no_data, culprits = source_gaps(tolerances, clock)
    cols = _columns(af, topics, thrust_src, hover_topic, hover_param, yaw_src, clock, notes)
    landed = _ground(ulog, clock, notes)
    gappy = no_data.copy()
    if log_signals(af).rotor_speeds:
        dead, note = esc_missing(topics["esc_status"], af.thrust.rotors, clock, ~landed & ~no_data)
        no_data |= dead
        if note:
            notes.append(note)
    px4, px4_var = _px4_wind(ulog, clock)
    if gappy.any():
        # esc_status has its own fixed tolerance; name it only when this airframe reads it
        esc = f"esc_status: {ROTOR_MAX_GAP_S:g} s; " if "esc_status" in tolerances else ""
        notes.append(count_note(gappy, f"with a topic gap (longer than max_dt {max_gap:g} s or, for a slow topic, "
                                       f"than its own tolerance; {esc}by topic: {culprits})", "NO_DATA"))
    warnings = tuple(f"{path}: {said} ({clock[-1] - clock[0]:.2f} s readable)" for said in (cut, damage.stopped) if said)
    bridged = None
    if bridge_gaps:
        bridged, note = bridge(af, tolerances, clock, gappy, landed | (no_data & ~gappy),
                              (thrust_src[0].topic,) if thrust_src else ())
        notes += note
    return UlogFlight(FlightLog(path, blank(cols, blanked(no_data, landed, bridged))), no_data, landed, px4,
                      tuple(notes), float(clock[0]), warnings, autopilot_wind_variance=px4_var, bridged=bridged,
                           silences=largest_silences(tolerances, clock))


def _px4_wind(ulog, clock: np.ndarray):
    """PX4's own wind estimate, (topic, time from the clock's start, NED wind with zero down), and its
    (north, east) variances when the topic has them; or (None, None). The first topic that is ever
    active wins (an all-zero topic is PX4 not estimating), else the first found (replay says inactive)."""
    found = []
    for name, north, east in PX4_WIND_TOPICS:
        src = _topic(ulog, name, [north, east], ("variance_north", "variance_east"))
        if src is not None:
            wind = np.column_stack([src[north], src[east], np.zeros(len(src["t"]))])
            var = (np.column_stack([src["variance_north"], src["variance_east"]])
                   if "variance_north" in src and "variance_east" in src else None)
            found.append(((name, src["t"] - clock[0], wind), var))
    active = [f for f in found if wind_active(f[0][2]).any()]
    return (active or found or [(None, None)])[0]


def _columns(af: Airframe, topics: dict, thrust_src, hover_topic, hover_param, yaw_src, clock: np.ndarray,
             notes: list[str]) -> dict[str, np.ndarray]:
    lp = topics["vehicle_local_position"]
    cols: dict[str, np.ndarray] = {"t": clock - clock[0]}
    vel = interp(lp, ["vx", "vy", "vz"], clock)
    cols.update(vel_n=vel[:, 0], vel_e=vel[:, 1], vel_d=vel[:, 2])
    if log_signals(af).ned_acceleration:
        acc = interp(lp, ["ax", "ay", "az"], clock)
        cols.update(acc_n=acc[:, 0], acc_e=acc[:, 1], acc_d=acc[:, 2])
    if log_signals(af).specific_force:
        sf = interp(topics["sensor_combined"], [f"accelerometer_m_s2[{i}]" for i in range(3)], clock)
        cols.update(sf_x=sf[:, 0], sf_y=sf[:, 1], sf_z=sf[:, 2])
    att = topics["vehicle_attitude"]
    q = quaternions(att["t"], np.column_stack([att[f"q[{i}]"] for i in range(4)]), clock)
    cols.update(q_w=q[:, 0], q_x=q[:, 1], q_y=q[:, 2], q_z=q[:, 3])
    if log_signals(af).rotor_speeds:
        rpm = interp(topics["esc_status"], [f"esc[{i}].esc_rpm" for i in range(af.thrust.rotors)], clock)
        for i in range(af.thrust.rotors):
            cols[f"rpm_{i + 1}"] = rpm[:, i]
    else:
        source, src = thrust_src
        normalized = source.up * hold(src, [source.field], clock)[:, 0]  # upward positive, whatever the layout
        hover = hold(hover_topic, ["hover_thrust"], clock)[:, 0] if hover_topic else np.full(len(clock), hover_param)
        cols["thrust"] = af.mass_kg * af.gravity_mps2 * normalized / hover
        said = older_layout(source)
        notes.append(f"collective thrust from {source.name}" + (f": {said}" if said else ""))
    if yaw_src is not None:
        cols["yaw_ref"] = hold(yaw_src, ["yaw_body"], clock)[:, 0]
    return cols


def _mean_directions(ours: np.ndarray, theirs: np.ndarray) -> dict:
    """Speed and direction (FROM, clockwise from north: the meteorological convention, which both winds are
    turned into from their north and east velocities of the air) of each mean wind, and how far apart the
    directions are, so a reader sees at once whether the autopilot and dobwind agree on where the wind
    comes from. A mean below 0.1 m/s has no direction (None)."""
    from dobwind.model.forceair import wind_from_deg

    out: dict = {}
    for who, rows in (("ours", ours), ("theirs", theirs)):
        n, e = rows.mean(axis=0)
        out[f"mean_wind_{who}_speed_mps"] = float(np.hypot(n, e))
        out[f"mean_wind_{who}_from_deg"] = float(wind_from_deg(n, e)) if np.hypot(n, e) >= 0.1 else None
    a, b = out["mean_wind_ours_from_deg"], out["mean_wind_theirs_from_deg"]
    out["direction_difference_deg"] = None if a is None or b is None else float((a - b + 180.0) % 360.0 - 180.0)
    return out


def compare_with_px4(t: np.ndarray, wind: np.ndarray, valid: np.ndarray, px4: tuple[str, np.ndarray, np.ndarray],
                     variance: np.ndarray | None = None) -> dict:
    """Differences between our horizontal wind and the autopilot's, over our valid rows where the
    autopilot was estimating (both samples around the row active; see resample.wind_active), with the
    autopilot's own variances over those rows when it logs them (PX4 wind: variance_north/east)."""
    name, tp, wp = px4
    active = wind_active(wp)
    if not active.any():
        return {"topic": name, "active": False, "overlap_rows": 0}
    inside = valid & (t >= tp[0]) & (t <= tp[-1]) & ~bracketing(tp, ~active, t)
    out: dict = {"topic": name, "active": True, "active_share": float(active.mean()), "overlap_rows": int(inside.sum())}
    if not inside.any():
        return out
    theirs = np.column_stack([np.interp(t[inside], tp, wp[:, i]) for i in range(2)])
    ours = wind[inside, :2]
    diff = ours - theirs
    # The mean of |ours - theirs| row by row, and |mean ours - mean theirs| (a steady wind's offset).
    out.update(mean_vector_difference_mps=float(np.mean(np.linalg.norm(diff, axis=1))),
               difference_of_means_mps=float(np.linalg.norm(diff.mean(axis=0))),
               mean_difference_ne_mps=[float(v) for v in diff.mean(axis=0)],
               mean_speed_difference_mps=float(np.mean(np.linalg.norm(ours, axis=1) - np.linalg.norm(theirs, axis=1))),
               mean_wind_ours_ne_mps=[float(v) for v in ours.mean(axis=0)],
               mean_wind_theirs_ne_mps=[float(v) for v in theirs.mean(axis=0)], **_mean_directions(ours, theirs))
    if variance is not None:
        var = np.column_stack([np.interp(t[inside], tp, variance[:, i]) for i in range(2)])
        out.update(variance_north_m2s2=float(np.mean(var[:, 0])), variance_east_m2s2=float(np.mean(var[:, 1])),
                   sigma_h_mps=float(np.sqrt(np.mean(var[:, 0] + var[:, 1]))))
    return out
