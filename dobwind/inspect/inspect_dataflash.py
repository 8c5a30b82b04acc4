"""`dobwind inspect` for ArduPilot DataFlash (.bin): the messages dobwind/io/dataflash.py reads, their rates,
the vehicle, ArduPilot's wind and the SITL wind parameters.

The message choices are dataflash.py's (VELOCITY, ATTITUDE, IMU, AP_WIND, EV_GROUND, older layouts
relabelled by aplayout.py, the primary EKF core from XKF4.PI or NKF4.PI): a role listed here is the
message replay reads for it.
"""
from __future__ import annotations

import numpy as np

from dobwind.io.dataflash import (AP_WIND, ATTITUDE, EV_GROUND, IMU, LAYOUT_FORMATS, VELOCITY, WANTED, FileNotes,
                                  density_step, ground_events, in_one_layout, pick_stream, read_messages)
from dobwind.core.errors import InputError
from dobwind.io.aplayout import logged_name
from dobwind.io.position import GEO_MESSAGES, Geo, dataflash_geo
from dobwind.io.quietfd import quiet_fds
from dobwind.io.vehiclekind import ardupilot_not_multirotor, firmware
from dobwind.inspect.loginspect import (AutopilotWind, LogSummary, Role, Vehicle, bulk_span, drag_fusion_reason,
                                inside, intervals, stream_stats, total, wind_activity)

PARAMETERS = ("MOT_THST_HOVER", "FRAME_CLASS", "FRAME_TYPE", "EK3_DRAG_BCOEF_X", "EK3_DRAG_BCOEF_Y",
              "EK3_DRAG_MCOEF", "SIM_WIND_SPD", "SIM_WIND_DIR", "SIM_WIND_TURB", "SIM_WIND_T", "SIM_WIND_T_ALT")
# ArduPilot FRAME_CLASS -> motors (AP_Motors: quad, hexa, octa, octaquad, Y6, tri, dodecahexa, deca).
FRAME_CLASS_ROTORS = {1: 4, 2: 6, 3: 8, 4: 8, 5: 6, 7: 3, 12: 12, 14: 10}
FRAME_CLASS_NAMES = {1: "quad", 2: "hexa", 3: "octa", 4: "octaquad", 5: "Y6", 7: "tri", 12: "dodecahexa", 14: "deca"}
# SERVOn_FUNCTION values of motors: Motor1..8 are 33..40, Motor9..12 are 82..85 (ArduPilot SRV_Channel).
MOTOR_FUNCTIONS = set(range(33, 41)) | set(range(82, 86))
RPM_AIRBORNE_SHARE = 0.95
MOTOR_PWM_US = 1100.0  # a spinning motor's output; idle and disarmed outputs sit near 1000 us
READ = WANTED + LAYOUT_FORMATS + ("PARM", "RCOU", "MSG", "BARO")
POSITION_ONLY = tuple(name for name in GEO_MESSAGES if name not in READ)


def _parameters(rows: list[dict]) -> dict[str, float]:
    """Each parameter's first logged value (the one the flight started with)."""
    out: dict[str, float] = {}
    for r in rows:
        name = r.get("Name")
        value = r.get("Value")
        if isinstance(name, str) and name not in out and isinstance(value, (int, float)) and np.isfinite(value):
            out[name] = float(value)
    return out


def _streams(msgs: dict) -> list:
    out = []
    for name, rows in msgs.items():
        if not rows:
            continue
        inst = "C" if "C" in rows[0] else "I" if name == "IMU" and "I" in rows[0] else "Instance" if name == "ESC" else None
        if inst is None:
            out.append(stream_stats(name, np.array([r["TimeUS"] for r in rows]) * 1e-6))
            continue
        for k in sorted({int(r.get(inst, 0)) for r in rows}):
            t = np.array([r["TimeUS"] for r in rows if int(r.get(inst, 0)) == k]) * 1e-6
            label = "primary core" if inst == "C" else f"{inst} {k}"
            if inst == "C" and k != 0:
                continue  # the other cores' rows were dropped by follow_primary
            out.append(stream_stats(f"{name} ({label})", t))
    return out


