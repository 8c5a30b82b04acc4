"""benchmarks/sitlconvert.py writes a simulated stand-in flight as an ArduCopter-4.1-like DataFlash log;
the DataFlash reader must get the flight back (issue #36's SITL cross-flight goal, benchmarks/sitlbin.py).

The flight is written here in closed form: 8 s hovering, a 2 m/s climb for 20 s (40 m: past ArduCopter's
25 m, where its density ratio first steps), hovering again; a thrust that swings by 3 %, a fixed heading
and tilt. Each assertion compares the reader's columns with these closed forms, the density ratio with
the ISA barometric law written out below, the SITL truth with the wind given. Nothing needs
../shared/data (the FMT comparison with the field log is skipped without it)."""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from benchmarks.fieldcross import TESTS, calibration_from_deg
from benchmarks.sitlbin import flight_jobs
from benchmarks.sitlconvert import GROUND_S, MESSAGES, SitlSetting, convert
from dobwind.io.dataflash import load_messages, read_dataflash
from dobwind.io.sitlwind import sitl_wind_ned
from dobwind.model.airframe import load_airframe

pytest.importorskip("pymavlink")

ROOT = Path(__file__).resolve().parents[1]
AIRFRAME = ROOT / "benchmarks" / "vehicles" / "arducopter.airframe.toml"
G = 9.80665
MASS = 3.0
SPEED, FROM_DEG = 6.0, 200.0
YAW_DEG, ROLL_DEG = 30.0, 4.0
CLIMB_START, CLIMB_END, CLIMB_MPS = 8.0, 28.0, 2.0
P0, T0_C = 94502.8, 25.53   # SitlSetting's ground, the field log's
SHARED = Path(os.environ.get("DOBWIND_SHARED_DATA", ROOT.parent / "shared" / "data"))
FIELD_LOG = SHARED / "field" / "arducopter_sitl_wind10_from180.bin"


def _quaternion(roll_deg: float, yaw_deg: float) -> np.ndarray:
    """Body to NED (w, x, y, z) of yaw then roll."""
    r, y = math.radians(roll_deg) / 2, math.radians(yaw_deg) / 2
    return np.array([math.cos(y) * math.cos(r), math.cos(y) * math.sin(r), math.sin(y) * math.sin(r),
                     math.sin(y) * math.cos(r)])


def climb_flight() -> dict[str, np.ndarray]:
    """The closed-form flight (module docstring) as `dobwind simulate`'s columns."""
    t = np.round(np.arange(0.0, 40.0, 0.1), 6)
    climbing = (t >= CLIMB_START) & (t < CLIMB_END)
    n = len(t)
    q = np.tile(_quaternion(ROLL_DEG, YAW_DEG), (n, 1))
    wind_n, wind_e = -SPEED * math.cos(math.radians(FROM_DEG)), -SPEED * math.sin(math.radians(FROM_DEG))
    return {"t": t, "vel_n": 0.5 * np.sin(0.2 * t), "vel_e": 0.3 * np.cos(0.1 * t),
            "vel_d": np.where(climbing, -CLIMB_MPS, 0.0), "sf_x": 0.1 * np.sin(0.3 * t), "sf_y": np.full(n, -0.7),
            "sf_z": np.full(n, -G), **{f"q_{c}": q[:, i] for i, c in enumerate("wxyz")},
            "thrust": MASS * G * (1.0 + 0.03 * np.sin(0.5 * t)), "yaw_ref": np.full(n, math.radians(YAW_DEG)),
            "wind_n": np.full(n, wind_n), "wind_e": np.full(n, wind_e), "wind_d": np.zeros(n)}


def isa_density_ratio(alt_m: float) -> float:
    """P / (R T) / 1.225 at alt_m above the ground (ISA lapse 6.5 K/km from the ground's P0 and T0)."""
    t0 = T0_C + 273.15
    p = P0 * (1 - 0.0065 * alt_m / t0) ** (G / (287.26 * 0.0065))
    return p / (287.26 * (t0 - 0.0065 * alt_m)) / 1.225


@pytest.fixture(scope="module")
def converted(tmp_path_factory):
    cols = climb_flight()
    path = convert(cols, SitlSetting(SPEED, FROM_DEG, mass_kg=MASS), tmp_path_factory.mktemp("sitlbin") / "climb.bin")
    af = load_airframe(str(AIRFRAME))
    return cols, path, read_dataflash(str(path), af)


def _airborne(cols, flight):
    """The reader's airborne rows and their times in the flight's own clock (cols["t"])."""
    air = ~flight.landed
    log_t = flight.log.time_s[air] + flight.t0_s
    first_air = flight.t0_s + flight.log.time_s[air][0]
    return air, log_t - first_air + cols["t"][0]


def test_the_ground_segments_are_landed_and_the_flight_airborne(converted):
    cols, _, flight = converted
    air, t = _airborne(cols, flight)
    assert flight.landed[0] and flight.landed[-1]
    assert air.sum() == pytest.approx(len(cols["t"]), abs=2)
    assert flight.landed.sum() == pytest.approx(2 * GROUND_S * 10, abs=3)


