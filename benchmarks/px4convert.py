"""A simulated flight (a `dobwind simulate` CSV) written as a PX4 v1.14-like ULog file (issue #36).

The PX4 field logs carry no known wind, and benchmarks/fieldcross.py replays the simulated family from
CSV logs, which skips the ULog reader (dobwind/io/ulog.py) and what a PX4 log does to the estimator: slow
topics at their own rates with the logger's timing jitter, a normalised thrust setpoint scaled by a hover
thrust estimate that converges in flight, ground segments from the land detector. This writes the flight
as PX4's logger would have, so that the whole user path (inspect, init, fit, replay) runs on it with the
scenario's wind as the truth (benchmarks/px4sim.py).

Topics, field lists and rates are those of the PX4 v1.14.0 field log (../shared/data/field/
px4_octo_x8_manual.ulg, read with pyulog; esc_status's from ../shared/data/px4-ulog/sample_px4_events.ulg)
and of PX4's default logger profile:

| topic | rate | from the CSV |
|---|---|---|
| vehicle_local_position | 10 Hz | vx vy vz, ax ay az, x y z (the velocity integrated), heading; valid flags set |
| vehicle_attitude | 20 Hz | q (slerp between the CSV's rows) |
| vehicle_attitude_setpoint | 20 Hz | yaw_body (yaw_ref), q_d, thrust_body[2] |
| vehicle_thrust_setpoint | 50 Hz | xyz[2] = -thrust / (m g) x the true hover thrust (negative up) |
| hover_thrust_estimate | 10 Hz, airborne | converges from MPC_THR_HOVER to the true hover thrust; `valid` after HOVER_VALID_S |
| sensor_combined | 200 Hz | accelerometer_m_s2 from sf_* |
| esc_status | 4 Hz | esc[i].esc_rpm from rpm_i (an rpm airframe's flight; --no-esc leaves it out) |
| vehicle_land_detected | 1 Hz and on change | ground before and after the flight (added here) |
| estimator_states | 1 Hz, instances 0 and 1 | all zero: EKF2 without drag fusion estimates no wind |

Every topic's timestamps (microseconds since boot) sit within +-JITTER of their period around the
nominal grid, drawn for each topic (the octo's 10 Hz intervals run 0.09-0.11 s). What the conversion adds:
GROUND_S of ground before and after (still, level, thrust and rpm 0), the land detector's sequence around
take-off and landing as the octo logs it (ground_contact, then maybe_landed, then landed), parameters
MPC_THR_HOVER (PX4's default 0.5, not the true hover thrust), MAV_TYPE, CA_ROTOR_COUNT, SYS_AUTOSTART and
EKF2 drag fusion off. No wind: a PX4 log carries no truth. Nothing here is a PX4 SITL run. On request
(``Px4Setting.silences``, ``--silence``) vehicle_local_position goes unlogged for given spans, as when the
logger drops a burst: the reader's gaps and replay's bridging (dobwind/io/bridge.py) on a known flight.

The simulated flight starts and ends in the air, moving: the ground meets it without a take-off or landing
manoeuvre (a step in thrust and velocity), so the one or two rows at the landing instant, where the reader
interpolates across that step, read as IMPLAUSIBLE (an acceleration no vehicle makes).

    .venv/bin/python -m benchmarks.px4convert FLIGHT.csv --mass 2.6 [--hover 0.42] [--no-esc]
        [--silence START,LENGTH ...] -o FLIGHT.ulg
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmarks.sitlconvert import GRAVITY, ROOT, euler_deg, read_flight_csv
from dobwind.io.atomic import write_file_atomically

GROUND_S = 8.0            # on the ground before take-off and after landing
BOOT_S = 30.0             # the log's first instant, seconds since boot (PX4's timestamps count from boot)
HOVER_TAU_S = 2.5         # hover_thrust_estimate's convergence from MPC_THR_HOVER after take-off
HOVER_VALID_S = 10.0      # ... and when PX4 calls it valid (the octo's took about 20 s)
CONTACT_BEFORE_S = 1.8    # land detector at take-off: landed and maybe_landed clear this long before (the octo's)
LANDING_S = (0.05, 0.65, 1.0)   # after the last airborne row: ground_contact, maybe_landed, landed set
VER_SW_RELEASE = 0x010E00FF     # v1.14.0, release (the octo log's ver_sw_release)
REQUIRED = ("t", "vel_n", "vel_e", "vel_d", "acc_n", "acc_e", "acc_d", "sf_x", "sf_y", "sf_z", "q_w", "q_x", "q_y",
            "q_z", "thrust", "yaw_ref")
MAV_TYPE = {3: 15, 4: 2, 6: 13, 8: 14}   # MAVLink: tricopter, quadrotor, hexarotor, octorotor

_T = [("uint64_t", "timestamp")]
_TS = _T + [("uint64_t", "timestamp_sample")]
LOCAL_POSITION = _TS + [("uint64_t", "ref_timestamp"), ("double", "ref_lat"), ("double", "ref_lon")] + [
    ("float", f) for f in ("x", "y", "z", "delta_xy[0]", "delta_xy[1]", "delta_z", "vx", "vy", "vz", "z_deriv",
                           "delta_vxy[0]", "delta_vxy[1]", "delta_vz", "ax", "ay", "az", "heading", "delta_heading",
                           "ref_alt", "dist_bottom", "eph", "epv", "evh", "evv", "vxy_max", "vz_max", "hagl_min",
                           "hagl_max")] + [
    ("bool", f) for f in ("xy_valid", "z_valid", "v_xy_valid", "v_z_valid")] + [
    ("uint8_t", f) for f in ("xy_reset_counter", "z_reset_counter", "vxy_reset_counter", "vz_reset_counter",
                             "heading_reset_counter")] + [
    ("bool", f) for f in ("heading_good_for_control", "xy_global", "z_global", "dist_bottom_valid")] + [
    ("uint8_t", "dist_bottom_sensor_bitfield"), ("bool", "dead_reckoning")]
ATTITUDE = _TS + [("float[4]", "q"), ("float[4]", "delta_q_reset"), ("uint8_t", "quat_reset_counter")]
ATTITUDE_SETPOINT = _T + [("float", f) for f in ("roll_body", "pitch_body", "yaw_body", "yaw_sp_move_rate")] + [
    ("float[4]", "q_d"), ("float[3]", "thrust_body"), ("bool", "reset_integral"), ("bool", "fw_control_yaw_wheel")]
THRUST_SETPOINT = _TS + [("float[3]", "xyz")]
HOVER_ESTIMATE = _TS + [("float", f) for f in ("hover_thrust", "hover_thrust_var", "accel_innov", "accel_innov_var",
                                               "accel_innov_test_ratio", "accel_noise_var")] + [("bool", "valid")]
SENSOR_COMBINED = _T + [("float[3]", "gyro_rad"), ("uint32_t", "gyro_integral_dt"),
                        ("int32_t", "accelerometer_timestamp_relative"), ("float[3]", "accelerometer_m_s2"),
                        ("uint32_t", "accelerometer_integral_dt"), ("uint8_t", "accelerometer_clipping"),
                        ("uint8_t", "gyro_clipping"), ("uint8_t", "accel_calibration_count"),
                        ("uint8_t", "gyro_calibration_count")]
LAND_FLAGS = ("freefall", "ground_contact", "maybe_landed", "landed", "in_ground_effect", "in_descend",
              "has_low_throttle", "vertical_movement", "horizontal_movement", "rotational_movement",
              "close_to_ground_or_skipped_check", "at_rest")
LAND_DETECTED = _T + [("bool", f) for f in LAND_FLAGS]
ESC_REPORT = {"esc_report": _T + [("uint32_t", "esc_errorcount"), ("int32_t", "esc_rpm"), ("float", "esc_voltage"),
                                  ("float", "esc_current"), ("float", "esc_temperature"), ("uint16_t", "failures"),
                                  ("uint8_t", "esc_address"), ("uint8_t", "esc_cmdcount"), ("uint8_t", "esc_state"),
                                  ("uint8_t", "actuator_function"), ("int8_t", "esc_power")]}
ESC_STATUS = _T + [("uint16_t", "counter"), ("uint8_t", "esc_count"), ("uint8_t", "esc_connectiontype"),
                   ("uint8_t", "esc_online_flags"), ("uint8_t", "esc_armed_flags"), ("esc_report[8]", "esc")]
ESTIMATOR_STATES = _TS + [("float[24]", "states"), ("uint8_t", "n_states"), ("float[23]", "covariances")]


@dataclass(frozen=True)
class Px4Rates:
    """Each topic's logging rate, Hz (PX4's default logger profile, as the field logs show it)."""
    local_position: float = 10.0
    attitude: float = 20.0
    attitude_setpoint: float = 20.0
    thrust_setpoint: float = 50.0
    hover_estimate: float = 10.0
    sensor_combined: float = 200.0
    esc: float = 4.0
    land_heartbeat: float = 1.0
    estimator_states: float = 1.0
    jitter: float = 0.05    # each stamp within +-5 % of its period of the nominal grid


@dataclass(frozen=True)
class Px4Setting:
    """What the converted log says of the vehicle."""
    mass_kg: float
    hover_thrust: float = 0.42      # the true hover throttle: the setpoint's scale and the estimate's limit
    mpc_thr_hover: float = 0.5      # PX4's default parameter, where hover_thrust_estimate starts
    rotors: int = 4                 # CA_ROTOR_COUNT (an rpm flight: its rpm columns' count)
    esc: bool = True                # esc_status when the flight has rpm columns
    seed: int = 0                   # the stamps' jitter
    rates: Px4Rates = field(default_factory=Px4Rates)
    # (start after take-off, length), s: vehicle_local_position not logged there (a lost burst of the logger,
    # for the reader's gap handling and bridging); none by default
    silences: tuple[tuple[float, float], ...] = ()

    def parameters(self) -> tuple[dict[str, float], dict[str, int]]:
        """(float, int32) parameters, as PX4 types them."""
        floats = {"MPC_THR_HOVER": self.mpc_thr_hover, "EKF2_BCOEF_X": 100.0, "EKF2_BCOEF_Y": 100.0, "EKF2_MCOEF": 0.15}
        ints = {"MAV_TYPE": MAV_TYPE.get(self.rotors, 2), "CA_ROTOR_COUNT": self.rotors, "SYS_AUTOSTART": 4001,
                "EKF2_DRAG_CTRL": 0}
        return floats, ints


@dataclass(frozen=True)
class Timeline:
    """The flight with ground either side, on the log's clock (s since boot), row by row."""
    clock: np.ndarray
    airborne: np.ndarray
    cols: dict[str, np.ndarray]

    @property
    def takeoff_s(self) -> float:
        return float(self.clock[np.flatnonzero(self.airborne)[0]])

    @property
    def landing_s(self) -> float:
        return float(self.clock[np.flatnonzero(self.airborne)[-1]])