def _stream_name(msgs: dict, name: str) -> str:
    rows = msgs.get(name) or [{}]
    if "C" in rows[0]:
        return f"{name} (primary core)"
    if name == "IMU" and "I" in rows[0]:
        return f"{name} (I 0)"
    return f"{name} (Instance 0)" if name == "ESC" and "Instance" in rows[0] else name


def _role(msgs: dict, role: str, candidates, fields: list[str], missing: str) -> Role:
    found = pick_stream(msgs, candidates, fields)
    if found is None:
        return Role(role, None, None, missing)
    logged = logged_name(msgs, found[0])  # an older layout's own name (XKQ1), not the 4.1 one it is read as
    return Role(role, f"{logged}.{fields[0]}..{fields[-1]}" if len(fields) > 1 else f"{logged}.{fields[0]}",
                _stream_name(msgs, found[0]))


def _roles(msgs: dict, params: dict) -> tuple[Role, ...]:
    ctun = (("CTUN", None, 0),)
    psc = pick_stream(msgs, (("PSCN", None, 0),), ["AN"])
    imu = _role(msgs, "specific_force", IMU, ["AccX", "AccY", "AccZ"], "no IMU")
    attitude = _role(msgs, "attitude", ATTITUDE, ["Q1", "Q2", "Q3", "Q4"], "no XKQ (or NKQ1, NKQ)")
    quat = (attitude.source or "XKQ").split(".")[0]  # an EKF2 log's NKQ1, not XKQ
    acc = (Role("acceleration", "PSCN.AN, PSCE.AE, PSCD.AD", "PSCN") if psc is not None else
           Role("acceleration", f"IMU specific force rotated by {quat}, plus gravity", imu.stream, "no PSCN/PSCE/PSCD")
           if imu.source else Role("acceleration", None, None, "no PSCN and no IMU"))
    hover = _role(msgs, "hover_thrust", ctun, ["ThH"], "no CTUN.ThH")
    heading = _role(msgs, "heading", (("ATT", None, 0),), ["DesYaw"], "")
    if heading.source is None:
        heading = Role("heading", "XKQ (the vehicle's own yaw)", _stream_name(msgs, "XKQ"), "no ATT.DesYaw")
    ground = (Role("ground", "EV landing events", "EV") if any(r.get("Id") in EV_GROUND for r in msgs["EV"]) else
              Role("ground", "CTUN.ThO at 0", "CTUN", "no EV events") if _has_tho(msgs) else
              Role("ground", None, None, "no EV events and no CTUN.ThO: replay treats every instant as airborne"))
    return (_role(msgs, "velocity", VELOCITY, ["VN", "VE", "VD"], "no XKF1 (or NKF1)"), acc, imu,
            attitude,
            _role(msgs, "rpm", (("ESC", None, 0),), ["RPM"], "no ESC telemetry"),
            _role(msgs, "thrust", ctun, ["ThO"], "no CTUN.ThO"), hover, heading, ground,
            _role(msgs, "autopilot_wind", AP_WIND, ["VWN", "VWE"], "no XKF2 (or NKF2)"))


def _airborne(msgs: dict, end_s: float) -> tuple[tuple[tuple[float, float], ...], str]:
    """As replay reads the ground: EV events (a log starts on the ground), else CTUN.ThO > 0."""
    t_ev, ground = ground_events(msgs)  # replay's order: by time, the log's among equal stamps
    if len(t_ev):
        return intervals(t_ev, ~ground, end_s), "EV events"
    ctun = pick_stream(msgs, (("CTUN", None, 0),), ["ThO"])
    if ctun is not None:
        return intervals(ctun[1]["t"], ctun[1]["ThO"] > 0, end_s), "CTUN.ThO above 0 (no EV events)"
    return (), "unknown: no EV events and no CTUN.ThO"


def _has_tho(msgs: dict) -> bool:
    """Whether CTUN carries ThO, as dataflash._ground asks (ArduPlane's CTUN has no ThO)."""
    return bool(msgs["CTUN"]) and "ThO" in msgs["CTUN"][0]