def test_velocity_and_attitude_read_back(converted):
    cols, _, flight = converted
    air, t = _airborne(cols, flight)
    for axis in ("vel_n", "vel_e", "vel_d"):
        np.testing.assert_allclose(flight.log.columns[axis][air], np.interp(t, cols["t"], cols[axis]), atol=0.02)
    q = flight.log.stack("q_w", "q_x", "q_y", "q_z")[air]
    dots = np.abs(q @ _quaternion(ROLL_DEG, YAW_DEG))
    assert dots.min() > math.cos(math.radians(0.05) / 2)  # within 0.05 deg of the written attitude


def test_the_density_step_is_in_the_log_where_the_barometer_reaches_25_m(converted):
    """ThO in the log steps by ArduCopter's ratio at 25 m (the thrust itself is smooth there)."""
    _, path, _ = converted
    msgs = load_messages(str(path), ("CTUN", "BARO"))
    alt = np.array([r["Alt"] for r in msgs["BARO"]])
    tho = np.array([r["ThO"] for r in msgs["CTUN"]])
    k = int(np.flatnonzero(alt >= 25.0)[0])
    assert alt[k - 1] < 25.0
    ratio = isa_density_ratio(alt[k])
    assert 0.85 < ratio < 0.95   # a 584 m field on a warm day: the step is ~10 %, far above the noise
    assert tho[k] / tho[k - 1] == pytest.approx(ratio, rel=0.01)  # 0.1 s of a 3 % swing at 0.5 rad/s: < 0.2 %


def test_the_reader_finds_the_step_and_the_thrust_comes_back(converted):
    cols, _, flight = converted
    air, t = _airborne(cols, flight)
    assert any("air-density compensation" in note for note in flight.notes), flight.notes
    # thrust = ThO / ThH x m g, the step undone: the simulator's thrust within 0.3 %
    np.testing.assert_allclose(flight.log.columns["thrust"][air], np.interp(t, cols["t"], cols["thrust"]), rtol=3e-3)


def test_the_sitl_truth_is_the_wind_given(converted):
    _, _, flight = converted
    assert flight.sitl is not None
    clock = flight.log.time_s + flight.t0_s
    truth = sitl_wind_ned(flight.sitl, clock)
    north, east = -SPEED * math.cos(math.radians(FROM_DEG)), -SPEED * math.sin(math.radians(FROM_DEG))
    np.testing.assert_allclose(truth, np.tile([north, east, 0.0], (len(clock), 1)), atol=1e-5)
    assert not flight.sitl.turbulent()


def test_turbulence_is_written_and_makes_the_truth_approximate(tmp_path):
    path = convert(climb_flight(), SitlSetting(SPEED, FROM_DEG, turbulence=0.9), tmp_path / "turb.bin")
    flight = read_dataflash(str(path), load_airframe(str(AIRFRAME)))
    assert flight.sitl.turbulent()
    assert flight.sitl.final_parameters()["SIM_WIND_TURB"] == pytest.approx(0.9, rel=1e-6)


def test_without_the_density_factor_there_is_no_step(tmp_path):
    """The contrast the benchmark replays: the same flight, ThO as if never compensated."""
    path = convert(climb_flight(), SitlSetting(SPEED, FROM_DEG, density_step=False), tmp_path / "flat.bin")
    flight = read_dataflash(str(path), load_airframe(str(AIRFRAME)))
    assert not any("air-density compensation" in note for note in flight.notes)


def test_the_benchmark_flies_fieldcross_flights():
    """Same calibration wind, winds and seeds as benchmarks/fieldcross.py (its table: C@D+90 seed 2, ...)."""
    jobs = flight_jobs(5.0, 1, Path("unused"))
    from_deg = calibration_from_deg("arducopter", 1)
    assert (jobs[0].flight.scenario, jobs[0].speed_mps, jobs[0].from_deg, jobs[0].seed) == ("box", 5.0, from_deg, 101)
    for job, flight in zip(jobs[1:], TESTS):
        assert job.flight == flight and job.seed == 100 + flight.seed_offset
        assert job.speed_mps == 5.0 * flight.speed_factor and job.from_deg == (from_deg + flight.turn_deg) % 360
        assert (job.turbulence() > 0) == (flight.scenario == "outdoor")


@pytest.mark.skipif(not FIELD_LOG.is_file(), reason="../shared/data absent")
def test_the_messages_are_the_field_logs():
    """Every message written has the field SITL log's format characters and columns."""
    from pymavlink import DFReader

    reader = DFReader.DFReader_binary(str(FIELD_LOG), zero_time_base=False)
    try:
        for name, (fmt, cols) in MESSAGES.items():
            field = reader.formats[reader.name_to_id[name]]
            assert (field.format, list(field.columns)) == (fmt, cols), name
    finally:
        reader.close()