def timeline(cols: dict[str, np.ndarray]) -> Timeline:
    """GROUND_S of ground at the CSV's own period before and after the flight: still, level at the first
    and last heading, thrust and rpm 0 (motors off), 1 g on the accelerometer; positions integrated."""
    t = np.asarray(cols["t"], float)
    period = float(np.median(np.diff(t)))
    n = int(round(GROUND_S / period))
    start = BOOT_S + n * period
    clock = np.concatenate([BOOT_S + period * np.arange(n), start + t - t[0], start + t[-1] - t[0] + period * np.arange(1, n + 1)])
    air = np.concatenate([np.zeros(n, bool), np.ones(len(t), bool), np.zeros(n, bool)])
    out: dict[str, np.ndarray] = {}
    still = [c for c in cols if c.startswith(("vel_", "acc_", "rpm_")) or c in ("sf_x", "sf_y", "thrust")]
    for name in still:
        out[name] = np.concatenate([np.zeros(n), np.asarray(cols[name], float), np.zeros(n)])
    out["sf_z"] = np.concatenate([np.full(n, -GRAVITY), np.asarray(cols["sf_z"], float), np.full(n, -GRAVITY)])
    yaw = np.unwrap(np.asarray(cols["yaw_ref"], float))
    out["yaw_ref"] = np.concatenate([np.full(n, yaw[0]), yaw, np.full(n, yaw[-1])])
    q = np.column_stack([cols[f"q_{c}"] for c in "wxyz"]).astype(float)
    heading = np.radians(euler_deg(q[[0, -1]])[:, 2])
    level = [np.tile([np.cos(h / 2), 0.0, 0.0, np.sin(h / 2)], (n, 1)) for h in heading]
    out["q"] = np.vstack([level[0], q, level[1]])
    for axis in "ned":  # trapezoidal: the position the EKF would report, from the ground's origin
        v = out[f"vel_{axis}"]
        out[f"pos_{axis}"] = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(clock))])
    return Timeline(clock, air, out)


