"""PX4 ULog replay, on small ULog files written here (tests/ulog_writer.py) from simulated flights."""
from __future__ import annotations

import math
import os
import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.model.status import STATUS_BITS, STATUS_LANDED, STATUS_NO_DATA, accepted
from dobwind.replay.replay import replay, replay_ulog
from dobwind.simulate.simulate import column_order, simulate
from dobwind.io.logs import write_csv
from tests.helpers import M300, ROOT, airframe_dict
from tests.ulog_writer import Topic, write_ulog

STATUS_SETTLING = next(bit.value for bit in STATUS_BITS if bit.name == "SETTLING")
ESC_REPORT = {"esc_report": [("int32_t", "esc_rpm"), ("float", "esc_voltage")]}
SAMPLE = ROOT.parent / "shared" / "data" / "px4-ulog" / "sample_log_small.ulg"


def _collective():
    return parse_airframe(dumps(airframe_dict(thrust={"source": "collective"}, mass=8.0, name="coll",
                                              **{"observer.force_offset": [0.0, 0.0, 0.0]})), "<c>")


def _flight(rate=100.0):
    """A simulated flight on a uniform clock: replay resamples autopilot logs onto a uniform clock at the
    observer's rate, so a row-for-row comparison with the CSV needs the log's samples on that clock."""
    af = load_airframe(M300)
    cols = simulate(af, "tunnel", seed=9, hold_s=4.0, rate_hz=rate)
    return af, {**cols, "t": np.arange(len(cols["t"])) / rate}


def _rows(cols, keys, names, t0_us=1_000_000, keep=None):
    rows = []
    for k in range(len(cols["t"])):
        if keep is not None and not keep[k]:
            continue
        row = {"timestamp": int(round(t0_us + cols["t"][k] * 1e6))}
        for key, name in zip(keys, names):
            row[name] = float(cols[key][k])
        rows.append(row)
    return rows


def _hover_topic(end_s: float, hover: float, converging: tuple[float, float] | None,
                 lapse: tuple[float, float] | None) -> Topic:
    """hover_thrust_estimate at 2 Hz (``converging``, ``lapse``: as _ulog's)."""
    t = np.arange(0, end_s, 0.5)
    if converging is None:
        return Topic("hover_thrust_estimate", [("uint64_t", "timestamp"), ("float", "hover_thrust")],
                     [{"timestamp": int(1_000_000 + s * 1e6), "hover_thrust": hover} for s in t])
    start, until = converging
    lo, hi = lapse or (math.inf, math.inf)
    valid = [until <= s and not lo <= s < hi for s in t]
    return Topic("hover_thrust_estimate", [("uint64_t", "timestamp"), ("float", "hover_thrust"), ("bool", "valid")],
                 [{"timestamp": int(1_000_000 + s * 1e6), "hover_thrust": hover if ok else start, "valid": ok}
                  for s, ok in zip(t, valid)])

