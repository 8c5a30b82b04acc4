"""benchmarks/px4convert.py writes a simulated flight as a PX4 v1.14-like ULog; the ULog reader and `init`
must get the flight back (issue #36's PX4 path with a known wind, benchmarks/px4sim.py).

The flight is written here in closed form (40 s at 50 Hz): a velocity swinging in all three axes with its
derivative as the acceleration, a heading turning through 60 deg with a 5 deg roll, a thrust swinging by
5 % about the weight, and, for the rpm case, six rotors whose rpm swings. Each assertion compares what the
reader (dobwind/io/ulog.py) or init (dobwind/inspect/initframe.py) makes of the file with these closed
forms and with the rates written (Px4Rates), never with the converter's own arrays. Nothing needs
../shared/data."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks.fieldcross import TESTS, calibration_from_deg
from benchmarks.px4convert import BOOT_S, GROUND_S, HOVER_TAU_S, HOVER_VALID_S, Px4Rates, Px4Setting, convert
from benchmarks.px4sim import CALIBRATION, flight_jobs
from dobwind.inspect.initframe import build_airframe
from dobwind.io.ulog import read_ulog
from dobwind.model.airframe import load_airframe

pytest.importorskip("pyulog")

G = 9.80665
MASS = 2.6
HOVER = 0.4          # the true hover thrust: the setpoint is thrust / (m g) x this
DURATION_S, RATE_HZ = 40.0, 50.0
ROTORS, RPM_HOVER = 6, 4000.0


def _velocity(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """NED velocity and its derivative: sines of 0.3, 0.2 and 0.5 rad/s."""
    amp, w = np.array([2.0, 1.5, 0.4]), np.array([0.3, 0.2, 0.5])
    return amp * np.sin(w * t[:, None]), amp * w * np.cos(w * t[:, None])


def _yaw(t: np.ndarray) -> np.ndarray:
    return np.radians(20.0 + 60.0 * t / DURATION_S)


def _quaternion(t: np.ndarray) -> np.ndarray:
    """Body to NED (w, x, y, z): yaw then a 5 deg roll."""
    y, r = _yaw(t) / 2, math.radians(5.0) / 2
    return np.column_stack([np.cos(y) * math.cos(r), np.cos(y) * math.sin(r), np.sin(y) * math.sin(r),
                            np.sin(y) * math.cos(r)])


def _thrust(t: np.ndarray) -> np.ndarray:
    return MASS * G * (1.0 + 0.05 * np.sin(0.5 * t))


def _rpm(t: np.ndarray, i: int) -> np.ndarray:
    return RPM_HOVER + 150.0 * np.sin(0.4 * t + i)


def flight(rpm: bool = False) -> dict[str, np.ndarray]:
    """The closed-form flight (module docstring) as `dobwind simulate`'s columns."""
    t = np.round(np.arange(0.0, DURATION_S, 1.0 / RATE_HZ), 6)
    vel, acc = _velocity(t)
    q = _quaternion(t)
    n = len(t)
    cols = {"t": t, **{f"vel_{a}": vel[:, i] for i, a in enumerate("ned")},
            **{f"acc_{a}": acc[:, i] for i, a in enumerate("ned")},
            "sf_x": np.zeros(n), "sf_y": np.full(n, 0.85), "sf_z": np.full(n, -G),
            **{f"q_{c}": q[:, i] for i, c in enumerate("wxyz")}, "thrust": _thrust(t), "yaw_ref": _yaw(t),
            "wind_n": np.full(n, 3.0), "wind_e": np.zeros(n), "wind_d": np.zeros(n)}
    if rpm:
        cols.update({f"rpm_{i + 1}": _rpm(t, i) for i in range(ROTORS)})
    return cols


def _converted(folder: Path, rpm: bool):
    """The flight as a ULog, init's choices on it, and the reader's flight through init's starter."""
    log = folder / ("rpm.ulg" if rpm else "collective.ulg")
    convert(flight(rpm), Px4Setting(MASS, HOVER, rotors=ROTORS if rpm else 4, seed=7), log)
    start = folder / ("rpm.toml" if rpm else "collective.toml")
    text, choices, _ = build_airframe(str(log), MASS, str(start))
    start.write_text(text)
    return log, choices, read_ulog(str(log), load_airframe(str(start)))