def stamps(rate_hz: float, start: float, end: float, jitter: float, rng: np.random.Generator) -> np.ndarray:
    """A topic's timestamps, whole microseconds in [start, end]: the nominal grid, each stamp moved by up
    to +-jitter of the period (uniformly), in order and distinct."""
    grid = start + np.arange(0.0, end - start, 1.0 / rate_hz)
    moved = grid + rng.uniform(-jitter, jitter, len(grid)) / rate_hz
    us = np.round(np.clip(moved, start, end) * 1e6).astype(np.int64)
    return np.unique(us)


def _at(tl: Timeline, name: str, us: np.ndarray) -> np.ndarray:
    return np.interp(us * 1e-6, tl.clock, tl.cols[name])


def _quaternions(tl: Timeline, us: np.ndarray) -> np.ndarray:
    """(w, x, y, z) at the stamps by spherical interpolation between rows (scipy's Slerp, not dobwind's
    resampler: the reader's quaternion interpolation is checked against an independent one)."""
    from scipy.spatial.transform import Rotation, Slerp

    q = tl.cols["q"]
    rot = Rotation.from_quat(np.column_stack([q[:, 1], q[:, 2], q[:, 3], q[:, 0]]))
    xyzw = Slerp(tl.clock, rot)(np.clip(us * 1e-6, tl.clock[0], tl.clock[-1])).as_quat()
    xyzw *= np.where(xyzw[:, 3:4] < 0, -1.0, 1.0)  # scalar part non-negative, as the CSV writes it
    return np.column_stack([xyzw[:, 3], xyzw[:, 0], xyzw[:, 1], xyzw[:, 2]])


