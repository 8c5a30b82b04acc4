"""ROS 2 bags (`.mcap`, `.db3`, or a bag folder) onto the estimator's inputs, read with rosbags (pure
Python, no ROS install; optional dependency group `rosbag`).

Two setups, told apart by their topics (every name can be replaced: `replay --topic ROLE=NAME`):
- PX4 over micro XRCE-DDS (px4_msgs, microsecond `timestamp` fields; PX4 1.16 adds `_v1` to some
  names, tried too, and the microRTPS bridge of v1.13 and earlier named them /fmu/NAME/out, tried too,
  with that version's VehicleOdometry layout):
  velocity /fmu/out/vehicle_odometry (velocity_frame NED, or BODY_FRD rotated by its q), else
  /fmu/out/vehicle_local_position (vx, vy, vz: NED; read with the bag's own message definition),
  attitude /fmu/out/vehicle_attitude (q: FRD body to NED), imu /fmu/out/sensor_combined
  (accelerometer_m_s2, FRD), esc /fmu/out/esc_status, land /fmu/out/vehicle_land_detected,
  wind /fmu/out/wind (comparison); collective airframes: thrust /fmu/out/vehicle_thrust_setpoint
  (xyz[2]) and hover /fmu/out/hover_thrust_estimate, as in the ULog path. PX4's default dds_topics.yaml
  publishes neither esc_status nor a thrust setpoint: the error says which topic to add to it.
- mavros (header stamps): velocity /mavros/local_position/velocity_local (ENU, converted to NED),
  imu /mavros/imu/data (orientation FLU body to ENU, acceleration FLU; both converted to FRD/NED),
  esc /mavros/esc_status/status, wind /mavros/wind_estimation (ENU).
NED acceleration (observer.acceleration = "ned") is the IMU's specific force rotated to NED plus
gravity. Message types come from the bag's own definitions when it stores them (MCAP, rosbag2 v8+),
else from the small .msg files in dobwind/io/msgs/. Resampling (a uniform clock at the observer's rate,
each topic's own gap tolerance), NO_DATA and LANDED as for ULog.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from dobwind.core.errors import InputError
from dobwind.io.logs import FlightLog
from dobwind.model.airframe import Airframe
from dobwind.io.bridge import blanked, bridge, largest_silences
from dobwind.io.resample import (ROTOR_MAX_GAP_S, AutopilotFlight, blank, count_note, quaternions, source_gaps,
                              topic_tolerances, uniform_clock)
from dobwind.model.signals import log_signals

PX4_TOPICS = {"velocity": "/fmu/out/vehicle_odometry", "attitude": "/fmu/out/vehicle_attitude",
              "imu": "/fmu/out/sensor_combined", "esc": "/fmu/out/esc_status",
              "thrust": "/fmu/out/vehicle_thrust_setpoint", "hover": "/fmu/out/hover_thrust_estimate",
              "land": "/fmu/out/vehicle_land_detected", "wind": "/fmu/out/wind"}
MAVROS_TOPICS = {"velocity": "/mavros/local_position/velocity_local", "imu": "/mavros/imu/data",
                 "esc": "/mavros/esc_status/status", "wind": "/mavros/wind_estimation"}
# A default topic the bag lacks is looked for under these names too (each also with PX4 1.16's _v1).
ALTERNATIVES = {"/fmu/out/vehicle_odometry": ("/fmu/out/vehicle_local_position",)}
MSG_DIR = Path(__file__).parent / "msgs"
# Frame changes as quaternions (w, x, y, z): ENU->NED is a half turn about (1, 1, 0)/sqrt 2, FRD->FLU a
# half turn about x. q_ned_frd = Q_NED_ENU * q_enu_flu * Q_FLU_FRD.
_H = 0.5 ** 0.5
Q_NED_ENU = np.array([0.0, _H, _H, 0.0])
Q_FLU_FRD = np.array([0.0, 1.0, 0.0, 0.0])
BODY_FRD = 3  # px4_msgs VehicleOdometry.VELOCITY_FRAME_BODY_FRD; 1 is NED


def qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products of (w, x, y, z) rows."""
    aw, ax, ay, az = np.moveaxis(np.atleast_2d(a), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.atleast_2d(b), -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """v rotated by unit quaternions q (rows)."""
    qv = np.column_stack([np.zeros(len(v)), v])
    conj = q * np.array([1.0, -1.0, -1.0, -1.0])
    return qmul(qmul(q, qv), conj)[:, 1:]


def enu_to_ned(v: np.ndarray) -> np.ndarray:
    return np.column_stack([v[:, 1], v[:, 0], -v[:, 2]])


def _typestore(path: str, connections) -> object:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types: dict = {}
    for pkg in ("px4_msgs", "mavros_msgs"):
        for f in sorted((MSG_DIR / pkg).glob("*.msg")):
            types.update(get_types_from_msg(f.read_text(), f"{pkg}/msg/{f.stem}"))
    for conn in connections:  # the bag's own definitions win: message layouts change between versions
        msgdef = getattr(conn, "msgdef", None)
        text = getattr(msgdef, "data", msgdef) if msgdef is not None else None
        if text and conn.msgtype not in store.types:
            try:
                types.update(get_types_from_msg(text, conn.msgtype))
            except Exception:  # a definition in another format (IDL): keep the shipped one
                pass
    store.register({k: v for k, v in types.items() if k not in store.types})
    return store


def present_topic(topic: str, topics: set[str]) -> str | None:
    """The name under which the bag holds a wanted topic: itself, its _v1, or an alternative's; for a
    PX4 /fmu/out/NAME also the /fmu/NAME/out of the microRTPS bridge (PX4 v1.13 and earlier)."""
    for name in (topic, *ALTERNATIVES.get(topic, ())):
        rtps = (f"/fmu/{name[len('/fmu/out/'):]}/out",) if name.startswith("/fmu/out/") else ()
        for candidate in (name, f"{name}_v1", *rtps):
            if candidate in topics:
                return candidate
    return None


def collect_messages(path: str, wanted: dict[str, str]) -> tuple[dict[str, list], set[str]]:
    """The deserialized messages of each wanted role and every topic in the bag; ``wanted`` is updated
    to the names actually read (a _v1 or an alternative topic), so that notes and errors name them."""
    try:
        from rosbags.rosbag2 import Reader
    except ImportError:  # pragma: no cover - the rosbag extra is part of `make setup`
        raise InputError(path, None, "reading ROS 2 bags needs rosbags (pip install 'dobwind[rosbag]')") from None
    out: dict[str, list] = {role: [] for role in wanted}
    try:
        with Reader(path) as reader:
            topics = {c.topic for c in reader.connections}
            by_topic = {}
            for role, topic in wanted.items():
                name = present_topic(topic, topics)
                if name is not None:
                    by_topic[name] = role
                    wanted[role] = name
            conns = [c for c in reader.connections if c.topic in by_topic]
            store = _typestore(path, conns)
            for conn, stamp, raw in reader.messages(connections=conns):
                out[by_topic[conn.topic]].append((stamp, _decoded(path, store, conn, raw)))
    except InputError:
        raise
    except Exception as exc:  # rosbags raises its own kinds on damaged bags and unknown types
        raise not_a_bag(path, exc) from None
    return out, topics


def _decoded(path: str, store, conn, raw: bytes):
    """One message, or exit 2 naming the topic and the definition that did not fit: a bag without its
    own definitions (rosbag2 before Iron, as the microRTPS bridge's users recorded) is decoded with the
    px4_msgs dobwind ships, whose layouts are v1.14's and later (VehicleOdometry's among them)."""
    try:
        return store.deserialize_cdr(raw, conn.msgtype)
    except Exception as exc:  # rosbags' SerdeError and kin: the bytes do not fit the layout
        msgdef = getattr(conn, "msgdef", None)
        own = bool(getattr(msgdef, "data", msgdef)) if msgdef is not None else False
        whose = ("the bag's own definition" if own else "the definition dobwind ships (px4_msgs of PX4 v1.14 "
                 "and later; the bag carries none: record with message definitions, e.g. MCAP)")
        raise InputError(path, f"topic {conn.topic}", f"{conn.msgtype} does not decode with {whose} "
                         f"({type(exc).__name__}: {str(exc)[:80]})") from None


def not_a_bag(path: str, exc: Exception) -> InputError:
    """The one-line complaint for a bag rosbags cannot open. A plain folder gets its own words: rosbags
    says "Expected metadata file 'DIR' does not exist", which names neither the file nor the fix."""
    if Path(path).is_dir() and not (Path(path) / "metadata.yaml").exists():
        return InputError(path, None, "a folder without metadata.yaml, so not a ROS 2 bag: give one log file "
                          "(replay and profile also take a folder of logs)")
    return InputError(path, None, f"not a readable ROS 2 bag ({type(exc).__name__}: {str(exc)[:100]})")


def message_stamp(msg, bag_ns: int, px4: bool) -> float:
    if px4:
        return msg.timestamp * 1e-6
    header = getattr(msg, "header", None)
    return header.stamp.sec + header.stamp.nanosec * 1e-9 if header is not None else bag_ns * 1e-9


def _series(items: list, px4: bool, values) -> dict | None:
    """{'t': seconds, 'v': rows} sorted by time without repeated stamps, or None if under two."""
    if len(items) < 2:
        return None
    t = np.array([message_stamp(m, s, px4) for s, m in items])
    v = np.array([values(m) for _, m in items], dtype=float)
    order = np.argsort(t, kind="stable")
    keep = order[np.r_[True, np.diff(t[order]) > 0]]
    return {"t": t[keep], "v": v[keep]}


def _velocity(path: str, m) -> np.ndarray:
    """NED ground velocity from vehicle_odometry (either px4_msgs layout) or vehicle_local_position. Before
    v1.14 VehicleOdometry held vx vy vz and numbered its frames from LOCAL_FRAME_NED = 0 (BODY_FRAME_FRD 3);
    v1.14 holds velocity[3] with VELOCITY_FRAME_NED = 1 (BODY_FRD 3)."""
    if hasattr(m, "velocity"):
        v, ned = np.asarray(m.velocity, dtype=float), 1
    elif hasattr(m, "velocity_frame"):
        v, ned = np.array([m.vx, m.vy, m.vz], dtype=float), 0
    else:  # vehicle_local_position: NED
        return np.array([m.vx, m.vy, m.vz], dtype=float)
    if m.velocity_frame == BODY_FRD:
        return rotate(np.asarray(m.q, dtype=float)[None], v[None])[0]
    if m.velocity_frame != ned:
        raise InputError(path, "vehicle_odometry.velocity_frame", f"is {m.velocity_frame}: only NED ({ned}) "
                         f"and BODY_FRD (3) have a known heading{'' if ned else ' (px4_msgs before v1.14)'}")
    return v


def _px4_streams(path: str, msgs: dict, rotors: int) -> dict:
    s = {"velocity": _series(msgs["velocity"], True, lambda m: _velocity(path, m)),
         "attitude": _series(msgs["attitude"], True, lambda m: m.q),
         "imu": _series(msgs["imu"], True, lambda m: m.accelerometer_m_s2),
         "wind": _series(msgs["wind"], True, lambda m: [m.windspeed_north, m.windspeed_east, 0.0]),
         "land": _series(msgs["land"], True, lambda m: [m.landed, m.maybe_landed, m.ground_contact])}
    if rotors:
        s["esc"] = _series(msgs["esc"], True, lambda m: [m.esc_count, m.esc_online_flags]
                           + [m.esc[i].esc_rpm for i in range(rotors)])
    else:
        s["thrust"] = _series(msgs["thrust"], True, lambda m: [m.xyz[2]])
        hover = _series(msgs["hover"], True, lambda m: [m.hover_thrust, getattr(m, "valid", True)])
        s["hover"] = _valid_hover(hover)
        s["hover_never_valid"] = hover is not None and not np.any(hover["v"][:, 1] > 0)
    return s


def _valid_hover(series: dict | None) -> dict | None:
    """As the ULog path (ulog._converged_hover): only estimates PX4 calls valid count (column 1 of the
    series), when there are any (a bag has no MPC_THR_HOVER to fall back on). The others read as the last
    valid one before them (the first valid one before any), so the series keeps its stamps: its first one
    bounds the clock's start. Returns the hover thrust alone (one column)."""
    if series is None:
        return None
    ok = series["v"][:, 1] > 0
    index = np.arange(len(ok)) if ok.all() or not ok.any() else np.maximum.accumulate(np.where(ok, np.arange(len(ok)), -1))
    index = np.where(index < 0, int(np.argmax(ok)), index)
    return {"t": series["t"], "v": series["v"][index, :1]}


def _mavros_streams(path: str, msgs: dict, rotors: int) -> dict:
    def esc(m):
        if len(m.esc_status) < rotors:
            return [np.nan] * rotors  # a short report: no data for this instant
        return [m.esc_status[i].rpm for i in range(rotors)]

    def orientation(m):
        o = m.orientation
        return qmul(qmul(Q_NED_ENU, np.array([o.w, o.x, o.y, o.z])), Q_FLU_FRD)[0]

    def accel(m):
        a = m.linear_acceleration
        return [a.x, -a.y, -a.z]  # FLU -> FRD

    s = {"velocity": _series(msgs["velocity"], False, lambda m: enu_to_ned(np.array([[m.twist.linear.x, m.twist.linear.y, m.twist.linear.z]]))[0]),
         "attitude": _series(msgs["imu"], False, orientation),
         "imu": _series(msgs["imu"], False, accel),
         "wind": _series(msgs["wind"], False, lambda m: enu_to_ned(np.array([[m.twist.twist.linear.x, m.twist.twist.linear.y, m.twist.twist.linear.z]]))[0]),
         "land": None}
    if rotors:
        s["esc"] = _series(msgs["esc"], False, esc)
    return s


def bag_setup(path: str, overrides: dict[str, str], from_airframe: dict[str, str]) -> tuple[str, dict[str, str]]:
    """The setup (by the bag's topics) and its topic per role: defaults, then the airframe's
    [ros2_topics] (roles of the other setup are ignored), then --topic (checked)."""
    from rosbags.rosbag2 import Reader

    try:
        with Reader(path) as reader:
            topics = {c.topic for c in reader.connections}
    except Exception as exc:
        raise not_a_bag(path, exc) from None
    # The bag's topics decide; only a bag with neither kind goes by the names the user gave.
    named = topics if any(t.startswith(("/fmu/", "/mavros/")) for t in topics) else set(overrides.values())
    px4 = not any(t.startswith("/mavros/") for t in named)
    defaults = PX4_TOPICS if px4 else MAVROS_TOPICS
    unknown = set(overrides) - set(defaults)
    if unknown:
        raise InputError(path, f"--topic {sorted(unknown)[0]}", f"is not a role of the {'PX4' if px4 else 'mavros'} "
                         f"setup (roles: {', '.join(defaults)})")
    from_file = {r: t for r, t in from_airframe.items() if r in defaults}
    return ("px4" if px4 else "mavros"), {**defaults, **from_file, **overrides}


def read_rosbag(path: str, af: Airframe, rate_hz: float | None = None,
                overrides: dict[str, str] | None = None, bridge_gaps: bool = False) -> AutopilotFlight:
    setup, wanted = bag_setup(path, overrides or {}, dict(af.ros2_topics))
    collective = af.thrust.source == "collective"
    if collective and setup != "px4":
        raise InputError(path, "thrust.source", "\"collective\" needs a thrust topic, which mavros does not record: "
                         "use an rpm airframe with ESC telemetry, or the autopilot's own log")
    msgs, topics = collect_messages(path, wanted)
    rotors = 0 if collective else af.thrust.rotors
    try:
        s = (_px4_streams if setup == "px4" else _mavros_streams)(path, msgs, rotors)
    except (AttributeError, IndexError, TypeError) as exc:  # a topic of another message type than the role's
        raise InputError(path, "topics " + ", ".join(wanted[r] for r in wanted if msgs[r]),
                         f"not the message types of the {setup} setup ({type(exc).__name__}: {str(exc)[:80]})") from None
    need = [("velocity", "ground velocity"), ("attitude", "attitude"), ("imu", "specific force")]
    need += [("thrust", "collective thrust"), ("hover", "hover thrust, to scale it to newtons")] if collective else \
        [("esc", f"rotor speeds of {rotors} motors")]
    for role, what in need:
        if s[role] is None:
            hint = (f"; PX4's default dds_topics.yaml does not publish {wanted[role].rsplit('/', 1)[-1]}: add "
                    f"{wanted[role]} to it" if role in ("esc", "thrust", "hover") else "")
            raise InputError(path, f"topic {wanted['imu' if role == 'attitude' and setup == 'mavros' else role]}",
                             f"missing from the bag or fewer than two messages ({what}){hint}")
    notes = [f"{setup} topics: " + ", ".join(f"{r} {wanted[r]} ({len(msgs[r])})" for r in wanted if msgs[r])]
    if s.get("hover_never_valid"):  # said, as the ULog path says its fallback to MPC_THR_HOVER
        notes.append("hover_thrust_estimate never valid: the thrust is scaled by its unconverged estimates (a bag "
                     "carries no MPC_THR_HOVER parameter to fall back on)")
    return _assemble(path, af, s, rate_hz, notes, wanted["wind"], bridge_gaps)


def _assemble(path: str, af: Airframe, s: dict, rate_hz: float | None, notes: list[str],
              wind_topic: str = "wind", bridge_gaps: bool = False) -> AutopilotFlight:
    rpm = log_signals(af).rotor_speeds
    used = {r: s[r] for r in ("velocity", "attitude", "imu") + (("esc",) if rpm else ("thrust", "hover")) if s[r]}
    att_t = s["attitude"]["t"]
    # The hover estimate, a slowly learned constant, is held past its last message and has no gaps.
    timed = {role: x["t"] for role, x in used.items() if role != "hover"}
    hover_start = [used["hover"]["t"][:1]] if "hover" in used else []
    clock = uniform_clock(path, list(timed.values()) + [np.r_[t0, np.inf] for t0 in hover_start],
                          rate_hz or 1.0 / af.observer.sample_time_s)
    # ESC reports are slow (ROTOR_MAX_GAP_S).
    tolerances, slow = topic_tolerances(timed, af.limits.max_dt_s, {"esc": ROTOR_MAX_GAP_S})
    notes += slow
    no_data, culprits = source_gaps(tolerances, clock)
    gappy = no_data.copy()
    q = quaternions(att_t, s["attitude"]["v"], clock)
    sf = np.column_stack([np.interp(clock, s["imu"]["t"], s["imu"]["v"][:, i]) for i in range(3)])
    v = np.column_stack([np.interp(clock, s["velocity"]["t"], s["velocity"]["v"][:, i]) for i in range(3)])
    cols = {"t": clock - clock[0], "vel_n": v[:, 0], "vel_e": v[:, 1], "vel_d": v[:, 2],
            "q_w": q[:, 0], "q_x": q[:, 1], "q_y": q[:, 2], "q_z": q[:, 3]}
    if log_signals(af).specific_force:
        cols.update(sf_x=sf[:, 0], sf_y=sf[:, 1], sf_z=sf[:, 2])
    elif log_signals(af).ned_acceleration:
        acc = rotate(q, sf) + np.array([0.0, 0.0, af.gravity_mps2])
        cols.update(acc_n=acc[:, 0], acc_e=acc[:, 1], acc_d=acc[:, 2])
        notes.append("NED acceleration is the IMU's specific force rotated to NED, plus gravity")
    landed = _landed(s["land"], clock, notes)
    if rpm:
        no_data |= _rotor_columns(af, s["esc"], clock, cols, ~landed & ~no_data, notes)
    else:
        cols["thrust"] = _collective(af, s["thrust"], s["hover"], clock)
        notes.append("collective thrust from vehicle_thrust_setpoint.xyz[2] / hover_thrust_estimate.hover_thrust times m g")
    if gappy.any():
        notes.append(count_note(gappy, f"with a topic gap (longer than max_dt {af.limits.max_dt_s:g} s or, for a slow "
                                       f"topic, than its own tolerance; esc: {ROTOR_MAX_GAP_S:g} s; by role: "
                                       f"{culprits})", "NO_DATA"))
    wind = s["wind"]
    ap_wind = None if wind is None else (f"ROS 2 {wind_topic}", wind["t"] - clock[0], wind["v"])
    bridged = None
    if bridge_gaps:
        bridged, note = bridge(af, tolerances, clock, gappy, landed | (no_data & ~gappy), ("thrust",))
        notes += note
    return AutopilotFlight(FlightLog(path, blank(cols, blanked(no_data, landed, bridged))), no_data, landed, ap_wind,
                           tuple(notes), float(clock[0]), bridged=bridged,
                           silences=largest_silences(tolerances, clock))


def _collective(af: Airframe, thrust: dict, hover: dict, clock: np.ndarray) -> np.ndarray:
    """Newtons from PX4's normalized setpoint (body z down: upward thrust is negative), both held."""
    def held(x: dict) -> np.ndarray:
        return x["v"][np.clip(np.searchsorted(x["t"], clock, side="right") - 1, 0, len(x["t"]) - 1), 0]

    return af.mass_kg * af.gravity_mps2 * -held(thrust) / held(hover)


def _rotor_columns(af: Airframe, esc: dict, clock: np.ndarray, cols: dict, airborne: np.ndarray,
                   notes: list[str]) -> np.ndarray:
    """rpm_i columns; returns the rows without rotor speeds (dead ESCs airborne, short reports)."""
    from dobwind.io.ulog import esc_missing

    rotors = af.thrust.rotors
    k = esc["v"].shape[1] - rotors  # px4: esc_count and online flags come first
    for i in range(rotors):
        cols[f"rpm_{i + 1}"] = np.interp(clock, esc["t"], esc["v"][:, k + i])
    report = {"t": esc["t"], **{f"esc[{i}].esc_rpm": np.nan_to_num(esc["v"][:, k + i]) for i in range(rotors)}}
    if k == 2:
        report.update(esc_count=esc["v"][:, 0], esc_online_flags=esc["v"][:, 1])
    dead, note = esc_missing(report, rotors, clock, airborne)
    if note:
        notes.append(note)
    return dead | ~np.all(np.isfinite(np.column_stack([cols[f"rpm_{i + 1}"] for i in range(rotors)])), axis=1)


def _landed(land: dict | None, clock: np.ndarray, notes: list[str]) -> np.ndarray:
    if land is None:
        notes.append("no land detector topic: every instant is treated as airborne")
        return np.zeros(len(clock), dtype=bool)
    flags = land["v"][np.clip(np.searchsorted(land["t"], clock, side="right") - 1, 0, len(land["t"]) - 1)]
    ground = np.any(flags > 0.5, axis=1) & (clock >= land["t"][0])
    if ground.any():
        notes.append(count_note(ground, "on the ground (landed, maybe_landed or ground_contact)", "LANDED"))
    return ground