def _ulog(path, cols, *, esc=True, thrust=None, hover=None, param=None, gap=None, landed_until=None, wind=False,
          attitude_setpoint=True, esc_count=4, esc_every=1, land_flags=None, esc_gap=None, extra=(), sensor=False,
          converging: tuple[float, float] | None = None, lapse: tuple[float, float] | None = None):
    """``converging`` (value, until s): hover_thrust_estimate logs ``valid`` and reads ``value``, not valid,
    before ``until`` (PX4's estimator converging from MPC_THR_HOVER), then ``hover``, valid; ``lapse``
    (from, to s): not valid, and ``value`` again, in that span too."""
    keep = None if gap is None else ~((cols["t"] > gap[0]) & (cols["t"] < gap[1]))
    topics = [
        Topic("vehicle_local_position", [("uint64_t", "timestamp")] + [("float", f) for f in ("vx", "vy", "vz", "ax", "ay", "az")],
              _rows(cols, ["vel_n", "vel_e", "vel_d", "acc_n", "acc_e", "acc_d"], ["vx", "vy", "vz", "ax", "ay", "az"])),
        Topic("vehicle_attitude", [("uint64_t", "timestamp"), ("float[4]", "q")],
              _rows(cols, ["q_w", "q_x", "q_y", "q_z"], [f"q[{i}]" for i in range(4)], keep=keep)),
    ]
    if attitude_setpoint:
        fields = [("uint64_t", "timestamp"), ("float", "yaw_body"), ("float[3]", "thrust_body")]
        rows = _rows(cols, ["yaw_ref"], ["yaw_body"])
        if thrust == "attitude_setpoint":
            for row, value in zip(rows, cols["thrust"]):
                row["thrust_body[2]"] = -value / (8.0 * 9.80665) * (param or 0.5)
        topics.append(Topic("vehicle_attitude_setpoint", fields, rows))
    if esc:
        esc_keep = None if esc_gap is None else ~((cols["t"] > esc_gap[0]) & (cols["t"] < esc_gap[1]))
        rows = _rows(cols, [f"rpm_{i}" for i in range(1, 5)], [f"esc[{i}].esc_rpm" for i in range(4)], keep=esc_keep)[::esc_every]
        for row in rows:
            row["esc_count"] = esc_count
        topics.append(Topic("esc_status", [("uint64_t", "timestamp"), ("uint8_t", "esc_count"), ("esc_report[8]", "esc")],
                            rows))
    if thrust == "thrust_setpoint":
        rows = _rows(cols, ["thrust"], ["xyz[2]"])
        for row in rows:
            row["xyz[2]"] = -row["xyz[2]"] / (8.0 * 9.80665) * hover
        topics.append(Topic("vehicle_thrust_setpoint", [("uint64_t", "timestamp"), ("float[3]", "xyz")], rows))
        topics.append(_hover_topic(cols["t"][-1], hover, converging, lapse))
    if landed_until is not None:  # land_flags: {flag: seconds it stays set}, e.g. {"ground_contact": 5.0}
        t = np.arange(0, cols["t"][-1], 0.2)
        until = {"landed": landed_until, "maybe_landed": landed_until, "ground_contact": landed_until, **(land_flags or {})}
        topics.append(Topic("vehicle_land_detected", [("uint64_t", "timestamp")] + [("bool", f) for f in until],
                            [{"timestamp": int(1_000_000 + s * 1e6), **{f: bool(s < u) for f, u in until.items()}}
                             for s in t]))
    if wind == "estimator_states":  # PX4's EKF state vector: wind north / east at states[22] / [23]
        topics.append(Topic("estimator_states", [("uint64_t", "timestamp"), ("float[24]", "states")],
                            _rows(cols, ["wind_n", "wind_e"], ["states[22]", "states[23]"])))
    elif wind:  # True: PX4's `wind` topic; or its older name, "wind_estimate"
        topics.append(Topic(wind if isinstance(wind, str) else "wind",
                            [("uint64_t", "timestamp"), ("float", "windspeed_north"), ("float", "windspeed_east")],
                            _rows(cols, ["wind_n", "wind_e"], ["windspeed_north", "windspeed_east"])))
    if sensor:
        topics.append(Topic("sensor_combined", [("uint64_t", "timestamp"), ("float[3]", "accelerometer_m_s2")],
                            _rows(cols, ["sf_x", "sf_y", "sf_z"], [f"accelerometer_m_s2[{i}]" for i in range(3)])))
    return write_ulog(path, topics + list(extra), {"MPC_THR_HOVER": param} if param else None, ESC_REPORT)


def _csv(path, cols):
    names = column_order(cols)
    write_csv(path, names, np.column_stack([cols[n] for n in names]), ["%.9g"] * len(names))
    return path


def test_rpm_mapping_matches_the_same_flight_as_csv(tmp_path):
    af, cols = _flight()
    model, flight, traj = replay_ulog(af, str(_ulog(tmp_path / "rpm.ulg", cols)))
    np.testing.assert_array_equal(traj.status, replay(af, str(_csv(tmp_path / "same.csv", cols)))[2].status)
    _, log, ref = replay(af, str(_csv(tmp_path / "rpm.csv", cols)))
    assert flight.log.rows == log.rows and np.all(accepted(traj.status))
    wind = model.outputs.slice("wind_ned")
    # ULog stores float32 and integer rpm: agreement to that resolution, not to the last bit.
    np.testing.assert_allclose(traj.outputs[200:, wind], ref.outputs[200:, wind], atol=0.05)