def _grid(tl: Timeline, rate: float, setting: Px4Setting, rng: np.random.Generator,
          span: tuple[float, float] | None = None) -> np.ndarray:
    start, end = span or (tl.clock[0], tl.clock[-1])
    return stamps(rate, start, end, setting.rates.jitter, rng)


def local_position_rows(tl: Timeline, us: np.ndarray) -> list[dict]:
    v = {a: _at(tl, f"vel_{a}", us) for a in "ned"}
    acc = {a: _at(tl, f"acc_{a}", us) for a in "ned"}
    pos = {a: _at(tl, f"pos_{a}", us) for a in "ned"}
    yaw = np.interp(us * 1e-6, tl.clock, np.radians(np.unwrap(euler_deg(tl.cols["q"])[:, 2], period=360.0)))
    valid = {f: 1 for f in ("xy_valid", "z_valid", "v_xy_valid", "v_z_valid", "heading_good_for_control",
                            "xy_global", "z_global")}
    return [{"timestamp": u, "timestamp_sample": u, "ref_timestamp": us[0], "ref_lat": 47.397742, "ref_lon": 8.545594,
             "x": pos["n"][k], "y": pos["e"][k], "z": pos["d"][k], "vx": v["n"][k], "vy": v["e"][k], "vz": v["d"][k],
             "z_deriv": v["d"][k], "ax": acc["n"][k], "ay": acc["e"][k], "az": acc["d"][k],
             "heading": float(np.angle(np.exp(1j * yaw[k]))), "ref_alt": 488.0, "dist_bottom": -pos["d"][k],
             "eph": 0.4, "epv": 0.6, "evh": 0.08, "evv": 0.1, "vxy_max": 12.0, "vz_max": 3.0, "hagl_max": 1e4, **valid}
            for k, u in enumerate(us)]