@pytest.fixture(scope="module")
def collective(tmp_path_factory):
    return _converted(tmp_path_factory.mktemp("px4sim"), rpm=False)


@pytest.fixture(scope="module")
def rpm(tmp_path_factory):
    return _converted(tmp_path_factory.mktemp("px4sim_rpm"), rpm=True)


def _flight_time(read) -> np.ndarray:
    """The reader's rows on the closed form's clock: the log's clock (s since boot) starts at BOOT_S, and
    take-off comes GROUND_S later (a whole number of the flight's 50 Hz rows)."""
    return read.log.time_s + read.t0_s - BOOT_S - GROUND_S


def _air(read) -> tuple[np.ndarray, np.ndarray]:
    """Rows strictly inside the flight (a sample period clear of take-off and landing) and their times."""
    t = _flight_time(read)
    inside = (t > 0.2) & (t < DURATION_S - 0.2)
    return inside, t[inside]


def test_velocity_and_acceleration_read_back(collective):
    _, _, read = collective
    inside, t = _air(read)
    vel, acc = _velocity(t)
    got_v = read.log.stack("vel_n", "vel_e", "vel_d")[inside]
    got_a = read.log.stack("acc_n", "acc_e", "acc_d")[inside]
    # 10 Hz samples linearly interpolated: the sines' curvature over 0.11 s is below 2 mm/s
    assert np.max(np.abs(got_v - vel)) < 0.01
    assert np.max(np.abs(got_a - acc)) < 0.01


def test_attitude_and_heading_read_back(collective):
    _, _, read = collective
    inside, t = _air(read)
    q = read.log.stack("q_w", "q_x", "q_y", "q_z")[inside]
    angle = 2 * np.degrees(np.arccos(np.clip(np.abs(np.sum(q * _quaternion(t), axis=1)), 0, 1)))
    assert np.max(angle) < 0.05
    # yaw_body (the heading frame) is held between 20 Hz setpoints: at most 0.05 s of a 1.5 deg/s turn
    heading = np.degrees(np.angle(np.exp(1j * (read.log.columns["yaw_ref"][inside] - _yaw(t)))))
    assert np.all(heading <= 1e-6) and np.all(heading > -0.1)


def test_collective_thrust_is_the_flights_newtons(collective):
    """thrust = m g x setpoint / hover estimate: the hover scaling undone, with the estimate held at its
    first valid value before PX4 calls it valid (it converges from MPC_THR_HOVER 0.5)."""
    _, _, read = collective
    inside, t = _air(read)
    ratio = read.log.columns["thrust"][inside] / _thrust(t)
    # two time constants after it turns valid the estimate is within 0.1 x exp(-6) of HOVER; what is left
    # is the 50 Hz setpoint held (0.05 x 0.5 rad/s x 0.02 s)
    settled = t > HOVER_VALID_S + 2 * HOVER_TAU_S
    assert np.max(np.abs(ratio[settled] - 1)) < 0.003
    assert np.max(np.abs(ratio - 1)) < 0.01             # the first valid estimate, 0.1 x exp(-4) off
    assert any("hover_thrust_estimate valid from" in n for n in read.notes)


def test_ground_rows_are_flagged_and_the_air_has_data(collective):
    _, _, read = collective
    t = _flight_time(read)
    ground = (t < -1e-3) | (t > DURATION_S - 1.0 / RATE_HZ + 0.06)   # landing: ground_contact 0.05 s after
    air = (t > 1e-3) & (t < DURATION_S - 1.0 / RATE_HZ)
    assert read.landed[ground].all() and not read.landed[air].any()
    assert not read.no_data[air].any()       # slow topics, jitter included, never read as a gap
    assert ground.sum() > 2 * GROUND_S * 15  # both ground segments are there (20 Hz rows)


def _intervals(log: Path) -> dict[str, np.ndarray]:
    from pyulog import ULog

    return {d.name: np.diff(d.data["timestamp"]) * 1e-6 for d in ULog(str(log)).data_list if d.multi_id == 0}