@pytest.mark.parametrize("source", ["thrust_setpoint", "attitude_setpoint"])
def test_collective_mapping_recovers_newtons(tmp_path, source):
    af = _collective()
    _, cols = _flight()
    path = _ulog(tmp_path / "coll.ulg", cols, esc=False, thrust=source, hover=0.42, param=0.55)
    _, flight, traj = replay_ulog(af, str(path), rate_hz=100.0)  # the log's rate: rows align with cols
    np.testing.assert_allclose(flight.log.columns["thrust"][5:-5], cols["thrust"][5:-5], rtol=1e-5)
    assert any(("MPC_THR_HOVER" in n) == (source == "attitude_setpoint") for n in flight.notes)
    assert np.all(np.isfinite(traj.outputs))


@pytest.mark.parametrize("until", [3.0, 1e9])
def test_the_hover_estimate_counts_only_once_valid(tmp_path, until):
    """PX4's hover thrust estimator starts at MPC_THR_HOVER and converges before it flags itself valid:
    the unconverged 0.30 (not 0.42) before ``until`` would scale the thrust 40 % high. Valid from 3 s: its
    first valid value holds before; never valid: the MPC_THR_HOVER parameter (0.42 too) throughout."""
    af = _collective()
    _, cols = _flight()
    path = _ulog(tmp_path / "h.ulg", cols, esc=False, thrust="thrust_setpoint", hover=0.42, param=0.42,
                 converging=(0.30, until))
    _, flight, _ = replay_ulog(af, str(path), rate_hz=100.0)
    np.testing.assert_allclose(flight.log.columns["thrust"][5:-5], cols["thrust"][5:-5], rtol=1e-5)
    said = " ".join(flight.notes)
    assert ("valid from 4.0 s" in said) if until < 1e9 else ("never valid" in said and "MPC_THR_HOVER" in said), said


def test_a_hover_estimate_that_lapses_later_is_used_where_valid_and_the_lapse_is_named(tmp_path):
    """Valid from 3 s, then not valid (reading the unconverged 0.30 again) from 6 to 7 s: those messages are
    left out, the valid ones around them scale the thrust, and the note names the lapse in log time."""
    af = _collective()
    _, cols = _flight()
    path = _ulog(tmp_path / "h.ulg", cols, esc=False, thrust="thrust_setpoint", hover=0.42, param=0.42,
                 converging=(0.30, 3.0), lapse=(6.0, 7.0))
    _, flight, _ = replay_ulog(af, str(path), rate_hz=100.0)
    np.testing.assert_allclose(flight.log.columns["thrust"][5:-5], cols["thrust"][5:-5], rtol=1e-5)
    said = " ".join(flight.notes)
    assert "valid from 4.0 s" in said and "not valid in 2 later message(s), 7.0-7.5 s" in said, said



def test_a_hover_estimate_never_valid_without_the_parameter_is_named_as_such(tmp_path):
    """The topic is there but never valid, and the log has no MPC_THR_HOVER: the refusal says so, not
    that the topic is missing (the user would look for a topic the log has)."""
    from dobwind.core.errors import InputError

    _, cols = _flight()
    path = _ulog(tmp_path / "h.ulg", cols, esc=False, thrust="thrust_setpoint", hover=0.42, converging=(0.30, 1e9))
    with pytest.raises(InputError, match="never valid, and no MPC_THR_HOVER parameter") as err:
        replay_ulog(_collective(), str(path), rate_hz=100.0)
    assert err.value.where == "topic hover_thrust_estimate"

@pytest.mark.parametrize("rpm", [True, False])
def test_the_gap_note_names_esc_status_tolerance_only_when_the_airframe_reads_it(tmp_path, rpm):
    af, cols = _flight()
    if rpm:
        path = _ulog(tmp_path / "rpm.ulg", cols, gap=(10.0, 11.2))
    else:
        af = _collective()
        path = _ulog(tmp_path / "coll.ulg", cols, esc=False, thrust="thrust_setpoint", hover=0.42, gap=(10.0, 11.2))
    _, flight, _ = replay_ulog(af, str(path), rate_hz=100.0)
    note = next(n for n in flight.notes if "topic gap" in n)
    assert ("esc_status:" in note) == rpm and "vehicle_attitude" in note.split("by topic: ")[1]