def _rotors(msgs: dict, params: dict, spans) -> tuple[int | None, str]:
    motors = [k for k, v in params.items() if k.startswith("SERVO") and k.endswith("_FUNCTION") and int(v) in MOTOR_FUNCTIONS]
    if motors:
        return len(motors), "SERVOn_FUNCTION set to a motor"
    frame = int(params.get("FRAME_CLASS", -1))
    if frame in FRAME_CLASS_ROTORS:
        return FRAME_CLASS_ROTORS[frame], f"FRAME_CLASS {frame}"
    escs = {r.get("Instance") for r in msgs["ESC"]}
    if escs:
        return len(escs), "ESC telemetry instances"
    driven = _driven_outputs(msgs.get("RCOU", []), spans)
    if driven:
        return driven, "RCOU channels above 1100 us while airborne (no parameters: servos would count too)"
    return None, "no motor SERVOn_FUNCTION, FRAME_CLASS, ESC telemetry or driven RCOU channel"


def _driven_outputs(rows: list[dict], spans) -> int:
    """Output channels whose airborne median PWM is above 1100 us (motors idle at about 1000)."""
    if not rows or not spans:
        return 0
    up = inside(np.array([r["TimeUS"] for r in rows]) * 1e-6, spans)
    if not up.any():
        return 0
    picked = [r for r, u in zip(rows, up) if u]
    return sum(1 for k in range(1, 33) if f"C{k}" in picked[0]
               and np.median([r.get(f"C{k}", 0) for r in picked]) > MOTOR_PWM_US)


def _rpm(msgs: dict, rotors: int | None, spans) -> tuple[bool, str, float | None, float | None]:
    if not msgs["ESC"] or not rotors:
        return False, "no ESC telemetry" if not msgs["ESC"] else "rotor count unknown", None, None
    values, shares = [], []
    for k in range(rotors):
        rows = [(r["TimeUS"] * 1e-6, r.get("RPM", 0.0)) for r in msgs["ESC"] if r.get("Instance") == k]
        if not rows:
            return False, f"no ESC telemetry for motor {k + 1} (Instance {k})", None, None
        t, rpm = np.array(rows).T
        up = inside(t, spans)
        if not up.any():
            return False, "no ESC report while airborne", None, None
        shares.append(float(np.mean(rpm[up] > 0)))
        values.append(rpm[up])
    share = min(shares)
    rpm_all = np.concatenate(values)
    note = (f"rpm > 0 in {100 * share:.0f} % of the airborne reports of the ESC with the fewest"
            f" ({100 * RPM_AIRBORNE_SHARE:.0f} % needed)")
    return share >= RPM_AIRBORNE_SHARE, note, float(np.median(rpm_all)), float(np.max(rpm_all))


def _hover(msgs: dict, params: dict, spans) -> tuple[float | None, str]:
    ctun = pick_stream(msgs, (("CTUN", None, 0),), ["ThH"])
    if ctun is not None:
        up = inside(ctun[1]["t"], spans)
        if up.any():
            return float(np.median(ctun[1]["ThH"][up])), "CTUN.ThH (airborne median)"
        return float(np.median(ctun[1]["ThH"])), "CTUN.ThH (median over the log: no airborne sample)"
    if "MOT_THST_HOVER" in params:
        return params["MOT_THST_HOVER"], "parameter MOT_THST_HOVER"
    return None, ""


def _ap_wind(msgs: dict, params: dict) -> AutopilotWind:
    keys = ("EK3_DRAG_BCOEF_X", "EK3_DRAG_BCOEF_Y", "EK3_DRAG_MCOEF")
    why = drag_fusion_reason("EK3", any(params.get(k, 0) > 0 for k in keys), any(k in params for k in keys),
                             "EK3_DRAG_BCOEF_X/Y and EK3_DRAG_MCOEF 0", "EK3_DRAG_*")
    found = pick_stream(msgs, AP_WIND, ["VWN", "VWE"])
    if found is None:
        return wind_activity(None, None, None, None, why)
    return wind_activity(found[0], found[1]["t"], found[1]["VWN"], found[1]["VWE"], why)


