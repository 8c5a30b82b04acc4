"""`dobwind inspect` for PX4 ULog: the topics dobwind/io/ulog.py reads, their rates, the vehicle and PX4's wind.

The topic choices are ulog.py's (TOPICS_READ, PX4_WIND_TOPICS and the fields read_ulog asks for): a
role listed here is the topic replay reads for it, in the same order of preference.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from dobwind.core.errors import InputError
from dobwind.inspect.loginspect import (AutopilotWind, LogSummary, Role, Vehicle, bulk_span, drag_fusion_reason,
                                inside, intervals, stream_stats, total, wind_activity)
from dobwind.io.position import GEO_TOPICS, Geo, ulog_geo
from dobwind.io.ulogformat import Damage, damaged_formats
from dobwind.io.ulog import PX4_WIND_TOPICS, TOPICS_READ, collective_source, open_ulog_noted, truncation
from dobwind.io.px4layout import (BATTERY_SCALE_PARAM, NOT_COLLECTIVE, THRUST_SOURCES, ThrustSource, battery_scale_note,
                                  older_layout)
from dobwind.io.resample import in_time_order
from dobwind.io.vehiclekind import px4_not_multirotor

# Read for the vehicle only (rotor count when esc_status is absent): not estimator inputs.
EXTRA_TOPICS = ("actuator_motors", "actuator_outputs")
PARAMETERS = ("MPC_THR_HOVER", "EKF2_AID_MASK", "EKF2_DRAG_CTRL", "EKF2_BCOEF_X", "EKF2_BCOEF_Y", "EKF2_MCOEF",
              "SYS_AUTOSTART", "CA_ROTOR_COUNT", "MAV_TYPE", BATTERY_SCALE_PARAM)
# MAV_TYPE (MAVLink) of multirotors -> rotor count: the last resort for the rotor count.
MAV_TYPE_ROTORS = {2: 4, 13: 6, 14: 8, 15: 3}
EKF2_AID_MASK_DRAG = 1 << 5   # "use drag": PX4 up to v1.13; later EKF2_DRAG_CTRL
# Share of airborne ESC reports that must read rpm > 0 on every rotor for rpm to be a thrust source.
RPM_AIRBORNE_SHARE = 0.95
INSPECTED = TOPICS_READ + EXTRA_TOPICS
POSITION_ONLY = tuple(name for name in GEO_TOPICS if name not in INSPECTED)


def _topics(ulog) -> dict[str, dict]:
    """Instance 0 of every topic inspect reads (INSPECTED; a parse may hold the position's topics too):
    its fields as float arrays and "t" in seconds."""
    out: dict[str, dict] = {}
    for data in ulog.data_list:
        if data.multi_id == 0 and data.name in INSPECTED and len(data.data["timestamp"]):
            with np.errstate(invalid="ignore"):
                cols = {k: np.asarray(v, dtype=float) for k, v in data.data.items()}
            cols["t"] = cols["timestamp"] * 1e-6
            out[data.name] = in_time_order(cols)  # as read_ulog takes it: rates and gaps in time order
    return out


def _role(topics: dict, role: str, candidates: tuple[tuple[str, tuple[str, ...]], ...], missing: str) -> Role:
    for name, fields in candidates:
        if name in topics and all(f in topics[name] for f in fields) and len(topics[name]["t"]) >= 2:
            shown = fields[0] if len(fields) == 1 else f"{fields[0]}..{fields[-1]}"
            return Role(role, f"{name}.{shown}", name)
    return Role(role, None, None, missing)


# The collective source replay reads (ulog.collective_source: its choice, not a copy of it), with its data.
Collective = tuple[ThrustSource, dict] | None


def _thrust_role(found: Collective, topics: dict, params: dict) -> Role:
    """The collective thrust source read_ulog takes, with what an older layout's source is and what the
    battery scale adds; when none, the mixer outputs are named as not read (they are not the collective)."""
    if found is not None:
        source = found[0]
        said = [n for n in (older_layout(source), battery_scale_note(source, params)) if n]
        return Role("thrust", source.name, source.topic, "; ".join(said))
    mixer = [name for name in NOT_COLLECTIVE if name in topics]
    return Role("thrust", None, None, f"none of {', '.join(s.name for s in THRUST_SOURCES)}"
                + (f" ({' and '.join(mixer)}: the mixer's per-motor outputs, not a collective: not read)" if mixer else ""))


def _roles(topics: dict, params: dict, found: Collective) -> tuple[Role, ...]:
    q = tuple(f"q[{i}]" for i in range(4))
    roles = [
        _role(topics, "velocity", (("vehicle_local_position", ("vx", "vy", "vz")),), "no vehicle_local_position"),
        _role(topics, "acceleration", (("vehicle_local_position", ("ax", "ay", "az")),), "no vehicle_local_position.ax"),
        _role(topics, "specific_force", (("sensor_combined", tuple(f"accelerometer_m_s2[{i}]" for i in range(3))),),
              "no sensor_combined"),
        _role(topics, "attitude", (("vehicle_attitude", q),), "no vehicle_attitude"),
        _role(topics, "rpm", (("esc_status", ("esc[0].esc_rpm",)),), "no esc_status"),
        _thrust_role(found, topics, params),
        _role(topics, "hover_thrust", (("hover_thrust_estimate", ("hover_thrust",)),), ""),
        _role(topics, "heading", (("vehicle_attitude_setpoint", ("yaw_body",)),), ""),
        _role(topics, "ground", (("vehicle_land_detected", ("landed",)),), ""),
    ]
    if roles[6].source is None:  # read_ulog's fallback: the parameter
        roles[6] = (Role("hover_thrust", "parameter MPC_THR_HOVER", None) if "MPC_THR_HOVER" in params else
                    Role("hover_thrust", None, None, "no hover_thrust_estimate and no MPC_THR_HOVER"))
    if roles[7].source is None:
        roles[7] = Role("heading", "vehicle_attitude (the vehicle's own yaw)", "vehicle_attitude",
                        "no vehicle_attitude_setpoint.yaw_body")
    if roles[8].source is None:
        roles[8] = Role("ground", None, None, "no vehicle_land_detected: replay treats every instant as airborne")
    wind = _role(topics, "autopilot_wind", tuple((n, (a, b)) for n, a, b in PX4_WIND_TOPICS), "no PX4 wind topic")
    return tuple(roles) + (wind,)


def _airborne(topics: dict, params: dict, end_s: float, found: Collective) -> tuple[tuple[tuple[float, float], ...], str]:
    """Airborne spans: vehicle_land_detected (landed, maybe_landed or ground_contact mean ground, as
    replay reads it), else replay's collective setpoint (``found``) above half the hover thrust."""
    land = topics.get("vehicle_land_detected")
    if land is not None and "landed" in land:
        ground = np.zeros(len(land["t"]), dtype=bool)
        for flag in ("landed", "maybe_landed", "ground_contact"):
            if flag in land:
                ground |= land[flag] > 0.5
        return intervals(land["t"], ~ground, end_s), "vehicle_land_detected"
    if found is not None:
        source, data = found
        hover = params.get("MPC_THR_HOVER", 0.5)
        return (intervals(data["t"], source.up * data[source.field] > 0.5 * hover, end_s),
                f"{source.name} above half the hover thrust (no vehicle_land_detected)")
    return (), "unknown: no vehicle_land_detected and no thrust setpoint"


def _rotor_count(topics: dict, params: dict, spans) -> tuple[int | None, str]:
    # The configured count first: SITL's esc_status reports more ESCs than the vehicle has motors.
    if params.get("CA_ROTOR_COUNT", 0) > 0:
        return int(params["CA_ROTOR_COUNT"]), "parameter CA_ROTOR_COUNT"
    esc = topics.get("esc_status")
    if esc is not None and "esc_count" in esc and np.nanmax(esc["esc_count"]) > 0:
        return int(np.nanmax(esc["esc_count"])), "esc_status.esc_count"
    motors = topics.get("actuator_motors")
    if motors is not None:
        up = inside(motors["t"], spans) if spans else np.ones(len(motors["t"]), dtype=bool)
        used = [k for k in range(16) if f"control[{k}]" in motors
                and np.any(np.isfinite(motors[f"control[{k}]"][up]) & (motors[f"control[{k}]"][up] > 0))]
        if used:
            return len(used), "actuator_motors channels driven while airborne"
    if int(params.get("MAV_TYPE", -1)) in MAV_TYPE_ROTORS:
        return MAV_TYPE_ROTORS[int(params["MAV_TYPE"])], f"MAV_TYPE {int(params['MAV_TYPE'])}"
    return None, "no esc_status, CA_ROTOR_COUNT, actuator_motors or multirotor MAV_TYPE"


def _rpm(topics: dict, rotors: int | None, spans) -> tuple[bool, str, float | None, float | None]:
    """Whether esc_status gives rpm > 0 on every rotor while airborne, with the airborne median and max."""
    esc = topics.get("esc_status")
    if esc is None or not rotors:
        return False, "no esc_status" if esc is None else "rotor count unknown", None, None
    cols = [esc.get(f"esc[{i}].esc_rpm") for i in range(rotors)]
    if any(c is None for c in cols):
        return False, f"esc_status has fewer than {rotors} ESCs", None, None
    rpm = np.column_stack(cols)
    up = inside(esc["t"], spans)
    if not up.any():
        return False, "no esc_status report while airborne", None, None
    share = float(np.mean(np.all(rpm[up] > 0, axis=1)))
    note = f"rpm > 0 on all {rotors} ESCs in {100 * share:.0f} % of {int(up.sum())} airborne reports"
    return share >= RPM_AIRBORNE_SHARE, note, float(np.median(rpm[up])), float(np.max(rpm[up]))


def _hover(topics: dict, params: dict, spans) -> tuple[float | None, str]:
    hte = topics.get("hover_thrust_estimate")
    if hte is not None and "hover_thrust" in hte:
        up = inside(hte["t"], spans) if spans else np.zeros(len(hte["t"]), dtype=bool)
        if up.any():
            return float(np.median(hte["hover_thrust"][up])), "hover_thrust_estimate (airborne median)"
        return float(np.median(hte["hover_thrust"])), "hover_thrust_estimate (median over the log: no airborne sample)"
    if "MPC_THR_HOVER" in params:
        return float(params["MPC_THR_HOVER"]), "parameter MPC_THR_HOVER"
    return None, ""


def _px4_wind(topics: dict, wind_role: Role, params: dict) -> AutopilotWind:
    drag = bool(int(params.get("EKF2_AID_MASK", 0)) & EKF2_AID_MASK_DRAG) or params.get("EKF2_DRAG_CTRL", 0) > 0
    why = drag_fusion_reason("EKF2", drag, "EKF2_AID_MASK" in params or "EKF2_DRAG_CTRL" in params,
                             "EKF2_AID_MASK bit 5 / EKF2_DRAG_CTRL", "EKF2_AID_MASK or EKF2_DRAG_CTRL")
    if wind_role.source is None:
        return wind_activity(None, None, None, None, why)
    name = wind_role.stream
    north, east = next((a, b) for n, a, b in PX4_WIND_TOPICS if n == name)
    src = topics[name]
    return wind_activity(name, src["t"], src[north], src[east], why)


def _acceleration_note(topics: dict, spans) -> str | None:
    """vehicle_local_position's own acceleration against its velocity's derivative while airborne
    (dobwind/io/accelcheck.py at init's 0.5 Hz band, on the topic's own samples), and what init does about it."""
    from dobwind.io.accelcheck import check_acceleration
    from dobwind.io.logs import FlightLog

    lp = topics.get("vehicle_local_position")
    if lp is None or not spans or not all(k in lp for k in ("vx", "vy", "ax", "ay")) or len(lp["t"]) < 3:
        return None
    order = np.argsort(lp["t"], kind="stable")
    cols = {"t": lp["t"][order], "vel_n": lp["vx"][order], "vel_e": lp["vy"][order], "acc_n": lp["ax"][order],
            "acc_e": lp["ay"][order]}
    check = check_acceleration(FlightLog("vehicle_local_position", cols), inside(cols["t"], spans), "ned", 0.5)
    if check is None:
        return None
    return (f"acceleration: vehicle_local_position: {check.text()}; init makes this check on the rows replay reads, at "
            "the starter's band, and above the limit takes the velocity's derivative (aliased vibration: a fast "
            "signal logged at a few hertz)")


def _damaged(path: str, ulog, topics: dict, roles: tuple[Role, ...]) -> tuple[tuple[Role, ...], list[str]]:
    """Topics read here that pyulog dropped for a damaged format definition (dobwind/io/ulogformat.py), named
    as such in the roles that miss them and in a note; walked only when pyulog found the file corrupt."""
    if not getattr(ulog, "file_corruption", False):
        return roles, []
    damaged = damaged_formats(path, [n for n in TOPICS_READ + EXTRA_TOPICS if n not in topics])
    if not damaged:
        return roles, []
    said = {name: f"{name}: its format definition in the log is damaged ({why})" for name, why in damaged.items()}
    out = tuple(next((replace(r, note=text) for name, text in said.items() if r.source is None
                      and r.note.startswith(f"no {name}")), r) for r in roles)
    return out, [f"{text}: none of its messages can be read" for text in said.values()]


def inspect_ulog_and_position(path: str) -> tuple[LogSummary, Geo | None]:
    """inspect_ulog and the log's position and UTC (position.ulog_geo), from one parse of the file where
    that gives what two would: the 3.5 MB logs of ../shared/data/field take 0.15 s a parse. The topics'
    data of a parse that read the whole file are the same whatever else it parsed (pyulog fills each
    topic from its own messages), so the position is taken from it; its corruption flag and first
    complaint are not (a position topic's damaged message would mark the file corrupt, and hush the
    complaint after it), so a parse with either, or one that stopped early, is followed by inspect's own.
    None: the position was not read (the caller reads it alone)."""
    try:
        ulog, complaint, damage = open_ulog_noted(path, INSPECTED + POSITION_ONLY)
    except InputError:  # inspect's own parse says what is wrong (or reads what this one could not)
        return inspect_ulog(path), None
    if damage.stopped:
        return inspect_ulog(path), None
    geo = ulog_geo(ulog)
    if complaint or damage.skipped or getattr(ulog, "file_corruption", False):
        return inspect_ulog(path), geo
    return _summary(path, ulog, complaint, damage), geo


def inspect_ulog(path: str) -> LogSummary:
    return _summary(path, *open_ulog_noted(path, INSPECTED))


def _summary(path: str, ulog, complaint: str | None, damage: Damage) -> LogSummary:  # type: ignore[no-untyped-def]
    topics = _topics(ulog)
    params = {k: float(ulog.initial_parameters[k]) for k in PARAMETERS
              if k in ulog.initial_parameters and np.isfinite(float(ulog.initial_parameters[k]))}
    if not params.get(BATTERY_SCALE_PARAM, 0):  # listed only when set: off (the default) changes nothing
        params.pop(BATTERY_SCALE_PARAM, None)
    if not topics:
        raise InputError(path, None, "no topic the estimator reads is in the log")
    span = bulk_span(np.concatenate([d["t"] for d in topics.values()]))
    start, end = span.start_s, span.end_s
    found = collective_source(ulog)  # replay's choice of collective thrust, for the role and the spans
    spans, airborne_source = _airborne(topics, params, end, found)
    spans = span.clip(spans)
    roles, damaged = _damaged(path, ulog, topics, _roles(topics, params, found))
    rotors, rotor_source = _rotor_count(topics, params, spans)
    rpm_ok, rpm_note, rpm_median, rpm_max = _rpm(topics, rotors, spans)
    hover, hover_source = _hover(topics, params, spans)
    autostart = f"PX4 SYS_AUTOSTART {int(params['SYS_AUTOSTART'])}" if "SYS_AUTOSTART" in params else "PX4 (no SYS_AUTOSTART)"
    vehicle = Vehicle(rotors, rotor_source, autostart, rpm_ok, rpm_note, hover, hover_source, rpm_median, rpm_max,
                      px4_not_multirotor(params))
    notes = [n for n in (complaint and f"pyulog: {complaint}", truncation(path), damage.stopped, damage.skipped,
                         span.note(),
                         _acceleration_note(topics, spans)) if n] + damaged
    streams = tuple(stream_stats(name, d["t"]) for name, d in sorted(topics.items()))
    return LogSummary(path, "ulog", "PX4", start, end, total(spans) if spans or "unknown" not in airborne_source else None,
                      airborne_source, spans, streams, roles, params, vehicle,
                      _px4_wind(topics, roles[-1], params), tuple(notes), outside_span=span.outside,
                      outside_span_s=span.outside_s)