@pytest.mark.parametrize("setpoint", ["absent", "without yaw_body"])
def test_the_heading_note_says_whether_the_setpoint_topic_or_its_yaw_is_missing(tmp_path, setpoint):
    af, cols = _flight()
    # PX4 v1.15+ logs vehicle_attitude_setpoint without yaw_body
    extra = [Topic("vehicle_attitude_setpoint", [("uint64_t", "timestamp"), ("float[3]", "thrust_body")],
                   _rows(cols, ["thrust"], ["thrust_body[2]"]))] if setpoint != "absent" else []
    path = _ulog(tmp_path / "yaw.ulg", cols, attitude_setpoint=False, extra=extra)
    _, flight, _ = replay_ulog(af, str(path), rate_hz=100.0)
    note = next(n for n in flight.notes if "heading frame follows" in n)
    assert note.startswith("no vehicle_attitude_setpoint" if setpoint == "absent"
                           else "vehicle_attitude_setpoint has no yaw_body")


def test_missing_topic_exits_2_naming_it(tmp_path, capsys):
    _, cols = _flight()
    path = _ulog(tmp_path / "noesc.ulg", cols, esc=False)
    assert main(["replay", str(M300), str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "esc_status" in err and "rotor speeds" in err and str(path) in err


def test_collective_without_hover_thrust_exits_2(tmp_path, capsys):
    _, cols = _flight()
    path = _ulog(tmp_path / "nohover.ulg", cols, esc=False, thrust="attitude_setpoint", param=None)
    af_path = tmp_path / "coll.toml"
    af_path.write_text(dumps(airframe_dict(thrust={"source": "collective"}, mass=8.0)))
    assert main(["replay", str(af_path), str(path)]) == 2
    assert "MPC_THR_HOVER" in capsys.readouterr().err


def test_gap_marks_rows_and_the_estimate_recovers(tmp_path):
    # 1.2 s: beyond the longest silence replay bridges (dobwind/io/bridge.py, at most 1 s; tests/test_bridge.py
    # has the bridged ones), so the observer restarts after it.
    af, cols = _flight()
    model, flight, traj = replay_ulog(af, str(_ulog(tmp_path / "gap.ulg", cols, gap=(10.0, 11.2))), rate_hz=100.0)
    t = flight.log.time_s
    inside = (t > 10.02) & (t < 11.17)
    assert np.all(traj.status[inside] == STATUS_NO_DATA)
    # The note says which topic to log faster: the attitude alone went silent.
    note = next(n for n in flight.notes if "topic gap" in n)
    assert note.split("by topic: ")[1].startswith(f"vehicle_attitude {int(np.sum(traj.status == STATUS_NO_DATA))})")
    assert np.all(accepted(traj.status[t > 11.3])) and np.all(accepted(traj.status[(t > 1) & (t < 9.9)]))
    # Accepted but not trusted for one settling time after the start and after the gap, then trusted.
    settle = model.settling_time_s
    assert np.all(traj.status[(t > 11.3) & (t < 11.15 + settle)] == STATUS_SETTLING)
    assert np.all(traj.status[t > 11.3 + settle] == 0) and np.all(traj.status[(t > settle + 0.1) & (t < 9.9)] == 0)
    assert np.all(np.isfinite(traj.outputs))


def test_landed_rows_are_flagged_and_not_fed(tmp_path):
    af, cols = _flight()
    model, flight, traj = replay_ulog(af, str(_ulog(tmp_path / "land.ulg", cols, landed_until=3.0)))
    t = flight.log.time_s
    assert np.all(traj.status[t < 2.9] == STATUS_LANDED) and np.all(accepted(traj.status[t > 3.3]))
    assert np.all(traj.status[t > 3.3 + model.settling_time_s] == 0)


@pytest.mark.parametrize("damage", ["garbage", "truncated_header"])
def test_corrupt_file_exits_2_without_traceback(tmp_path, capsys, damage):
    path = tmp_path / "bad.ulg"
    path.write_bytes(os.urandom(4000) if damage == "garbage" else b"ULog\x01\x12\x35")
    assert main(["replay", str(M300), str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and "Traceback" not in err


def test_px4_wind_is_compared_and_plotted(tmp_path, capsys):
    af, cols = _flight()
    path = _ulog(tmp_path / "wind.ulg", cols, wind=True)
    plot = tmp_path / "wind.png"
    assert main(["replay", str(M300), str(path), "--plot", str(plot)]) == 0
    out = capsys.readouterr().out
    assert "PX4 wind: mean vector difference" in out and plot.read_bytes()[:4] == b"\x89PNG"


def test_real_sample_log(tmp_path, capsys):
    """The real VTOL hop (optional: skips without ../shared/data)."""
    if not SAMPLE.exists():
        pytest.skip("sample_log_small.ulg is not beside this checkout")
    af = tmp_path / "vtol.toml"
    af.write_text(dumps(airframe_dict(name="vtol", mass=6.0, thrust={"source": "collective"},
                                      **{"limits.max_dt": 0.2, "observer.sample_time": 0.01})))
    out = tmp_path / "est.csv"
    assert main(["replay", str(af), str(SAMPLE), "-o", str(out), "--json"]) == 0
    import json
    summary = json.loads(capsys.readouterr().out)
    # About 0.5 s airborne, at the observer's 100 Hz (the attitude's own clock was faster: more rows).
    assert summary["outputs_finite"] and summary["valid_rows"] > 40 and summary["px4"]["topic"] == "wind_estimate"
    assert len(out.read_text().splitlines()) == summary["rows"] + 1
    assert main(["replay", str(M300), str(SAMPLE)]) == 2
    assert "esc_status" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["sample_log_small.ulg", "sample_px4_events.ulg"])
def test_real_logs_give_no_valid_estimate_on_the_ground(tmp_path, name):
    """Independently of the reader: every instant where the raw vehicle_land_detected says landed,
    maybe_landed or ground_contact must not be an accepted estimate (optional: needs ../shared/data)."""
    path = SAMPLE.parent / name
    if not path.exists():
        pytest.skip(f"{name} is not beside this checkout")
    from pyulog import ULog

    af = parse_airframe(dumps(airframe_dict(name="quad", mass=2.0, thrust={"source": "collective"},
                                            **{"limits.max_dt": 0.2})), "<q>")
    _, flight, traj = replay_ulog(af, str(path))
    land = ULog(str(path), ["vehicle_land_detected"]).get_dataset("vehicle_land_detected").data
    lt = land["timestamp"] * 1e-6 - flight.t0_s
    ground = land["landed"] | land["maybe_landed"] | land["ground_contact"]
    t = flight.log.time_s
    idx = np.searchsorted(lt, t, side="right") - 1
    on_ground = (idx >= 0) & ground[np.clip(idx, 0, None)].astype(bool)
    assert on_ground.any() and not accepted(traj.status[on_ground]).any()


# --- corrupt files: no hang, one line or a clean result, stdout stays one JSON object -------------

def _corrupt_cases(tmp_path, good: bytes) -> list:
    import random

    rng = random.Random(16)
    # This seed's random bytes send pyulog's definitions reader seeking back and forth for ever.
    cases = [good[:16] + random.Random(0).randbytes(100_000)]
    for _ in range(5):
        flipped = bytearray(good)
        for _ in range(6):
            k = rng.randrange(16, len(flipped))
            flipped[k] ^= 1 << rng.randrange(8)
        cases.append(bytes(flipped))
    paths = []
    for i, blob in enumerate(cases):
        path = tmp_path / f"corrupt{i}.ulg"
        path.write_bytes(blob)
        paths.append(path)
    return paths


def test_corrupt_ulogs_end_quickly_with_one_line_or_one_json_object(tmp_path):
    import json
    import subprocess
    import sys
    import time

    af, cols = _flight(rate=50.0)
    good = _ulog(tmp_path / "good.ulg", cols).read_bytes()
    outcomes = set()
    for path in _corrupt_cases(tmp_path, good):
        start = time.monotonic()
        done = subprocess.run([sys.executable, "-m", "dobwind.cli", "replay", str(M300), str(path), "--json"],
                              capture_output=True, text=True, timeout=60)
        assert time.monotonic() - start < 30, path
        assert "Traceback" not in done.stderr
        if done.returncode == 0:
            # A damaged length field can make the file end inside a message: a warning line, no more.
            assert isinstance(json.loads(done.stdout), dict)
            assert all(line.startswith("dobwind replay: warning:") for line in done.stderr.splitlines())
        else:
            assert done.returncode == 2 and done.stdout == "" and done.stderr.count("\n") == 1, done.stderr
            assert str(path) in done.stderr
        outcomes.add(done.returncode)
    assert 2 in outcomes  # the random tail at least is refused


def test_the_read_budget_stops_pyulogs_endless_loop(tmp_path):
    from dobwind.core.errors import InputError
    from dobwind.io.ulog import open_ulog
    import random
    import time

    good = _ulog(tmp_path / "good.ulg", _flight(rate=50.0)[1]).read_bytes()
    path = tmp_path / "loop.ulg"
    path.write_bytes(good[:16] + random.Random(0).randbytes(100_000))
    start = time.monotonic()
    with pytest.raises(InputError, match="made no progress"):
        open_ulog(str(path))
    assert time.monotonic() - start < 20


def test_report_compares_with_px4_wind_when_the_log_has_no_truth(tmp_path, capsys, shared_figures):
    _, cols = _flight(rate=50.0)
    path = _ulog(tmp_path / "wind.ulg", cols, wind=True)
    page = tmp_path / "report.html"
    assert main(["report", str(M300), str(path), "-o", str(page)]) == 0
    text = page.read_text()
    assert "compared with the autopilot" in text and "mean_vector_difference_mps" in text
    assert text.count("data:image/png;base64,") >= 3


# --- issue 14: what real PX4 logs showed -------------------------------------------------------------

def test_escs_reporting_nothing_are_missing_data_named(tmp_path, capsys):
    """esc_count 0 and every rpm 0 (a real FMU-v5 log): not rotor speeds. No valid estimate, and the
    note names the ESCs and why."""
    af, cols = _flight()
    dead = {**cols, **{f"rpm_{i}": np.zeros_like(cols["t"]) for i in range(1, 5)}}
    _, flight, traj = replay_ulog(af, str(_ulog(tmp_path / "dead.ulg", dead, esc_count=0)))
    assert not accepted(traj.status).any() and np.all(traj.status == STATUS_NO_DATA)
    note = next(n for n in flight.notes if "esc_status" in n)
    assert all(f"ESC {i} (offline)" in note for i in range(1, 5)) and f"{flight.log.rows} of {flight.log.rows}" in note


def test_one_esc_at_zero_rpm_in_flight_blanks_only_those_rows(tmp_path):
    af, cols = _flight()
    stalled = dict(cols)
    stalled["rpm_2"] = np.where((cols["t"] > 6.0) & (cols["t"] < 7.0), 0.0, cols["rpm_2"])
    _, flight, traj = replay_ulog(af, str(_ulog(tmp_path / "stall.ulg", stalled)))
    t = flight.log.time_s
    assert np.all(traj.status[(t > 6.02) & (t < 6.98)] == STATUS_NO_DATA)
    assert np.all(accepted(traj.status[(t < 5.98) | (t > 7.02)]))
    assert any("ESC 2 (0 rpm)" in n and "ESC 1" not in n for n in flight.notes)


def test_ground_contact_and_maybe_landed_are_flagged_landed(tmp_path):
    """landed clears at 1 s but ground contact lasts to 3 s and maybe_landed to 2 s: on the ground to 3 s."""
    af, cols = _flight()
    path = _ulog(tmp_path / "hop.ulg", cols, landed_until=1.0, land_flags={"maybe_landed": 2.0, "ground_contact": 3.0})
    _, flight, traj = replay_ulog(af, str(path))
    t = flight.log.time_s
    assert np.all(traj.status[t < 2.95] == STATUS_LANDED) and np.all(accepted(traj.status[t > 3.25]))
    assert any("ground_contact" in n and "maybe_landed" in n for n in flight.notes)


def test_truncated_ulog_replays_the_readable_part_with_a_warning(tmp_path, capsys):
    _, cols = _flight()
    whole = _ulog(tmp_path / "whole.ulg", cols)
    path = tmp_path / "cut.ulg"
    path.write_bytes(whole.read_bytes()[: len(whole.read_bytes()) * 2 // 3 + 7])  # mid-message
    assert main(["replay", str(M300), str(path), "--json"]) == 0
    captured = capsys.readouterr()
    import json
    summary = json.loads(captured.out)
    assert captured.err.count("\n") == 1 and "warning" in captured.err and "truncated" in captured.err
    assert str(path) in captured.err and summary["warnings"]
    assert 0.5 * cols["t"][-1] < summary["duration_s"] < 0.75 * cols["t"][-1]  # about two thirds of the flight
    assert main(["replay", str(M300), str(whole)]) == 0 and capsys.readouterr().err == ""


def test_esc_status_at_4_hz_is_interpolated_not_no_data(tmp_path):
    """Rotor speeds reported every 0.25 s (PX4 SITL) against max_dt 0.1: interpolated, every row fed;
    a longer silence than ROTOR_MAX_GAP_S is still NO_DATA."""
    from dobwind.io.resample import ROTOR_MAX_GAP_S

    af, cols = _flight()
    model, flight, slow = replay_ulog(af, str(_ulog(tmp_path / "slow.ulg", cols, esc_every=25)))
    _, _, fast = replay_ulog(af, str(_ulog(tmp_path / "fast.ulg", cols)))
    t = flight.log.time_s
    assert np.all(accepted(slow.status[t < t[-1] - 0.25]))
    wind = model.outputs.slice("wind_ned")
    # The tunnel's rpm steps between holds: the 0.25 s interpolation smears each step, the holds agree.
    settled = (t % 4.0 > 3.0)  # the slow log ends at its last ESC report: the fast one's first rows match
    np.testing.assert_allclose(slow.outputs[settled, wind], fast.outputs[:len(t)][settled, wind], atol=0.15)
    _, flight2, gap = replay_ulog(af, str(_ulog(tmp_path / "silent.ulg", cols, esc_gap=(6.0, 6.0 + ROTOR_MAX_GAP_S + 0.1))))
    t2 = flight2.log.time_s
    assert np.all(gap.status[(t2 > 6.02) & (t2 < 6.0 + ROTOR_MAX_GAP_S + 0.08)] == STATUS_NO_DATA)
    assert any(n.endswith(f"by topic: esc_status {int(np.sum(gap.status == STATUS_NO_DATA))}): status NO_DATA")
               for n in flight2.notes)
    assert np.all(accepted(gap.status[(t2 > 1.0) & (t2 < 5.98)]))


def test_px4_wind_file_holds_the_estimate_and_its_variances(tmp_path, capsys):
    af, cols = _flight()
    path = _ulog(tmp_path / "f.ulg", cols)
    est, px4 = tmp_path / "est.csv", tmp_path / "px4wind.csv"
    # An uncertainty table constant at 0.2 m/s: every variance is 0.04 m²/s².
    airframe = tmp_path / "m300_unc.toml"
    airframe.write_text(M300.read_text() + "\n[uncertainty]\nspeeds = [0.0, 20.0]\nsigma_h = [0.2, 0.2]\n"
                                           "sigma_up = [0.1, 0.1]\n")
    assert main(["replay", str(airframe), str(path), "-o", str(est), "--px4-wind", str(px4)]) == 0
    e = np.genfromtxt(est, delimiter=",", names=True)
    w = np.genfromtxt(px4, delimiter=",", names=True, skip_header=1)
    ok = (e["status"].astype(int) & 0x33F) == 0
    assert len(w) == ok.sum() > 100
    # The ULog's clock starts at 1 s (1_000_000 us): both files keep the log's own clock.
    assert e["t"][0] == 1.0
    np.testing.assert_allclose(w["timestamp"], e["t"][ok] * 1e6, atol=1.0)
    np.testing.assert_allclose(w["windspeed_north"], e["wind_n"][ok], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(w["windspeed_east"], e["wind_e"][ok], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(w["variance_north"], 0.04, rtol=1e-5)
    np.testing.assert_array_equal(w["variance_north"], w["variance_east"])
    # With an observer noise of 0.15 m/s beside the table: 0.2² + 0.15² = 0.0625 m²/s² (a 0.25 m/s sigma).
    airframe.write_text(airframe.read_text().replace("sigma_up = [0.1, 0.1]\n", "sigma_up = [0.1, 0.1]\nnoise_h = 0.15\n"))
    assert main(["replay", str(airframe), str(path), "--px4-wind", str(px4)]) == 0
    np.testing.assert_allclose(np.genfromtxt(px4, delimiter=",", names=True, skip_header=1)["variance_north"], 0.0625,
                               rtol=1e-5)
    # Without the table the sigma is unknown: NaN variances, not a fake confidence.
    assert main(["replay", str(M300), str(path), "--px4-wind", str(px4)]) == 0
    assert np.all(np.isnan(np.genfromtxt(px4, delimiter=",", names=True, skip_header=1)["variance_north"]))


def test_px4_wind_refused_for_csv_logs(tmp_path, capsys):
    _, cols = _flight()
    assert main(["replay", str(M300), str(_csv(tmp_path / "a.csv", cols)), "--px4-wind", str(tmp_path / "w.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--px4-wind" in err



@pytest.mark.parametrize("variant", ["rpm, ned acceleration, wind", "collective, specific force, estimator_states",
                                     "rpm, ned acceleration, wind_estimate"])
def test_only_the_topics_read_are_parsed_and_the_flight_is_the_same(tmp_path, monkeypatch, variant):
    """pyulog is given ulog.TOPICS_READ: a topic nobody reads is not parsed, and the flight is the same,
    array for array, as from a parse of every topic (so every topic the module reads is in the list;
    the two variants between them read every one)."""
    import pyulog

    from dobwind.io import ulog

    af, cols = _flight()
    specific = variant.startswith("collective")
    if specific:
        af = parse_airframe(dumps(airframe_dict(thrust={"source": "collective"}, mass=8.0, name="coll",
                                                **{"observer.force_offset": [0.0, 0.0, 0.0],
                                                   "observer.acceleration": "specific_force"})), "<sf>")
    gyro = Topic("sensor_gyro", [("uint64_t", "timestamp"), ("float[3]", "xyz")],
                 _rows(cols, ["acc_n", "acc_e", "acc_d"], [f"xyz[{i}]" for i in range(3)]))
    path = _ulog(tmp_path / "f.ulg", cols, wind=variant.split(", ")[-1], landed_until=1.0,
                 extra=[gyro], sensor=specific, thrust="thrust_setpoint" if specific else None,
                 hover=0.5 if specific else None)
    parsed: list[set[str]] = []
    real_ulog = pyulog.ULog

    def spy(*args, **kwargs):
        log = real_ulog(*args, **kwargs)
        parsed.append({d.name for d in log.data_list})
        return log

    monkeypatch.setattr(pyulog, "ULog", spy)
    filtered = ulog.read_ulog(str(path), af)
    monkeypatch.setattr(ulog.open_ulog_noted, "__defaults__", (None,))  # every topic
    whole = ulog.read_ulog(str(path), af)
    assert "sensor_gyro" in parsed[1] and "sensor_gyro" not in parsed[0]
    assert parsed[1] - parsed[0] == {"sensor_gyro"}
    assert set(whole.log.columns) == set(filtered.log.columns)
    for key in whole.log.columns:
        np.testing.assert_array_equal(filtered.log.columns[key], whole.log.columns[key])
    np.testing.assert_array_equal(filtered.no_data, whole.no_data)
    np.testing.assert_array_equal(filtered.landed, whole.landed)
    assert filtered.notes == whole.notes and filtered.px4_wind is not None