def attitude_rows(tl: Timeline, us: np.ndarray) -> list[dict]:
    q = _quaternions(tl, us)
    return [{"timestamp": u, "timestamp_sample": u, **{f"q[{i}]": q[k, i] for i in range(4)}}
            for k, u in enumerate(us)]


def normalised_thrust(tl: Timeline, us: np.ndarray, setting: Px4Setting) -> np.ndarray:
    """The collective setpoint PX4 would log, as a positive share: thrust / (m g) x the true hover thrust."""
    return _at(tl, "thrust", us) / (setting.mass_kg * GRAVITY) * setting.hover_thrust


def attitude_setpoint_rows(tl: Timeline, us: np.ndarray, setting: Px4Setting) -> list[dict]:
    q = _quaternions(tl, us)
    euler = np.radians(euler_deg(q))
    yaw = np.angle(np.exp(1j * _at(tl, "yaw_ref", us)))   # unwrapped in the timeline, wrapped as PX4 logs it
    thrust = normalised_thrust(tl, us, setting)
    return [{"timestamp": u, "roll_body": euler[k, 0], "pitch_body": euler[k, 1], "yaw_body": yaw[k],
             **{f"q_d[{i}]": q[k, i] for i in range(4)}, "thrust_body[2]": -thrust[k]} for k, u in enumerate(us)]


def thrust_setpoint_rows(tl: Timeline, us: np.ndarray, setting: Px4Setting) -> list[dict]:
    thrust = normalised_thrust(tl, us, setting)
    return [{"timestamp": u, "timestamp_sample": u, "xyz[2]": -thrust[k]} for k, u in enumerate(us)]


def hover_estimate_rows(tl: Timeline, us: np.ndarray, setting: Px4Setting) -> list[dict]:
    """From take-off: MPC_THR_HOVER converging to the true hover thrust, `valid` once HOVER_VALID_S in."""
    since = us * 1e-6 - tl.takeoff_s
    hover = setting.hover_thrust + (setting.mpc_thr_hover - setting.hover_thrust) * np.exp(-since / HOVER_TAU_S)
    return [{"timestamp": u, "timestamp_sample": u, "hover_thrust": hover[k], "hover_thrust_var": 1e-5,
             "accel_noise_var": 0.5, "valid": int(since[k] >= HOVER_VALID_S)} for k, u in enumerate(us)]


def sensor_combined_rows(tl: Timeline, us: np.ndarray, setting: Px4Setting) -> list[dict]:
    sf = [_at(tl, f"sf_{a}", us) for a in "xyz"]
    dt_us = int(round(1e6 / setting.rates.sensor_combined))
    return [{"timestamp": u, "gyro_integral_dt": dt_us, "accelerometer_integral_dt": dt_us,
             **{f"accelerometer_m_s2[{i}]": sf[i][k] for i in range(3)}} for k, u in enumerate(us)]


