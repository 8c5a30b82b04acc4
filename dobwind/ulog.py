"""PX4 ULog flights onto the estimator's inputs (pyulog, optional dependency group `ulog`).

Topics: vehicle_local_position (vx vy vz, ax ay az), vehicle_attitude (q), esc_status (esc_rpm per
motor) for rpm airframes, vehicle_thrust_setpoint (xyz[2]) or the older vehicle_attitude_setpoint
(thrust_body[2]) scaled by hover_thrust_estimate (or the MPC_THR_HOVER parameter) times m g for
collective airframes, sensor_combined (accelerometer) for specific force, and
vehicle_attitude_setpoint (yaw_body) for the heading frame, else the vehicle's own yaw.

Everything is resampled onto one clock (the attitude's, or a uniform --rate) inside the span all
needed topics cover: continuous signals are interpolated (quaternions sign-aligned, then normalised),
setpoints are held. Where a topic has a gap longer than the airframe's max_dt around an instant,
that row has no data: its inputs are NaN and replay marks it with the NO_DATA status bit.
"""
from __future__ import annotations

import contextlib
import io
import os
from dataclasses import dataclass

import numpy as np

from dobwind.errors import InputError
from dobwind.logs import FlightLog
from dobwind.model.airframe import Airframe

PX4_WIND_TOPICS = (("wind", "windspeed_north", "windspeed_east"),
                   ("wind_estimate", "windspeed_north", "windspeed_east"),
                   ("estimator_states", "states[22]", "states[23]"))


@dataclass(frozen=True)
class UlogFlight:
    log: FlightLog
    no_data: np.ndarray                     # rows without data from some topic
    landed: np.ndarray                      # rows where vehicle_land_detected says landed
    px4_wind: tuple[str, np.ndarray, np.ndarray] | None  # (topic, t, wind NED rows)
    notes: tuple[str, ...]


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

    def __getattr__(self, name: str):
        return getattr(self._handle, name)


READS_PER_BYTE = 3    # resynchronising after corruption advances one byte per two reads
EXTRA_READS = 1 << 16


def _open(path: str) -> tuple[object, str | None]:
    """pyulog's parse of ``path`` and its first complaint, if it printed one (pyulog prints to stdout,
    which must stay one JSON object under --json)."""
    try:
        from pyulog import ULog
    except ImportError:  # pragma: no cover - the ulog extra is part of `make setup`
        raise InputError(path, None, "reading ULog needs pyulog (pip install 'dobwind[ulog]')") from None
    printed = io.StringIO()
    try:
        with open(path, "rb") as handle, contextlib.redirect_stdout(printed):
            ulog = ULog(_BudgetedFile(handle, os.fstat(handle.fileno()).st_size))
    except _NoProgress:
        raise InputError(path, None, "not a readable ULog file (corrupt: the parser made no progress)") from None
    except OSError as exc:
        raise InputError(path, None, f"cannot read: {exc.strerror}") from None
    except Exception as exc:  # pyulog raises many kinds on corrupt or truncated files
        raise InputError(path, None, f"not a readable ULog file ({type(exc).__name__}: {str(exc)[:80]})") from None
    complaints = [line.strip() for line in printed.getvalue().splitlines() if line.strip()]
    return ulog, (complaints[0][:120] if complaints else None)


def _topic(ulog, name: str, fields: list[str]) -> dict[str, np.ndarray] | None:
    for data in ulog.data_list:
        if data.name == name and data.multi_id == 0 and all(f in data.data for f in fields):
            if len(data.data["timestamp"]) < 2:
                return None
            out = {f: np.asarray(data.data[f], dtype=float) for f in fields}
            out["t"] = np.asarray(data.data["timestamp"], dtype=float) * 1e-6
            return out
    return None


def _gaps(t_src: np.ndarray, t_dst: np.ndarray, max_gap: float) -> np.ndarray:
    """True where t_dst is outside the topic's span or between samples farther apart than max_gap."""
    idx = np.searchsorted(t_src, t_dst, side="right")
    outside = (idx == 0) | (t_dst > t_src[-1])
    prev = t_src[np.clip(idx - 1, 0, len(t_src) - 1)]
    nxt = t_src[np.clip(idx, 0, len(t_src) - 1)]
    exact = t_dst == prev
    return outside | (~exact & ((nxt - prev) > max_gap))


