"""`dobwind inspect` for ROS 2 bags (the topics dobwind/io/rosbag.py reads, by its setup detection) and for
CSV flight logs (the columns of docs/formats.md, flight log)."""
from __future__ import annotations

import csv
import re

import numpy as np

from dobwind.core.errors import InputError
from dobwind.io.csvchunks import not_text
from dobwind.io.logs import airframe_given_as_log, refuse_an_estimate
from dobwind.inspect.loginspect import AutopilotWind, LogSummary, Role, Vehicle, bulk_span, inside, intervals, stream_stats, total, \
    wind_activity

# rosbag.py's role names -> inspect's roles. "imu" is the specific force (and, under mavros, the attitude).
BAG_ROLES = {"velocity": "velocity", "attitude": "attitude", "imu": "specific_force", "esc": "rpm",
             "thrust": "thrust", "hover": "hover_thrust", "land": "ground", "wind": "autopilot_wind"}
RPM_AIRBORNE_SHARE = 0.95


def _bag_stamps(path: str, wanted: dict[str, str]) -> tuple[dict[str, np.ndarray], list[str]]:
    """Receive times (s) of every message of the wanted topics (not deserialized) and the other topics."""
    from rosbags.rosbag2 import Reader

    from dobwind.io.rosbag import not_a_bag, present_topic

    stamps: dict[str, list[int]] = {}
    try:
        with Reader(path) as reader:
            topics = {c.topic for c in reader.connections}
            names = {r: present_topic(t, topics) for r, t in wanted.items()}
            conns = [c for c in reader.connections if c.topic in set(names.values())]
            for conn, stamp, _ in reader.messages(connections=conns):
                stamps.setdefault(conn.topic, []).append(stamp)
    except Exception as exc:  # rosbags raises its own kinds on damaged bags
        raise not_a_bag(path, exc) from None
    for role, name in names.items():
        wanted[role] = name or wanted[role]
    others = sorted(topics - set(stamps))
    return {t: np.array(s, dtype=float) * 1e-9 for t, s in stamps.items()}, others


def _bag_ground(setup: str, rows: list, end_s: float) -> tuple[tuple[tuple[float, float], ...], str]:
    """PX4 bags: airborne from vehicle_land_detected (landed or maybe_landed or ground_contact)."""
    if setup != "px4":
        return (), "unknown: mavros bags carry no land detection"
    if not rows:
        return (), "unknown: no vehicle_land_detected"
    t = np.array([m.timestamp * 1e-6 for _, m in rows])
    ground = np.array([bool(getattr(m, "landed", False) or getattr(m, "maybe_landed", False)
                            or getattr(m, "ground_contact", False)) for _, m in rows])
    return intervals(t, ~ground, end_s), "vehicle_land_detected"


def _bag_esc(setup: str, rows: list, spans) -> tuple[int | None, bool, str, float | None, float | None]:
    """Rotor count (the ESCs reporting) and whether every one reads rpm > 0 while airborne."""
    from dobwind.io.rosbag import message_stamp

    if not rows:
        return None, False, "no ESC messages", None, None
    px4 = setup == "px4"
    t = np.array([message_stamp(m, stamp, px4) for stamp, m in rows])
    reports = [[r.esc_rpm for r in m.esc[:m.esc_count]] if px4 else [r.rpm for r in m.esc_status] for _, m in rows]
    rotors = max(len(r) for r in reports)
    if rotors == 0:
        return None, False, "ESC messages report no ESC", None, None
    rpm = np.array([r + [0] * (rotors - len(r)) for r in reports], dtype=float)
    up = inside(t, spans) if spans else np.ones(len(t), dtype=bool)
    share = float(np.mean(np.all(rpm[up] > 0, axis=1))) if up.any() else 0.0
    note = f"rpm > 0 on all {rotors} ESCs in {100 * share:.0f} % of {int(up.sum())} " + ("airborne " if spans else "") + "reports"
    return (rotors, share >= RPM_AIRBORNE_SHARE, note, float(np.median(rpm[up])) if up.any() else None,
            float(np.max(rpm[up])) if up.any() else None)


def _bag_wind(setup: str, topic: str | None, rows: list) -> AutopilotWind:
    from dobwind.io.rosbag import message_stamp

    if not rows:
        return wind_activity(None, None, None, None)
    px4 = setup == "px4"
    t = np.array([message_stamp(m, stamp, px4) for stamp, m in rows])
    # PX4's wind is NED; mavros' wind_estimation is ENU (x east, y north).
    ne = np.array([[m.windspeed_north, m.windspeed_east] if px4 else [m.twist.twist.linear.y, m.twist.twist.linear.x]
                   for _, m in rows], dtype=float)
    return wind_activity(topic, t, ne[:, 0], ne[:, 1])


def _bag_roles(setup: str, wanted: dict[str, str], stamps: dict[str, np.ndarray]) -> dict[str, Role]:
    roles = {}
    for bag_role, role in BAG_ROLES.items():
        topic = wanted.get(bag_role)
        roles[role] = (Role(role, topic, topic) if topic in stamps and len(stamps[topic]) >= 2 else
                       Role(role, None, None, f"no {topic}" if topic else f"the {setup} setup has no such topic"))
    if setup == "mavros" and roles["specific_force"].source:
        roles["attitude"] = Role("attitude", f"{wanted['imu']} (orientation)", wanted["imu"])
    imu = roles["specific_force"]
    roles["acceleration"] = Role("acceleration", "IMU specific force rotated to NED, plus gravity", imu.stream) \
        if imu.source else Role("acceleration", None, None, "no IMU topic")
    roles["heading"] = Role("heading", "the vehicle's own yaw", roles["attitude"].stream)
    order = ("velocity", "acceleration", "specific_force", "attitude", "rpm", "thrust", "hover_thrust", "heading",
             "ground", "autopilot_wind")
    return {r: roles.get(r, Role(r, None, None, f"the {setup} setup has no such topic")) for r in order}


