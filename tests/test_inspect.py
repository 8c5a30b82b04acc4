"""`dobwind inspect` and `dobwind init` (issue #36) on logs written here: every rate, airborne span and
choice below is set by construction, so the expected values are closed forms of the test's own
schedule. The real field logs are checked at the end and skipped without them."""
from __future__ import annotations

import json
import math
import struct
from pathlib import Path

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.core.errors import InputError
from dobwind.inspect.initframe import REFERENCE_MASS_KG, build_airframe, common_rate
from dobwind.inspect.anylog import inspect_log
from dobwind.model.airframe import PRIOR, load_airframe
from tests.dataflash_writer import write_dataflash
from tests.helpers import ROOT
from tests.ulog_writer import Topic, write_ulog

pytest.importorskip("pyulog")

FIELD = ROOT.parent / "shared" / "data" / "field"
REAL_LOGS = sorted(FIELD.glob("*.ulg")) + sorted(FIELD.glob("*.bin")) + \
    [ROOT.parent / "shared" / "data" / "px4-ulog" / "sample_px4_events.ulg"]
ESC_REPORT = {"esc_report": [("int32_t", "esc_rpm")]}
T0_US = 1_000_000
LOG_S = 30.0
TAKEOFF_S, LANDING_S = 5.0, 25.0   # vehicle_land_detected at 1 Hz: airborne from 5 s to 25 s
HOVER_RPM = 4000.0


def _stamps(rate_hz: float, gap: tuple[float, float] | None = None) -> np.ndarray:
    t = np.arange(0.0, LOG_S, 1.0 / rate_hz)
    return t if gap is None else t[(t <= gap[0]) | (t >= gap[1])]


def _topic(name: str, fields: list[tuple[str, str]], t: np.ndarray, values) -> Topic:
    return Topic(name, [("uint64_t", "timestamp")] + fields,
                 [{"timestamp": int(round(T0_US + s * 1e6)), **values(s)} for s in t])


def _airborne(s: float) -> bool:
    return TAKEOFF_S <= s < LANDING_S


def _px4_log(path: Path, *, attitude_hz=50.0, thrust_hz=50.0, position_gap=(12.0, 12.5), esc=True, dead_motor=False,
             wind_active=False, land=True, rotor_param=4, extra_params: dict[str, float] | None = None,
             drop: tuple[str, ...] = (), wobble_mps2: float = 0.0) -> Path:
    """A PX4 log: position 10 Hz (with one gap), attitude and thrust setpoint at the given rates, ESC at
    4 Hz (0 rpm on the ground; with dead_motor, motor 2 reads 0 rpm throughout), wind zero or not.
    ``wobble_mps2``: the logged ax and ay carry a 0.2 Hz sinusoid of this amplitude that the velocity
    (constant) does not (what aliased vibration looks like in the observer's band)."""
    def rpm(s: float) -> dict:
        return {f"esc[{i}].esc_rpm": 0.0 if not _airborne(s) or (dead_motor and i == 1) else HOVER_RPM + 100 * i
                for i in range(4)} | {"esc_count": 4}

    topics = [
        _topic("vehicle_local_position", [("float", f) for f in ("vx", "vy", "vz", "ax", "ay", "az")],
               _stamps(10.0, position_gap), lambda s: {"vx": 1.0, "ax": wobble_mps2 * math.sin(0.4 * math.pi * s),
                                                       "ay": wobble_mps2 * math.cos(0.4 * math.pi * s)}),
        _topic("vehicle_attitude", [("float[4]", "q")], _stamps(attitude_hz), lambda s: {"q[0]": 1.0}),
        _topic("vehicle_thrust_setpoint", [("float[3]", "xyz")], _stamps(thrust_hz), lambda s: {"xyz[2]": -0.5}),
        _topic("hover_thrust_estimate", [("float", "hover_thrust")], _stamps(10.0), lambda s: {"hover_thrust": 0.45}),
        _topic("wind", [("float", "windspeed_north"), ("float", "windspeed_east")], _stamps(5.0),
               lambda s: {"windspeed_north": 3.0 if wind_active else 0.0, "windspeed_east": 4.0 if wind_active else 0.0}),
    ]
    if land:
        topics.append(_topic("vehicle_land_detected", [("bool", "landed")], _stamps(1.0),
                             lambda s: {"landed": not _airborne(s)}))
    if esc:
        topics.append(_topic("esc_status", [("uint8_t", "esc_count"), ("esc_report[4]", "esc")], _stamps(4.0), rpm))
    params = {"MPC_THR_HOVER": 0.5, "EKF2_DRAG_CTRL": 1.0 if wind_active else 0.0, "SYS_AUTOSTART": 4001.0}
    if rotor_param:
        params["CA_ROTOR_COUNT"] = float(rotor_param)
    return write_ulog(path, [t for t in topics if t.name not in drop], params | (extra_params or {}), ESC_REPORT)


@pytest.fixture(scope="module")
def px4(tmp_path_factory) -> tuple[Path, str]:
    """The default PX4 log and the starter airframe init builds from it for 2 kg (built once: the gain
    design takes a second or two)."""
    folder = tmp_path_factory.mktemp("px4")
    log = _px4_log(folder / "a.ulg")
    text, _, _ = build_airframe(str(log), REFERENCE_MASS_KG, str(folder / "v.toml"))
    return log, str(_write(folder / "v.toml", text))