def esc_rows(tl: Timeline, us: np.ndarray, rotors: int) -> list[dict]:
    rpm = [_at(tl, f"rpm_{i + 1}", us) for i in range(rotors)]
    flags = (1 << rotors) - 1
    return [{"timestamp": u, "counter": k % 65536, "esc_count": rotors, "esc_connectiontype": 1, "esc_online_flags": flags,
             "esc_armed_flags": flags, **{f"esc[{i}].esc_rpm": rpm[i][k] for i in range(rotors)},
             **{f"esc[{i}].timestamp": u for i in range(rotors)}} for k, u in enumerate(us)]


def land_rows(tl: Timeline, setting: Px4Setting, rng: np.random.Generator) -> list[dict]:
    """vehicle_land_detected as PX4 publishes it: on every change and at least once a second. Landed,
    maybe_landed and ground_contact all set on the ground; at take-off landed and maybe_landed clear
    CONTACT_BEFORE_S ahead and ground_contact with the first airborne row; at landing ground_contact,
    maybe_landed and landed set in turn after the last airborne row."""
    up, down = tl.takeoff_s, tl.landing_s
    changes = [(up - CONTACT_BEFORE_S, (0, 0, 1)), (up - 1e-6, (0, 0, 0))]
    changes += [(down + d, flags) for d, flags in zip(LANDING_S, ((0, 0, 1), (0, 1, 1), (1, 1, 1)))]
    beats = _grid(tl, setting.rates.land_heartbeat, setting, rng) * 1e-6
    # the first message at the log's first instant: PX4 publishes the detector's state at start-up
    times = np.unique(np.concatenate([[tl.clock[0]], beats, [c[0] for c in changes]]))
    when = np.array([c[0] for c in changes])
    rows = []
    for s in times:
        k = int(np.searchsorted(when, s, side="right")) - 1
        landed, maybe, contact = (1, 1, 1) if k < 0 else changes[k][1]
        rows.append({"timestamp": int(round(s * 1e6)), "landed": landed, "maybe_landed": maybe,
                     "ground_contact": contact, "has_low_throttle": landed, "at_rest": landed,
                     "close_to_ground_or_skipped_check": contact})
    return rows


def silenced(us: np.ndarray, tl: Timeline, setting: Px4Setting) -> np.ndarray:
    """The stamps outside ``setting.silences`` (measured from take-off)."""
    since = us * 1e-6 - tl.takeoff_s
    quiet = np.zeros(len(us), dtype=bool)
    for start, length in setting.silences:
        quiet |= (since > start) & (since < start + length)
    return us[~quiet]


def topics(tl: Timeline, setting: Px4Setting) -> list:
    """Every topic of the converted log, its stamps drawn from ``setting.seed``."""
    sys.path.insert(0, str(ROOT))  # tests/ is not installed (as tools/bench_slow_ulog.py imports it)
    from tests.ulog_writer import Topic

    rng = np.random.default_rng(setting.seed)
    r = setting.rates
    air = (tl.takeoff_s, tl.landing_s)
    out = [Topic("vehicle_local_position", LOCAL_POSITION,
                 local_position_rows(tl, silenced(_grid(tl, r.local_position, setting, rng), tl, setting))),
           Topic("vehicle_attitude", ATTITUDE, attitude_rows(tl, _grid(tl, r.attitude, setting, rng))),
           Topic("vehicle_attitude_setpoint", ATTITUDE_SETPOINT,
                 attitude_setpoint_rows(tl, _grid(tl, r.attitude_setpoint, setting, rng), setting)),
           Topic("vehicle_thrust_setpoint", THRUST_SETPOINT,
                 thrust_setpoint_rows(tl, _grid(tl, r.thrust_setpoint, setting, rng), setting)),
           Topic("hover_thrust_estimate", HOVER_ESTIMATE,
                 hover_estimate_rows(tl, _grid(tl, r.hover_estimate, setting, rng, air), setting)),
           Topic("sensor_combined", SENSOR_COMBINED,
                 sensor_combined_rows(tl, _grid(tl, r.sensor_combined, setting, rng), setting)),
           Topic("vehicle_land_detected", LAND_DETECTED, land_rows(tl, setting, rng))]
    if setting.esc and any(c.startswith("rpm_") for c in tl.cols):
        out.append(Topic("esc_status", ESC_STATUS, esc_rows(tl, _grid(tl, r.esc, setting, rng), setting.rotors)))
    states = _grid(tl, r.estimator_states, setting, rng)
    out += [Topic("estimator_states", ESTIMATOR_STATES, [{"timestamp": u, "timestamp_sample": u, "n_states": 24}
                                                         for u in states], multi_id=i) for i in (0, 1)]
    return out