def inspect_rosbag(path: str) -> LogSummary:
    from dobwind.io.rosbag import collect_messages, bag_setup

    setup, wanted = bag_setup(path, {}, {})
    stamps, others = _bag_stamps(path, wanted)
    if not stamps:
        raise InputError(path, None, "no topic the estimator reads is in the bag")
    start = min(float(s.min()) for s in stamps.values())
    end = max(float(s.max()) for s in stamps.values())
    roles = _bag_roles(setup, wanted, stamps)
    read = {r: wanted[r] for r in ("land", "esc", "wind") if r in wanted and wanted[r] in stamps}
    msgs, _ = collect_messages(path, read) if read else ({}, set())
    spans, airborne_source = _bag_ground(setup, msgs.get("land", []), end)
    rotors, rpm_ok, rpm_note, rpm_median, rpm_max = _bag_esc(setup, msgs.get("esc", []), spans)
    vehicle = Vehicle(rotors, "the ESCs reporting" if rotors else "no ESC topic: give it in the airframe",
                      f"ROS 2 bag ({setup} setup)", rpm_ok, rpm_note, None, "", rpm_median, rpm_max)
    return LogSummary(path, "rosbag", "PX4" if setup == "px4" else "mavros", start, end,
                      total(spans) if spans else None, airborne_source, spans,
                      tuple(stream_stats(t, s) for t, s in sorted(stamps.items())), tuple(roles.values()), {},
                      vehicle, _bag_wind(setup, read.get("wind"), msgs.get("wind", [])),
                      (f"{setup} setup (by the bag's topic names)",), tuple(others))


# Flight-log CSV columns (docs/formats.md) per role.
CSV_ROLES = {"velocity": ("vel_n", "vel_e", "vel_d"), "acceleration": ("acc_n", "acc_e", "acc_d"),
             "specific_force": ("sf_x", "sf_y", "sf_z"), "attitude": ("q_w", "q_x", "q_y", "q_z"),
             "thrust": ("thrust",), "heading": ("yaw_ref",)}


def _csv_columns(path: str) -> tuple[list[str], dict[str, np.ndarray]]:
    try:
        with open(path, newline="", encoding="utf-8-sig") as handle:
            rows = [r for r in csv.reader(handle) if r and not r[0].lstrip().startswith("#")]
    except OSError as exc:
        raise InputError(path, None, f"cannot read: {exc.strerror}") from None
    except UnicodeDecodeError:
        with open(path, "rb") as handle:
            raise InputError(path, None, not_text(handle.read(2))) from None
    if not rows:
        raise InputError(path, None, "empty: no header line")
    header = [h.strip() for h in rows[0]]
    refuse_an_estimate(path, header)
    if "t" not in header:
        raise InputError(path, "column t", "missing from the header (a flight log's time, s)" + airframe_given_as_log(path))
    cols: dict[str, np.ndarray] = {}
    for k, name in enumerate(header):
        if name == "t" or re.fullmatch(r"rpm_\d+", name):
            try:
                cols[name] = np.array([float(r[k]) if k < len(r) and r[k].strip() else np.nan for r in rows[1:]])
            except ValueError:
                raise InputError(path, f"column {name}", "holds text that is not a number") from None
    return header, cols


def inspect_csv(path: str) -> LogSummary:
    header, cols = _csv_columns(path)
    t = cols["t"]
    if len(t) < 2:
        raise InputError(path, None, "fewer than two rows")
    stream = stream_stats("rows", t)
    roles = [Role(role, ", ".join(names), "rows") if all(n in header for n in names)
             else Role(role, None, None, "no columns " + ", ".join(names)) for role, names in CSV_ROLES.items()]
    rpm_cols = sorted((c for c in cols if c.startswith("rpm_")), key=lambda c: int(c[4:]))
    roles.insert(4, Role("rpm", ", ".join(rpm_cols), "rows") if rpm_cols else Role("rpm", None, None, "no rpm_k columns"))
    roles.insert(6, Role("hover_thrust", "not needed: CSV thrust is in newtons", None))
    roles += [Role("ground", None, None, "CSV logs carry no ground state: every row is fed"),
              Role("autopilot_wind", "wind_n, wind_e, wind_d (the true wind)", "rows") if "wind_n" in header
              else Role("autopilot_wind", None, None, "no wind columns")]
    rpm = np.column_stack([cols[c] for c in rpm_cols]) if rpm_cols else None
    share = float(np.mean(np.all(rpm > 0, axis=1))) if rpm is not None else 0.0
    vehicle = Vehicle(len(rpm_cols) or None, "rpm_k columns" if rpm_cols else "no rpm_k columns", "CSV flight log",
                      share >= RPM_AIRBORNE_SHARE, f"rpm > 0 on every rotor in {100 * share:.0f} % of rows" if rpm_cols else "",
                      None, "", float(np.nanmedian(rpm)) if rpm is not None else None,
                      float(np.nanmax(rpm)) if rpm is not None else None)
    span = bulk_span(t)
    if span.samples < 2:
        raise InputError(path, "column t", "fewer than two rows with a finite time")
    spans = ((span.start_s, span.end_s),)
    notes = ("rates are of the rows: a CSV log has one clock",) + ((span.note(),) if span.outside else ())
    return LogSummary(path, "csv", None, span.start_s, span.end_s, total(spans), "every row (CSV: no ground state)",
                      spans, (stream,), tuple(roles), {}, vehicle, wind_activity(None, None, None, None),
                      tuple(n for n in notes if n), outside_span=span.outside, outside_span_s=span.outside_s)