def test_ulog_rates_gaps_airborne_and_roles(tmp_path):
    s = inspect_log(str(_px4_log(tmp_path / "a.ulg")))
    lp = s.stream("vehicle_local_position")
    assert lp.rate_hz == pytest.approx(10.0, rel=1e-6) and lp.worst_gap_s == pytest.approx(0.5, abs=1e-6)  # 12.0 s, then 12.5 s
    assert s.stream("esc_status").rate_hz == pytest.approx(4.0, rel=1e-6)
    assert s.stream("vehicle_attitude").count == 1500
    assert s.airborne_s == pytest.approx(LANDING_S - TAKEOFF_S) and s.airborne_source == "vehicle_land_detected"
    assert s.airborne_intervals == ((TAKEOFF_S + 1.0, LANDING_S + 1.0),)  # the log's clock starts at 1 s
    assert s.role("velocity").source == "vehicle_local_position.vx..vz"
    assert s.role("thrust").source == "vehicle_thrust_setpoint.xyz[2]"
    assert s.role("hover_thrust").stream == "hover_thrust_estimate"
    # No vehicle_attitude_setpoint: the heading frame follows the vehicle's yaw, as replay does.
    assert s.role("heading").source.startswith("vehicle_attitude (") and s.missing() == []
    assert s.vehicle.rotors == 4 and s.vehicle.rpm_nonzero_airborne
    assert not s.autopilot_wind.active and "all zero" in s.autopilot_wind.reason


def test_ulog_wind_active_and_missing_roles(tmp_path):
    s = inspect_log(str(_px4_log(tmp_path / "a.ulg", wind_active=True, esc=False, land=False, rotor_param=0)))
    assert s.autopilot_wind.active and s.autopilot_wind.mean_speed_mps == pytest.approx(5.0)
    assert "drag fusion is on" in s.autopilot_wind.reason
    assert s.role("rpm").source is None and s.vehicle.rotors is None
    # Without land detection the collective setpoint (0.5 > half of MPC_THR_HOVER) says airborne throughout.
    assert "vehicle_thrust_setpoint" in s.airborne_source
    assert s.airborne_s == pytest.approx(LOG_S - 1 / 50, abs=1e-6)