def convert(cols: dict[str, np.ndarray], setting: Px4Setting, out: Path) -> Timeline:
    """Write the flight ``cols`` (a `dobwind simulate` CSV's columns) as a ULog at ``out``; its timeline."""
    sys.path.insert(0, str(ROOT))
    from tests.ulog_writer import write_ulog

    tl = timeline(cols)
    floats, ints = setting.parameters()
    info = {"sys_name": "PX4", "ver_hw": "DOBWIND_PX4CONVERT", "ver_sw_release": VER_SW_RELEASE}
    # Atomically: an interrupted conversion leaves no half log under the final name, nor a temporary.
    write_file_atomically(out, lambda tmp: write_ulog(tmp, topics(tl, setting), floats, ESC_REPORT, info=info,
                                                      int_parameters=ints))
    return tl


def rotor_count(cols: dict[str, np.ndarray], default: int = 4) -> int:
    """The flight's rpm columns' count, else ``default`` (a collective flight does not say)."""
    return sum(1 for c in cols if c.startswith("rpm_")) or default


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("flight", help="a `dobwind simulate` CSV")
    p.add_argument("--mass", type=float, required=True, help="the vehicle's mass, kg (the thrust setpoint's m g)")
    p.add_argument("--hover", type=float, default=0.42, help="the true hover thrust, 0..1 (default 0.42)")
    p.add_argument("--no-esc", action="store_true", help="no esc_status, even for a flight with rpm columns")
    p.add_argument("--seed", type=int, default=0, help="the timestamps' jitter (default 0)")
    p.add_argument("--silence", action="append", default=[], metavar="START,LENGTH",
                   help="no vehicle_local_position from START s after take-off for LENGTH s (repeatable)")
    p.add_argument("-o", "--output", required=True)
    args = p.parse_args(argv)
    if not (args.mass > 0 and 0 < args.hover < 1):
        print(f"px4convert: --mass {args.mass:g} / --hover {args.hover:g}: need a mass > 0 and a hover thrust in (0, 1)",
              file=sys.stderr)
        return 2
    try:
        cols = read_flight_csv(args.flight)
    except (OSError, ValueError, IndexError) as exc:
        print(f"px4convert: {args.flight}: not a readable `dobwind simulate` CSV ({exc})", file=sys.stderr)
        return 2
    missing = [c for c in REQUIRED if c not in cols]
    if missing:
        print(f"px4convert: {args.flight}: column(s) {', '.join(missing)} missing (a `dobwind simulate` CSV has them)",
              file=sys.stderr)
        return 2
    try:
        silences = tuple((float(a), float(b)) for a, b in (text.split(",") for text in args.silence))
    except ValueError:
        print(f"px4convert: --silence: {args.silence!r}: each is START,LENGTH in seconds (e.g. 20,0.7)", file=sys.stderr)
        return 2
    setting = Px4Setting(args.mass, args.hover, rotors=rotor_count(cols), esc=not args.no_esc, seed=args.seed,
                         silences=silences)
    convert(cols, setting, Path(args.output))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