def test_topics_at_the_rates_written(collective, rpm):
    r = Px4Rates()
    gaps = {**_intervals(collective[0]), "esc_status": _intervals(rpm[0])["esc_status"]}
    for name, rate in (("vehicle_local_position", r.local_position), ("vehicle_attitude", r.attitude),
                       ("vehicle_thrust_setpoint", r.thrust_setpoint), ("sensor_combined", r.sensor_combined),
                       ("hover_thrust_estimate", r.hover_estimate), ("esc_status", r.esc)):
        dt = gaps[name]
        assert abs(np.median(dt) * rate - 1) < 0.02, name
        # jittered: intervals spread within +-2 x jitter of the period, not all equal
        assert dt.min() * rate >= 1 - 2 * r.jitter - 1e-3 and dt.max() * rate <= 1 + 2 * r.jitter + 1e-3, name
        assert np.std(dt) * rate > 0.2 * r.jitter, name


def test_init_picks_collective_and_a_max_dt_the_rates_support(collective):
    log, choices, _ = collective
    lp = _intervals(log)["vehicle_local_position"]
    assert choices.thrust_source == "collective" and choices.acceleration == "ned"
    assert choices.rate_hz == Px4Rates().attitude
    # covers the slowest needed topic's longest interval, and no more than twice its period
    assert lp.max() <= choices.max_dt_s <= 2.0 / Px4Rates().local_position


def test_init_picks_rpm_from_esc_status_and_the_reader_gets_it(rpm):
    _, choices, read = rpm
    assert choices.thrust_source == "rpm" and choices.rotors == ROTORS
    inside, t = _air(read)
    # clear of the step from 0 rpm on the ground by one report interval, which interpolation spans
    clear = (t > 1.2 / Px4Rates().esc) & (t < DURATION_S - 1.2 / Px4Rates().esc)
    inside[inside] = clear
    t = t[clear]
    for i in range(ROTORS):  # 4 Hz reports interpolated: 150 rpm x 0.4^2 rad²/s² x 0.28² s² / 8 < 1 rpm
        assert np.max(np.abs(read.log.columns[f"rpm_{i + 1}"][inside] - _rpm(t, i))) < 2.0


def test_the_benchmark_flies_fieldcross_flights(tmp_path):
    """The calibration box and fieldcross's test flights with its winds and seeds (C@D + 90, seed 2, ...)."""
    jobs = flight_jobs("px4quad", 5.0, 1, tmp_path)
    d = calibration_from_deg("px4quad", 1)
    assert [j.flight.name for j in jobs] == [CALIBRATION.name] + [f.name for f in TESTS]
    assert [(j.speed_mps, j.from_deg, j.seed) for j in jobs] == [
        (5.0 * f.speed_factor, (d + f.turn_deg) % 360, 100 + f.seed_offset) for f in (CALIBRATION, *TESTS)]


SILENCE = (20.0, 0.7)   # vehicle_local_position lost for 0.7 s, 20 s after take-off


def test_a_lost_burst_of_the_local_position_is_a_gap_or_bridged(tmp_path):
    """0.7 s without vehicle_local_position (beyond its tolerance of four 10 Hz intervals): without bridging
    those rows are NO_DATA with no inputs; bridged (dobwind/io/bridge.py, as replay reads) they carry the
    velocity interpolated across the silence, within the sines' curvature over 0.8 s of the closed form."""
    log = tmp_path / "silent.ulg"
    convert(flight(), Px4Setting(MASS, HOVER, seed=7, silences=(SILENCE,)), log)
    start = tmp_path / "silent.toml"
    start.write_text(build_airframe(str(log), MASS, str(start))[0])
    af = load_airframe(str(start))
    plain, bridged = read_ulog(str(log), af), read_ulog(str(log), af, bridge_gaps=True)
    t = _flight_time(plain)
    inside = (t > SILENCE[0] + 0.15) & (t < SILENCE[0] + SILENCE[1] - 0.15)
    assert plain.no_data[inside].all() and np.isnan(plain.log.columns["vel_n"][inside]).all()
    assert not plain.no_data[(t > 1.0) & (t < SILENCE[0] - 0.5)].any()
    assert bridged.bridged is not None and bridged.bridged[inside].all()
    vel, _ = _velocity(t[inside])
    assert np.max(np.abs(bridged.log.stack("vel_n", "vel_e", "vel_d")[inside] - vel)) < 0.03