def test_inspect_cli_text_and_one_json_object(tmp_path, capsys):
    log = _px4_log(tmp_path / "a.ulg")
    assert main(["inspect", str(log), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["roles"]["attitude"]["source"] == "vehicle_attitude.q[0]..q[3]" and out["missing"] == []
    assert out["parameters"]["MPC_THR_HOVER"] == 0.5 and out["vehicle"]["rotors"] == 4
    assert main(["inspect", str(log)]) == 0
    text = capsys.readouterr().out
    assert "vehicle_local_position" in text and "autopilot wind: inactive" in text
    assert main(["inspect", str(tmp_path / "missing.ulg")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "missing.ulg" in err


def test_init_rpm_when_every_esc_reads_rpm_airborne(px4):
    af = load_airframe(px4[1])
    assert af.thrust.source == "rpm" and af.thrust.rotors == 4 and af.calibration == PRIOR
    # rpm only: the attitude's 50 Hz sets the rate; max_dt 1.5 position intervals (0.15 s) > 3 x 0.02 s.
    assert af.observer.sample_time_s == pytest.approx(0.02) and af.limits.max_dt_s == pytest.approx(0.15)
    # The prior thrust curve carries the weight at the airborne median rpm (hover): four rotors, m g.
    median = np.median([HOVER_RPM + 100 * i for i in range(4)])
    per_rotor = sum(c * (median / af.thrust.max_rpm) ** k for k, c in enumerate(af.thrust.coefficients))
    assert 4 * per_rotor == pytest.approx(2.0 * af.gravity_mps2, rel=1e-9)


def test_init_collective_when_a_motor_reads_zero_and_the_rate_follows_the_slower_stream(tmp_path):
    log = _px4_log(tmp_path / "a.ulg", dead_motor=True, attitude_hz=19.6, thrust_hz=48.0)
    text, choices, _ = build_airframe(str(log), 2.0, str(tmp_path / "v.toml"))
    af = load_airframe(_write(tmp_path / "v.toml", text))
    assert af.thrust.source == "collective" and choices.rotors == 4
    # 19.6 Hz attitude is a jittery 20 Hz log: 20 Hz, not 10.
    assert af.observer.sample_time_s == pytest.approx(0.05) and af.limits.max_dt_s == pytest.approx(0.15)


def test_common_rate_rounds_down_with_jitter():
    assert [common_rate(r) for r in (5.0, 9.6, 10.0, 19.6, 23.0, 24.0, 31.0, 47.5, 60.0, 250.0)] == \
        [10.0, 10.0, 10.0, 20.0, 20.0, 25.0, 25.0, 25.0, 50.0, 100.0]


def test_init_prior_scales_drag_area_with_mass_to_two_thirds(px4, tmp_path):
    text = build_airframe(str(px4[0]), 8 * REFERENCE_MASS_KG, str(tmp_path / "v.toml"))[0]
    small, large = load_airframe(px4[1]).drag, load_airframe(_write(tmp_path / "v.toml", text)).drag
    assert large.q0 / small.q0 == pytest.approx(4.0) and large.l0 / small.l0 == pytest.approx(8.0)
    # PX4's ballistic coefficient at the reference mass: q0 = rho/2 * m / BC = 0.6125 * 2 / 100.
    assert small.q0 == pytest.approx(0.5 * 1.225 * REFERENCE_MASS_KG / 100.0)


def test_init_gains_give_the_chosen_bandwidth(px4):
    af = load_airframe(px4[1])
    # 10 Hz position: 1/20 of it is 0.5 Hz, the cap. For the paper's discretization the observer is a
    # first-order low-pass with pole p = 1 - dt gain / (2 m): |H| = 1/sqrt 2 at cos w = 1 - (1-p)^2/(2p).
    dt, m, w = af.observer.sample_time_s, af.mass_kg, 2 * math.pi * 0.5 * af.observer.sample_time_s
    c = 2 - math.cos(w)
    pole = c - math.sqrt(c * c - 1)
    assert af.observer.gains[0] == pytest.approx(2 * m * (1 - pole) / dt, rel=1e-6)
    assert max(af.filter.cutoffs_hz) == pytest.approx(0.5)


def test_init_cli_refuses_the_log_as_output_and_bad_mass(tmp_path, capsys):
    log = _px4_log(tmp_path / "a.ulg", esc=False)
    before = log.read_bytes()
    assert main(["init", str(log), "--mass", "2", "-o", str(log)]) == 2
    assert "input file" in capsys.readouterr().err and log.read_bytes() == before
    assert main(["init", str(log), "--mass", "-1", "-o", str(tmp_path / "v.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--mass" in err and not (tmp_path / "v.toml").exists()
    assert main(["init", str(log), "--mass", "2", "-o", str(tmp_path / "v.toml"), "--name", "Bad Name"]) == 2
    assert "--name" in capsys.readouterr().err and not (tmp_path / "v.toml").exists()
    assert main(["init", str(log), "--mass", "2", "-o", str(tmp_path / "v.toml"), "--name", "quad", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["choices"]["thrust_source"] == "collective" and load_airframe(tmp_path / "v.toml").name == "quad"


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


# ----- ArduPilot DataFlash -----
MESSAGES = {
    "XKF1": ("QBfff", ["TimeUS", "C", "VN", "VE", "VD"]),
    "XKQ": ("QBffff", ["TimeUS", "C", "Q1", "Q2", "Q3", "Q4"]),
    "XKF2": ("QBff", ["TimeUS", "C", "VWN", "VWE"]),
    "IMU": ("QBfff", ["TimeUS", "I", "AccX", "AccY", "AccZ"]),
    "ESC": ("QBf", ["TimeUS", "Instance", "RPM"]),
    "CTUN": ("Qff", ["TimeUS", "ThO", "ThH"]),
    "EV": ("QB", ["TimeUS", "Id"]),
    "RCOU": ("QHHHHHH", ["TimeUS", "C1", "C2", "C3", "C4", "C5", "C6"]),
}
PARM_TYPE = 129  # write_dataflash numbers its messages from 130


def _parameters(params: dict[str, float]) -> bytes:
    """PARM messages (Name is char[16], which the shared writer does not pack), appended to a log."""
    blob = bytes([0xA3, 0x95, 128]) + struct.pack("<BB4s16s64s", PARM_TYPE, 3 + 8 + 16 + 4, b"PARM", b"QNf",
                                                  b"TimeUS,Name,Value")
    for name, value in params.items():
        blob += bytes([0xA3, 0x95, PARM_TYPE]) + np.array([T0_US], "<u8").tobytes() + name.encode().ljust(16, b"\0") \
            + np.array([value], "<f4").tobytes()
    return blob


def _ardupilot_log(path: Path, *, esc_rpm: bool, esc: bool = True, parameters: bool = True, banner: str = "",
                   more: dict[str, float] | None = None, flies: bool = True) -> Path:
    """10 Hz EKF and CTUN, 25 Hz IMU; EV NOT_LANDED at 5 s and LAND_COMPLETE at 25 s; SITL ESCs at 0 rpm
    unless esc_rpm. ``banner``: the firmware's MSG at boot; ``more``: parameters besides the copter's;
    ``flies`` False: no EV events and the throttle at 0 throughout (a pre-arm log)."""
    rows: list = [("MSG", {"TimeUS": T0_US, "Message": banner})] if banner else []
    for k in range(int(LOG_S * 50)):  # a 50 Hz grid: IMU on every second instant, the rest on every fifth
        s, us = k / 50, T0_US + k * 20_000
        if k == TAKEOFF_S * 50 and flies:
            rows.append(("EV", {"TimeUS": us, "Id": 28}))
        if k == LANDING_S * 50 and flies:
            rows.append(("EV", {"TimeUS": us, "Id": 18}))
        if k % 2 == 0:
            rows.append(("IMU", {"TimeUS": us, "I": 0, "AccZ": -9.8}))
        if k % 5 == 0:
            rows += [("XKF1", {"TimeUS": us, "C": 0, "VN": 1.0}), ("XKQ", {"TimeUS": us, "C": 0, "Q1": 1.0}),
                     ("XKF2", {"TimeUS": us, "C": 0}), ("CTUN", {"TimeUS": us, "ThO": 0.4 * flies, "ThH": 0.37})]
            rows += [("ESC", {"TimeUS": us, "Instance": i, "RPM": 5000.0 if esc_rpm and _airborne(s) else 0.0})
                     for i in range(4) if esc]
            # Four motors, one servo at its 1000 us rest, one output unused.
            rows.append(("RCOU", {"TimeUS": us, **{f"C{c}": 1500 if _airborne(s) else 1000 for c in range(1, 5)},
                                  "C5": 1000, "C6": 0}))
    write_dataflash(path, {**MESSAGES, "MSG": ("QZ", ["TimeUS", "Message"])}, rows)
    if not parameters:
        return path
    params = {"FRAME_CLASS": 1, "MOT_THST_HOVER": 0.37, "SIM_WIND_SPD": 10.0, "SIM_WIND_DIR": 180.0,
              **{f"SERVO{i}_FUNCTION": 32.0 + i for i in range(1, 5)}, **(more or {})}
    path.write_bytes(path.read_bytes() + _parameters(params))
    return path


def test_dataflash_rates_airborne_roles_and_collective_init(tmp_path):
    pytest.importorskip("pymavlink")
    log = _ardupilot_log(tmp_path / "a.bin", esc_rpm=False)
    s = inspect_log(str(log))
    assert s.stream("XKF1 (primary core)").rate_hz == pytest.approx(10.0, rel=1e-4)
    assert s.stream("IMU (I 0)").rate_hz == pytest.approx(25.0, rel=1e-4)
    assert s.airborne_s == pytest.approx(LANDING_S - TAKEOFF_S) and s.airborne_source == "EV events"
    assert s.role("thrust").source == "CTUN.ThO" and s.role("acceleration").source.startswith("IMU specific force")
    assert s.parameters["SIM_WIND_SPD"] == 10.0 and s.vehicle.rotors == 4
    assert not s.vehicle.rpm_nonzero_airborne and not s.autopilot_wind.active
    text, choices, _ = build_airframe(str(log), 1.5, str(tmp_path / "v.toml"))
    af = load_airframe(_write(tmp_path / "v.toml", text))
    # CTUN and XKQ at 10 Hz: sample time 0.1 s, max_dt three of them.
    assert af.thrust.source == "collective" and af.observer.sample_time_s == pytest.approx(0.1)
    assert af.limits.max_dt_s == pytest.approx(0.3)


def test_a_corrupt_dataflash_log_is_one_line_on_stderr(tmp_path, capfd):
    pytest.importorskip("pymavlink")
    junk = tmp_path / "junk.bin"
    junk.write_bytes(np.random.default_rng(1).integers(0, 256, 3000, dtype=np.uint8).tobytes())
    assert main(["inspect", str(junk)]) == 2
    out, err = capfd.readouterr()
    assert out == "" and err.count("\n") == 1 and "junk.bin" in err


def test_dataflash_rotors_from_driven_outputs_without_parameters_or_esc(tmp_path):
    pytest.importorskip("pymavlink")
    s = inspect_log(str(_ardupilot_log(tmp_path / "a.bin", esc_rpm=False, esc=False, parameters=False)))
    assert s.vehicle.rotors == 4 and s.vehicle.rotor_source.startswith("RCOU")


def test_dataflash_rpm_init(tmp_path):
    pytest.importorskip("pymavlink")
    text, choices, _ = build_airframe(str(_ardupilot_log(tmp_path / "a.bin", esc_rpm=True)), 1.5, str(tmp_path / "v.toml"))
    assert choices.thrust_source == "rpm" and choices.rotors == 4


def test_csv_inspect_and_init(tmp_path):
    from dobwind.io.logs import write_csv

    t = np.arange(0, 10, 0.01)
    cols = {"t": t, "vel_n": t * 0, "vel_e": t * 0, "vel_d": t * 0, "acc_n": t * 0, "acc_e": t * 0, "acc_d": t * 0,
            "q_w": t * 0 + 1, "q_x": t * 0, "q_y": t * 0, "q_z": t * 0,
            **{f"rpm_{i}": t * 0 + 3000 for i in range(1, 7)}}
    write_csv(tmp_path / "f.csv", list(cols), np.column_stack(list(cols.values())), ["%.6f"] * len(cols))
    s = inspect_log(str(tmp_path / "f.csv"))
    assert s.stream("rows").rate_hz == pytest.approx(100.0, rel=1e-6) and s.vehicle.rotors == 6
    assert s.role("thrust").source is None and s.missing() == []
    text, choices, _ = build_airframe(str(tmp_path / "f.csv"), 3.0, str(tmp_path / "v.toml"))
    assert choices.thrust_source == "rpm" and choices.rotors == 6 and choices.rate_hz == 100.0


def _real_log(log: Path) -> None:
    if not log.exists():
        pytest.skip(f"{log} not present")
    pytest.importorskip("pymavlink")


@pytest.mark.parametrize("log", REAL_LOGS, ids=lambda p: p.name)
def test_real_logs_inspect(log, capsys):
    """Each real log's roles, airborne span and rotors, read by inspect (0.1 s a log)."""
    _real_log(log)
    assert main(["inspect", str(log), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["missing"] == [] and summary["airborne_s"] > 5 and summary["vehicle"]["rotors"] in (4, 8)


@pytest.mark.parametrize("log", REAL_LOGS, ids=lambda p: p.name)
def test_real_logs_init_a_starter_that_passes_check(log, tmp_path):
    """The whole chain on each real log (a gain design and check's generate and self-test, 1.5-2 s a log:
    in make test only; test-fast runs init on the logs written here, and check's own tests)."""
    _real_log(log)
    assert main(["init", str(log), "--mass", "2.0", "-o", str(tmp_path / "v.toml")]) == 0
    assert main(["check", str(tmp_path / "v.toml")]) == 0
    assert load_airframe(tmp_path / "v.toml").uncalibrated
    assert math.isfinite(load_airframe(tmp_path / "v.toml").observer.gains[0])


def test_rosbag_streams_airborne_esc_wind_and_init(tmp_path):
    pytest.importorskip("rosbags")
    from dobwind.simulate.simulate import simulate
    from tests.helpers import M300
    from tests.test_rosbag import T0_US as BAG_T0_US, _px4_bag

    af = load_airframe(M300)
    cols = simulate(af, "tunnel", seed=5, hold_s=1.0, rate_hz=50.0)
    bag = str(_px4_bag(tmp_path / "bag", af, cols, "mcap", landed_until=2.0, hover=0.4))
    s = inspect_log(bag)
    assert s.format == "rosbag" and s.role("velocity").source == "/fmu/out/vehicle_odometry"
    assert s.stream("/fmu/out/vehicle_attitude").count == len(cols["t"])
    assert s.stream("/fmu/out/vehicle_land_detected").rate_hz == pytest.approx(5.0, rel=1e-3)
    # Land detection every 10th sample, landed while t < 2 s: airborne from the first report at or after 2 s.
    first_up = cols["t"][::10][cols["t"][::10] >= 2.0][0]
    assert s.airborne_intervals[0][0] == pytest.approx(BAG_T0_US * 1e-6 + first_up, abs=1e-6)
    assert s.vehicle.rotors == 4 and s.vehicle.rpm_nonzero_airborne and s.autopilot_wind.active
    _, choices, _ = build_airframe(bag, 8.0, str(tmp_path / "v.toml"))
    assert choices.thrust_source == "rpm" and choices.rate_hz == 50.0


def test_inspect_names_only_what_the_readers_read(px4, tmp_path):
    """The roles' streams are topics the replay readers parse (ulog.TOPICS_READ, dataflash.WANTED): a
    reader that drops a topic must not leave inspect promising it."""
    from dobwind.io.ulog import TOPICS_READ

    for role in inspect_log(str(px4[0])).roles:
        assert role.stream is None or role.stream in TOPICS_READ, role
    pytest.importorskip("pymavlink")
    from dobwind.io.dataflash import WANTED

    for role in inspect_log(str(_ardupilot_log(tmp_path / "a.bin", esc_rpm=True))).roles:
        assert role.stream is None or role.stream.split(" ")[0] in WANTED, role


def test_the_starter_airframe_passes_verify(px4, capsys):
    assert main(["verify", px4[1], "--steps", "2000"]) == 0
    assert "0 status mismatches" in capsys.readouterr().out


def test_replay_says_how_many_rows_of_its_mean_wind_are_trusted(px4, capsys):
    """The starter's estimates all carry UNCALIBRATED: the mean wind line says it is over accepted rows
    of which none is trusted, so it does not read as a confident number."""
    assert main(["replay", px4[1], str(px4[0]), "--json"]) == 0
    counts = json.loads(capsys.readouterr().out)["status_counts"]
    accepted = sum(n for name, n in counts.items() if "LANDED" not in name and "NO_DATA" not in name)
    assert main(["replay", px4[1], str(px4[0])]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("mean horizontal wind"))
    assert line.endswith(f"m/s (over the {accepted} accepted rows, 0 of them trusted; the others carry the "
                         "quality flags in the status counts above)"), line


def test_replay_of_the_log_with_its_starter_airframe_names_the_bit(px4, capsys):
    assert main(["replay", px4[1], str(px4[0]), "--json"]) == 0
    counts = json.loads(capsys.readouterr().out)["status_counts"]
    accepted = {name: n for name, n in counts.items() if "LANDED" not in name and "NO_DATA" not in name}
    assert accepted and all("UNCALIBRATED" in name for name in accepted)


def test_init_says_the_mass_is_unchecked_and_a_wrong_one_only_scales_the_law(px4, tmp_path, capsys):
    """What init tells the user about --mass (text, --json and the file) is what the code does: at three
    times the mass the starter's thrust and observer gains are exactly three times as large, and with its
    force-air law three times the small one's too, replay reads the same wind on every row: a wrong mass
    scales the law the forces are calibrated into, nothing else."""
    from dobwind.model.airframe import parse_airframe
    from dobwind.model.airframe_toml import airframe_document, dumps
    from dobwind.replay.replay import replay_ulog

    log, small_path = px4
    big_path = tmp_path / "big.toml"
    assert main(["init", str(log), "--mass", str(3 * REFERENCE_MASS_KG), "-o", str(big_path)]) == 0
    out = capsys.readouterr().out
    assert f"mass         {3 * REFERENCE_MASS_KG:g} kg from --mass, not checked against the log" in out
    assert "a wrong mass scales the force-air law by the same factor" in out
    assert "# mass: 6 kg from --mass, not checked against the log" in big_path.read_text()
    assert main(["init", str(log), "--mass", "6", "-o", str(tmp_path / "j.toml"), "--json"]) == 0
    mass = json.loads(capsys.readouterr().out)["mass"]
    assert mass["kg"] == 6.0 and mass["source"] == "--mass" and mass["checked_against_log"] is False
    assert "no absolute force" in mass["why"] and "same factor" in mass["if_wrong"]

    small, big = load_airframe(small_path), load_airframe(big_path)
    np.testing.assert_allclose(big.thrust.coefficients, 3 * np.asarray(small.thrust.coefficients), rtol=1e-12)
    np.testing.assert_allclose(big.observer.gains, 3 * np.asarray(small.observer.gains), rtol=1e-9)
    doc, law = airframe_document(big), airframe_document(small)["force_air"]
    doc["force_air"] = {**law, "drag": {k: 3 * v for k, v in law["drag"].items()}}
    scaled = parse_airframe(dumps(doc), "scaled.toml")
    winds = []
    for af in (small, scaled):
        model, _, traj = replay_ulog(af, str(log))
        winds.append(traj.outputs[:, model.outputs.slice("wind_ned")])
    assert np.isfinite(winds[0]).any()
    np.testing.assert_allclose(winds[1], winds[0], atol=1e-6, equal_nan=True)


def test_a_mean_over_trusted_rows_only_says_so():
    from dobwind.cli.replay import _over_rows

    assert _over_rows({"valid_rows": 12, "status_counts": {"OK": 12, "LANDED": 3}}) == "(over the 12 accepted rows, all trusted)"
    assert "5 of them trusted" in _over_rows({"valid_rows": 12, "status_counts": {"OK": 5, "SETTLING": 7}})


def test_init_explains_its_acceleration_input(px4, tmp_path, capsys):
    """The bare keyword `ned` is followed by what it is; every keyword init can choose has a meaning."""
    from dobwind.inspect.initframe import ACCELERATION_MEANING

    assert main(["init", str(px4[0]), "--mass", "2", "-o", str(tmp_path / "v.toml")]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("  acceleration"))
    assert line.startswith("  acceleration ned (the log's own NED acceleration; the log's NED acceleration and the "
                           "velocity's derivative differ by 0.00 m/s² RMS below 0.5 Hz"), line
    assert set(ACCELERATION_MEANING) == {"ned", "specific_force", "velocity"}


def test_arguments_swapped_say_which_file_is_which(px4, tmp_path, capsys):
    """A ULog where the airframe belongs used to be "not UTF-8 text", an airframe where the log belongs
    "column t: missing": each now says what the file is and the order the commands take."""
    log, airframe = px4
    for argv, said in ((["replay", str(log), airframe], "this is a PX4 ULog flight log, not an airframe TOML"),
                       (["report", str(log), airframe, "-o", str(tmp_path / "r.html")], "PX4 ULog flight log"),
                       (["replay", airframe, airframe], "a .toml file is an airframe, not a flight log"),
                       (["inspect", airframe], "inspect and init take the log alone"),
                       (["init", airframe, "--mass", "2", "-o", str(tmp_path / "v.toml")], "not a flight log")):
        assert main(argv) == 2, argv
        errors = [line for line in capsys.readouterr().err.splitlines() if ": warning: " not in line]
        assert len(errors) == 1 and said in errors[0] and "AIRFRAME then LOG" in errors[0], (argv, errors)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("mass", ["0", "-3", "nan", "inf", "-inf", "1e400", "0.001", "20000"])
def test_init_refuses_a_mass_that_is_no_multirotors_in_one_line(px4, tmp_path, capsys, mass):
    out = tmp_path / "v.toml"
    assert main(["init", str(px4[0]), f"--mass={mass}", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--mass" in err and "kg" in err and "Traceback" not in err
    assert not out.exists()


def test_an_estimate_given_where_a_log_belongs_is_named_as_such(px4, tmp_path, capsys):
    """replay's own output fed back as the log: each command said "no thrust source" (init) or "column
    vel_n: missing" (replay, report, fit); now one line says it is an estimate and what to give instead."""
    log, airframe = px4
    estimate = tmp_path / "e.csv"
    assert main(["replay", airframe, str(log), "-o", str(estimate)]) == 0
    capsys.readouterr()
    commands = (["inspect", str(estimate)], ["inspect", str(estimate), "--json"],
                ["init", str(estimate), "--mass", "2", "-o", str(tmp_path / "v.toml")],
                ["replay", airframe, str(estimate), "-o", str(tmp_path / "e2.csv")],
                ["report", airframe, str(estimate), "-o", str(tmp_path / "r.html")],
                ["fit", airframe, str(estimate), "-o", str(tmp_path / "f.toml")])
    for argv in commands:
        assert main(argv) == 2, argv
        err = [line for line in capsys.readouterr().err.splitlines() if "uncalibrated prior" not in line]
        assert len(err) == 1 and f"{estimate}: is a dobwind estimate" in err[0] and "flight log" in err[0], (argv, err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["e.csv"]


@pytest.mark.parametrize("banner, more, refused", [
    ("ArduPlane V4.5.1 (abcdef12)", {"Q_ENABLE": 0.0}, "ArduPlane V4.5.1 with Q_ENABLE 0: a fixed-wing plane without VTOL lift rotors"),
    ("ArduPlane V4.5.1 (abcdef12)", {}, "ArduPlane V4.5.1 with Q_ENABLE 0: a fixed-wing plane without VTOL lift rotors"),
    ("ArduSub V4.1.0 (abcdef12)", {}, "ArduSub V4.1.0: a submarine"),
    ("ArduPlane V4.5.1 (abcdef12)", {"Q_ENABLE": 1.0}, None),   # a quadplane hovers on its lift rotors
    ("ArduCopter V4.6.2 (abcdef12)", {}, None)])
def test_init_refuses_the_log_of_a_vehicle_that_is_no_multirotor(tmp_path, capsys, banner, more, refused):
    """The plane log gave only "no thrust source" (or, with a throttle, a starter for a plane): the
    firmware's banner says what flew, and inspect and init say it."""
    pytest.importorskip("pymavlink")
    log = _ardupilot_log(tmp_path / "a.bin", esc_rpm=False, banner=banner, more=more)
    s = inspect_log(str(log))
    assert s.vehicle.airframe.endswith(f"firmware {banner.split(' (')[0]}")
    assert s.vehicle.not_multirotor == (refused or "")
    code = main(["init", str(log), "--mass", "2", "-o", str(tmp_path / "v.toml")])
    err = capsys.readouterr().err
    if refused is None:
        assert code == 0 and err == ""
        return
    assert code == 2 and err.count("\n") == 1 and f"{log}: vehicle: {refused}" in err and "multirotor" in err, err
    assert not (tmp_path / "v.toml").exists()
    assert main(["inspect", str(log)]) == 0
    out = capsys.readouterr().out
    assert f"NOT A MULTIROTOR: {refused}" in out and "missing: vehicle: not a multirotor" in out
    # replay (and so report and fit) refuse it too, whatever the airframe: it failed on CTUN.ThO before
    assert main(["replay", str(ROOT / "airframes" / "m300.toml"), str(log), "-o", str(tmp_path / "e.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{log}: vehicle: {refused}" in err, err


@pytest.mark.parametrize("mav_type, refused", [(1, "MAV_TYPE 1: a fixed-wing plane"), (12, "MAV_TYPE 12: a submarine"),
                                               (2, ""), (22, "")])
def test_a_px4_mav_type_of_a_plane_or_a_submarine_is_no_multirotor(tmp_path, mav_type, refused):
    assert inspect_log(str(_px4_log(tmp_path / "a.ulg"))).vehicle.not_multirotor == ""   # no MAV_TYPE logged
    log = _px4_log(tmp_path / "b.ulg", extra_params={"MAV_TYPE": float(mav_type)})
    assert inspect_log(str(log)).vehicle.not_multirotor == refused
    if refused:  # the log has every topic replay reads: it was replayed as a copter's
        from dobwind.io.ulog import read_ulog

        with pytest.raises(InputError, match="vehicle: " + refused):
            read_ulog(str(log), load_airframe(ROOT / "airframes" / "m300.toml"))


def test_init_refuses_a_log_that_never_flew(tmp_path, capsys):
    """A pre-arm log (throttle at 0, no take-off): init wrote a starter from it, which then estimated nothing."""
    pytest.importorskip("pymavlink")
    log = _ardupilot_log(tmp_path / "a.bin", esc_rpm=False, flies=False)
    assert inspect_log(str(log)).airborne_s == 0.0
    assert main(["init", str(log), "--mass", "2", "-o", str(tmp_path / "v.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{log}: airborne: never airborne in its" in err and "give the log of a flight" in err
    assert not (tmp_path / "v.toml").exists()


@pytest.mark.parametrize("topic, role", [("vehicle_local_position", "velocity"), ("vehicle_attitude", "attitude")])
def test_init_refuses_a_log_without_the_velocity_or_the_attitude(tmp_path, capsys, topic, role):
    """inspect listed "missing: velocity" and init still wrote a starter, which replay then refused."""
    log = _px4_log(tmp_path / "a.ulg", drop=(topic,))
    assert any(line.startswith(f"{role}:") for line in inspect_log(str(log)).missing())
    assert main(["init", str(log), "--mass", "2", "-o", str(tmp_path / "v.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{log}: {role}: " in err and topic in err and "replay needs it" in err, err
    assert not (tmp_path / "v.toml").exists()


@pytest.mark.parametrize("name, kind", [("e.ulg", "ULog"), ("e.bin", "DataFlash")])
def test_an_empty_log_says_it_is_empty(tmp_path, capsys, name, kind):
    """An empty file said "Header too short" (ULog) or "does not start with 0xA3 0x95" (DataFlash)."""
    if kind == "DataFlash":
        pytest.importorskip("pymavlink")
    log = tmp_path / name
    log.write_bytes(b"")
    for argv in (["inspect", str(log)], ["replay", str(ROOT / "airframes" / "m300.toml"), str(log), "-o",
                                          str(tmp_path / "e.csv")]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"{log}: is empty (0 bytes): not a {kind}" in err, err


@pytest.mark.parametrize("params, says", [
    ({}, "EK3 drag fusion unknown (no EK3_DRAG_*"),                       # EKF2-era log: nothing to read
    ({"EK3_DRAG_BCOEF_X": 0.0, "EK3_DRAG_MCOEF": 0.0}, "EK3 drag fusion is off"),
    ({"EK3_DRAG_BCOEF_X": 0.0, "EK3_DRAG_MCOEF": 0.2}, "EK3 drag fusion is on"),
])
def test_ardupilot_drag_fusion_is_off_only_when_its_parameters_say_so(params, says):
    from dobwind.inspect.inspect_dataflash import _ap_wind
    reason = _ap_wind({}, params).reason
    assert says in reason and ("unknown" in reason) == (not params)


@pytest.mark.parametrize("params, says", [
    ({}, "EKF2 drag fusion unknown (no EKF2_AID_MASK or EKF2_DRAG_CTRL"),
    ({"EKF2_AID_MASK": 1}, "EKF2 drag fusion is off"),
    ({"EKF2_DRAG_CTRL": 0}, "EKF2 drag fusion is off"),
    ({"EKF2_AID_MASK": 32}, "EKF2 drag fusion is on"),
])
def test_px4_drag_fusion_is_off_only_when_its_parameters_say_so(params, says):
    from dobwind.inspect.inspect_ulog import _px4_wind
    from dobwind.inspect.loginspect import Role
    reason = _px4_wind({}, Role("autopilot_wind", None), params).reason
    assert says in reason and ("unknown" in reason) == (not params)


def _two_flights_rows(pause_s: float):
    """A DataFlash log of two flights, the board not rebooted: ArduPilot (LOG_DISARMED 0) logs nothing while
    disarmed and goes on in the same file at the next arming, so the pooled streams pause for pause_s."""
    from tests.test_dataflash import _flight, _rows

    af, cols = _flight()
    first = _rows(af, cols) + [("EV", {"TimeUS": 1_000_000 + int(cols["t"][-1] * 1e6) + 1, "Id": 11})]
    shift = int((cols["t"][-1] + pause_s) * 1e6)
    second = [(name, {**row, "TimeUS": row["TimeUS"] + shift}) for name, row in first]
    return first + second, float(cols["t"][-1])


def test_two_flights_a_long_pause_apart_both_count(tmp_path, capsys):
    """bulk_span took a pause of more than 60 s with no sample for a broken clock and kept only the larger
    run: the second of two flights two minutes apart (ArduPilot's disarmed pause) was dropped from the span
    and the airborne time, and a note called the clock damaged. A run of samples that lasts is a flight."""
    import json

    from tests.dataflash_writer import write_dataflash
    from tests.test_dataflash import MESSAGES

    rows, flight_s = _two_flights_rows(120.0)
    log = write_dataflash(tmp_path / "two.bin", MESSAGES, rows)
    assert main(["inspect", str(log), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["outside_span"] == 0 and not any("outside the span" in n for n in got["notes"]), got["notes"]
    assert got["duration_s"] == pytest.approx(2 * flight_s + 120.0, abs=0.01)
    assert got["airborne_s"] == pytest.approx(2 * flight_s, abs=0.05)


def test_the_span_keeps_runs_that_last_and_drops_stray_stamps():
    """Closed forms on bulk_span: two 10 s runs at 10 Hz 120 s apart are one span of 140 s; two stamps with
    the same high bit flipped, 5 s apart (a run of two lasting 5 s), a lone one before, and a burst of a
    dozen within 0.11 s are outside it."""
    from dobwind.inspect.loginspect import bulk_span

    a = np.arange(100) * 0.1
    b = 130.0 + np.arange(100) * 0.1
    both = bulk_span(np.r_[a, b])
    assert (both.start_s, both.end_s, both.outside) == (0.0, b[-1], 0)
    wild = 2.0 ** 61 * 1e-6
    stray = bulk_span(np.r_[-500.0, a, b, wild + 3.0, wild + 8.0])
    assert (stray.start_s, stray.end_s, stray.outside, stray.samples) == (0.0, b[-1], 3, 203)
    assert stray.outside_s == (-500.0, wild + 8.0)
    burst = bulk_span(np.r_[a, b, -1e9 + np.arange(12) * 0.01])  # a buffer of 12 stamps in 0.11 s, all wild
    assert (burst.start_s, burst.end_s, burst.outside) == (0.0, b[-1], 12)
    tiny = bulk_span(np.r_[0.0, 0.1, 0.2, wild])  # no run lasts: the largest is the span
    assert (tiny.start_s, tiny.end_s, tiny.outside) == (0.0, 0.2, 1)


def test_a_clock_in_other_units_is_no_damaged_clock(tmp_path, capsys):
    """A CSV whose t is in microseconds (100 Hz rows 10000 "s" apart) has no run of samples at all: bulk_span
    took its first row for the span (0 .. 0 s) and called the other 99.9 % a damaged clock. With no run
    that lasts and none holding most of the samples, the span is the samples' whole range, nothing outside."""
    import json

    from dobwind.inspect.loginspect import bulk_span

    t = np.arange(800) * 1e4
    whole = bulk_span(t)
    assert (whole.start_s, whole.end_s, whole.outside) == (0.0, t[-1], 0)
    lines = ["t,vel_n,vel_e,vel_d,q_w,q_x,q_y,q_z"] + [f"{x:g},0,0,0,1,0,0,0" for x in t]
    log = tmp_path / "us.csv"
    log.write_text("\n".join(lines) + "\n")
    assert main(["inspect", str(log), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["outside_span"] == 0 and got["duration_s"] == t[-1], got
    assert not any("damaged clock" in n for n in got["notes"]), got["notes"]