def _interp(src: dict, fields: list[str], t: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(t, src["t"], src[f]) for f in fields])


def _hold(src: dict, fields: list[str], t: np.ndarray) -> np.ndarray:
    idx = np.clip(np.searchsorted(src["t"], t, side="right") - 1, 0, len(src["t"]) - 1)
    return np.column_stack([src[f][idx] for f in fields])


def _quaternions(src: dict, t: np.ndarray) -> np.ndarray:
    q = np.column_stack([src[f"q[{i}]"] for i in range(4)])
    flips = np.cumsum(np.r_[0, np.einsum("ij,ij->i", q[1:], q[:-1]) < 0]) % 2  # same hemisphere throughout
    aligned = {"t": src["t"], **{f"q[{i}]": np.where(flips == 1, -q[:, i], q[:, i]) for i in range(4)}}
    out = _interp(aligned, [f"q[{i}]" for i in range(4)], t)
    return out / np.linalg.norm(out, axis=1)[:, None]


def read_ulog(path: str, af: Airframe, rate_hz: float | None = None) -> UlogFlight:
    ulog, complaint = _open(path)
    need: dict[str, tuple[list[str], str]] = {
        "vehicle_local_position": (["vx", "vy", "vz"] + (["ax", "ay", "az"] if af.observer.acceleration == "ned" else []),
                                   "ground velocity" + (" and acceleration" if af.observer.acceleration == "ned" else "")),
        "vehicle_attitude": ([f"q[{i}]" for i in range(4)], "attitude"),
    }
    if af.observer.acceleration == "specific_force":
        need["sensor_combined"] = ([f"accelerometer_m_s2[{i}]" for i in range(3)], "specific force")
    if af.thrust.source == "rpm":
        need["esc_status"] = ([f"esc[{i}].esc_rpm" for i in range(af.thrust.rotors)],
                              f"rotor speeds of {af.thrust.rotors} motors (thrust.source = \"rpm\")")
    topics = {name: _topic(ulog, name, fields) for name, (fields, _) in need.items()}
    thrust_src = None
    if af.thrust.source == "collective":
        thrust_src = (("vehicle_thrust_setpoint", _topic(ulog, "vehicle_thrust_setpoint", ["xyz[2]"]), "xyz[2]")
                      if _topic(ulog, "vehicle_thrust_setpoint", ["xyz[2]"]) is not None else
                      ("vehicle_attitude_setpoint", _topic(ulog, "vehicle_attitude_setpoint", ["thrust_body[2]"]), "thrust_body[2]"))
    missing = [f"{name} ({need[name][1]})" for name, data in topics.items() if data is None]
    if thrust_src is not None and thrust_src[1] is None:
        missing.append("vehicle_thrust_setpoint or vehicle_attitude_setpoint (collective thrust)")
    if missing:
        raise InputError(path, "topic" + ("s " if len(missing) > 1 else " ") + ", ".join(missing), "missing from the log")
    notes = [] if complaint is None else [f"pyulog: {complaint} (the parse went on past it)"]
    hover_topic = _topic(ulog, "hover_thrust_estimate", ["hover_thrust"]) if thrust_src else None
    hover_param = ulog.initial_parameters.get("MPC_THR_HOVER")
    if thrust_src and hover_topic is None and hover_param is None:
        raise InputError(path, "topic hover_thrust_estimate", "missing, and no MPC_THR_HOVER parameter: collective "
                                                              "thrust cannot be scaled to newtons")
    if thrust_src and hover_topic is None:
        notes.append(f"hover thrust from the MPC_THR_HOVER parameter ({hover_param:.3f})")
    yaw_src = _topic(ulog, "vehicle_attitude_setpoint", ["yaw_body"])
    if yaw_src is None:
        notes.append("no vehicle_attitude_setpoint: the heading frame follows the vehicle's own yaw")

    used = [d for d in topics.values() if d is not None] + ([thrust_src[1]] if thrust_src else [])
    start = max(d["t"][0] for d in used)
    stop = min(d["t"][-1] for d in used)
    if not stop > start:
        raise InputError(path, None, "the needed topics do not overlap in time")
    att_t = topics["vehicle_attitude"]["t"]
    clock = (np.arange(start, stop, 1.0 / rate_hz) if rate_hz else att_t[(att_t >= start) & (att_t <= stop)])
    if len(clock) < 2:
        raise InputError(path, None, "fewer than two instants to resample onto")
    max_gap = af.limits.max_dt_s
    no_data = np.zeros(len(clock), dtype=bool)
    for d in used:
        no_data |= _gaps(d["t"], clock, max_gap)

    lp = topics["vehicle_local_position"]
    cols: dict[str, np.ndarray] = {"t": clock - clock[0]}
    vel = _interp(lp, ["vx", "vy", "vz"], clock)
    cols.update(vel_n=vel[:, 0], vel_e=vel[:, 1], vel_d=vel[:, 2])
    if af.observer.acceleration == "ned":
        acc = _interp(lp, ["ax", "ay", "az"], clock)
        cols.update(acc_n=acc[:, 0], acc_e=acc[:, 1], acc_d=acc[:, 2])
    if af.observer.acceleration == "specific_force":
        sf = _interp(topics["sensor_combined"], [f"accelerometer_m_s2[{i}]" for i in range(3)], clock)
        cols.update(sf_x=sf[:, 0], sf_y=sf[:, 1], sf_z=sf[:, 2])
    q = _quaternions(topics["vehicle_attitude"], clock)
    cols.update(q_w=q[:, 0], q_x=q[:, 1], q_y=q[:, 2], q_z=q[:, 3])
    if af.thrust.source == "rpm":
        rpm = _interp(topics["esc_status"], need["esc_status"][0], clock)
        for i in range(af.thrust.rotors):
            cols[f"rpm_{i + 1}"] = rpm[:, i]
    else:
        name, src, field = thrust_src
        normalized = -_hold(src, [field], clock)[:, 0]  # body z points down: upward thrust is negative
        hover = _hold(hover_topic, ["hover_thrust"], clock)[:, 0] if hover_topic else np.full(len(clock), hover_param)
        cols["thrust"] = af.mass_kg * af.gravity_mps2 * normalized / hover
        notes.append(f"collective thrust from {name}.{field}")
    if yaw_src is not None:
        cols["yaw_ref"] = _hold(yaw_src, ["yaw_body"], clock)[:, 0]
    land = _topic(ulog, "vehicle_land_detected", ["landed"])
    if land is None:
        landed = np.zeros(len(clock), dtype=bool)
        notes.append("no vehicle_land_detected: every instant is treated as airborne")
    else:
        landed = _hold(land, ["landed"], clock)[:, 0] > 0.5
        landed &= clock >= land["t"][0]
        if landed.any():
            notes.append(f"{int(landed.sum())} of {len(clock)} instants on the ground (vehicle_land_detected): status LANDED")
    # Rows the estimator must not see get NaN inputs: the step rejects them and keeps its state, so
    # the observer starts at the first airborne sample instead of at the ground's reaction force.
    for key in cols:
        if key != "t":
            cols[key] = np.where(no_data | landed, np.nan, cols[key])

    px4 = None
    for name, north, east in PX4_WIND_TOPICS:
        src = _topic(ulog, name, [north, east])
        if src is not None:
            px4 = (name, src["t"] - clock[0], np.column_stack([src[north], src[east], np.zeros(len(src["t"]))]))
            break
    if no_data.any():
        notes.append(f"{int(no_data.sum())} of {len(clock)} instants have a topic gap longer than max_dt "
                     f"({max_gap:g} s): status NO_DATA")
    return UlogFlight(FlightLog(path, cols), no_data, landed, px4, tuple(notes))


def compare_with_px4(t: np.ndarray, wind: np.ndarray, valid: np.ndarray, px4: tuple[str, np.ndarray, np.ndarray]) -> dict:
    """Mean differences between our horizontal wind and PX4's, where both exist."""
    name, tp, wp = px4
    inside = valid & (t >= tp[0]) & (t <= tp[-1])
    if not inside.any():
        return {"topic": name, "overlap_rows": 0}
    theirs = np.column_stack([np.interp(t[inside], tp, wp[:, i]) for i in range(2)])
    ours = wind[inside, :2]
    return {"topic": name, "overlap_rows": int(inside.sum()),
            "mean_vector_difference_mps": float(np.mean(np.linalg.norm(ours - theirs, axis=1))),
            "mean_speed_difference_mps": float(np.mean(np.linalg.norm(ours, axis=1) - np.linalg.norm(theirs, axis=1)))}