def _density_step(msgs: dict, baro: list[dict]) -> list[str]:
    """What replay's reader says of ArduCopter's density step in CTUN.ThO (dobwind/io/densitystep.py)."""
    ctun = pick_stream(msgs, (("CTUN", None, 0),), ["ThO", "ThH"])
    if ctun is None:
        return []
    return [f"for a collective airframe: {line}" for line in density_step({**msgs, "BARO": baro}, ctun[1])[1]]


def inspect_dataflash_and_position(path: str) -> tuple[LogSummary, Geo | None]:
    """inspect_dataflash and the log's position and UTC (position.dataflash_geo) from one read of the file:
    DataFlash messages are parsed one by one, each the same whatever else is read, so a read that
    succeeds gives both what their own reads would (0.14 s saved on the 3.6 MB SITL log of
    ../shared/data/field). A read that fails (a damaged position message among them) is followed by
    inspect's own; None: the position was not read (the caller reads it alone)."""
    try:
        with quiet_fds():  # pymavlink's compiled indexer prints a line per bad byte, to fd 2 itself
            loaded, said = read_messages(path, READ + POSITION_ONLY)
    except InputError:
        return inspect_dataflash(path), None
    geo = dataflash_geo({name: loaded[name] for name in GEO_MESSAGES})
    return _summary(path, {name: rows for name, rows in loaded.items() if name not in POSITION_ONLY}, said), geo


def inspect_dataflash(path: str) -> LogSummary:
    with quiet_fds():  # pymavlink's compiled indexer prints a line per bad byte, to fd 2 itself
        loaded, said = read_messages(path, READ)
    return _summary(path, loaded, said)


def _summary(path: str, loaded: dict[str, list[dict]], said: FileNotes) -> LogSummary:
    notes: list[str] = []
    msgs = in_one_layout(loaded, notes)
    baro = msgs.pop("BARO")
    params_all = _parameters(msgs.pop("PARM"))
    banner = firmware(msgs.pop("MSG"))
    params = {k: params_all[k] for k in PARAMETERS if k in params_all}
    streams = _streams(msgs)
    if not streams:
        raise InputError(path, None, "no message the estimator reads is in the log")
    span = bulk_span(np.array([r["TimeUS"] for rows in msgs.values() for r in rows], dtype=float) * 1e-6)
    start, end = span.start_s, span.end_s
    spans, source = _airborne(msgs, end)
    spans = span.clip(spans)
    rotors, rotor_source = _rotors(msgs, params_all, spans)
    rpm_ok, rpm_note, rpm_median, rpm_max = _rpm(msgs, rotors, spans)
    hover, hover_source = _hover(msgs, params, spans)
    frame = int(params.get("FRAME_CLASS", -1))
    airframe = (f"ArduPilot FRAME_CLASS {frame} ({FRAME_CLASS_NAMES.get(frame, 'not a multirotor class')})"
                if "FRAME_CLASS" in params else "ArduPilot (no FRAME_CLASS)") + (f", firmware {banner}" if banner else "")
    vehicle = Vehicle(rotors, rotor_source, airframe, rpm_ok, rpm_note, hover, hover_source, rpm_median, rpm_max,
                      ardupilot_not_multirotor(banner, params_all))
    notes += [n for n in (said.truncated, said.damaged, span.note()) if n] + _density_step(msgs, baro)
    if "SIM_WIND_SPD" in params:
        notes.append(f"SITL wind: {params['SIM_WIND_SPD']:g} m/s from {params.get('SIM_WIND_DIR', 0):g} deg"
                     + (f", below {params.get('SIM_WIND_T_ALT', 0):g} m scaled by sqrt(height / SIM_WIND_T_ALT)"
                        if params.get("SIM_WIND_T", 0) == 0 and params.get("SIM_WIND_T_ALT", 0) > 0 else ""))
    return LogSummary(path, "dataflash", "ArduPilot", start, end, total(spans) if spans or "unknown" not in source else None,
                      source, spans, tuple(streams), _roles(msgs, params), params, vehicle, _ap_wind(msgs, params),
                      tuple(notes), outside_span=span.outside, outside_span_s=span.outside_s)
