"""Logs of older PX4 and ArduPilot versions (issue #36; docs/autopilot-logs.md, *Versions the readers
accept*): the same simulated flight written in each layout must replay to the same inputs and the same
estimate as in the current layout, inspect and init must name the source they took, and a layout the
readers do not know must end in one stderr line and exit 2. Every log here is written by the test."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.inspect.anylog import inspect_log
from dobwind.inspect.initframe import build_airframe
from dobwind.io.autopilot import read_autopilot
from dobwind.replay.replay import replay, replay_autopilot, replay_ulog
from tests import test_dataflash as df
from tests import test_inspect as ti
from tests.dataflash_writer import write_dataflash
from tests.helpers import M300
from tests.test_ulog import _collective, _flight, _rows
from tests.ulog_writer import Topic, write_ulog

pytest.importorskip("pyulog")

HOVER = 0.42
MG = 8.0 * 9.80665  # the collective airframe's weight (test_ulog._collective)
STAMP = [("uint64_t", "timestamp")]


def _normalised(cols) -> np.ndarray:
    """The collective thrust as PX4 logs it: m g at the hover thrust, upward positive."""
    return cols["thrust"] / MG * HOVER


def _px4_layout(path, cols, layout: str, extra: tuple[Topic, ...] = (), params: dict | None = None):
    """The flight in one PX4 layout. v1.14: vehicle_thrust_setpoint.xyz[2] (negative up) scaled by
    hover_thrust_estimate; v1.12: actuator_controls_0.control[3] (positive up), the attitude setpoint
    without a thrust field; v1.8: vehicle_attitude_setpoint.thrust (a positive scalar), no
    hover_thrust_estimate (PX4 before v1.11: MPC_THR_HOVER, set to the same value). Every layout logs
    yaw_body, so the heading frame is the same."""
    up = _normalised(cols)
    stamps = [{"timestamp": r["timestamp"]} for r in _rows(cols, [], [])]
    topics = [
        Topic("vehicle_local_position", STAMP + [("float", f) for f in ("vx", "vy", "vz", "ax", "ay", "az")],
              _rows(cols, ["vel_n", "vel_e", "vel_d", "acc_n", "acc_e", "acc_d"], ["vx", "vy", "vz", "ax", "ay", "az"])),
        Topic("vehicle_attitude", STAMP + [("float[4]", "q")],
              _rows(cols, ["q_w", "q_x", "q_y", "q_z"], [f"q[{i}]" for i in range(4)])),
    ]
    yaw = _rows(cols, ["yaw_ref"], ["yaw_body"])
    if layout == "v1.8":
        topics.append(Topic("vehicle_attitude_setpoint", STAMP + [("float", "roll_body"), ("float", "yaw_body"),
                                                                  ("float", "thrust")],
                            [dict(r, thrust=u) for r, u in zip(yaw, up)]))
    else:
        topics.append(Topic("vehicle_attitude_setpoint", STAMP + [("float", "yaw_body"), ("float[4]", "q_d")], yaw))
        topics.append(Topic("hover_thrust_estimate", STAMP + [("float", "hover_thrust")],
                            [dict(s, hover_thrust=HOVER) for s in stamps[::50]]))
    if layout == "v1.14":
        topics.append(Topic("vehicle_thrust_setpoint", STAMP + [("float[3]", "xyz")],
                            [dict(s, **{"xyz[2]": -u}) for s, u in zip(stamps, up)]))
    elif layout == "v1.12":
        topics.append(Topic("actuator_controls_0", STAMP + [("float[8]", "control")],
                            [dict(s, **{"control[3]": u}) for s, u in zip(stamps, up)]))
    return write_ulog(path, topics + list(extra), {"MPC_THR_HOVER": HOVER, **(params or {})})


@pytest.fixture(scope="module")
def px4_flight(tmp_path_factory):
    """The flight in the v1.14 layout, replayed once: the reference every older layout must equal."""
    _, cols = _flight()
    path = _px4_layout(tmp_path_factory.mktemp("v114") / "v114.ulg", cols, "v1.14")
    return cols, replay_ulog(_collective(), str(path), rate_hz=100.0)


@pytest.mark.parametrize("layout, source", [("v1.12", "actuator_controls_0.control[3]"),
                                            ("v1.8", "vehicle_attitude_setpoint.thrust")])
def test_an_older_px4_layout_replays_to_the_same_inputs_and_estimate(tmp_path, px4_flight, layout, source):
    cols, (_, ref_flight, ref) = px4_flight
    _, flight, traj = replay_ulog(_collective(), str(_px4_layout(tmp_path / "old.ulg", cols, layout)), rate_hz=100.0)
    for key in ("vel_n", "vel_e", "vel_d", "acc_d", "q_w", "q_z", "thrust", "yaw_ref"):
        np.testing.assert_array_equal(flight.log.columns[key], ref_flight.log.columns[key], err_msg=key)
    np.testing.assert_array_equal(traj.status, ref.status)
    np.testing.assert_array_equal(traj.outputs, ref.outputs)
    # The thrust is the simulated one (not merely equal to the reference): m g x setpoint / hover.
    np.testing.assert_allclose(flight.log.columns["thrust"][5:-5], cols["thrust"][5:-5], rtol=1e-5)
    said = " ".join(flight.notes)
    assert f"collective thrust from {source}:" in said, said
    assert ("MPC_THR_HOVER parameter" in said) == (layout == "v1.8"), said


def test_inspect_and_init_name_an_older_thrust_source(tmp_path, capsys):
    """inspect's thrust role is the source replay takes, with what it is; init's reason names it."""
    t = ti._stamps(50.0)
    topics = [
        ti._topic("vehicle_local_position", [("float", f) for f in ("vx", "vy", "vz", "ax", "ay", "az")],
                  ti._stamps(10.0), lambda s: {"vx": 1.0}),
        ti._topic("vehicle_attitude", [("float[4]", "q")], t, lambda s: {"q[0]": 1.0}),
        ti._topic("actuator_controls_0", [("float[8]", "control")], t, lambda s: {"control[3]": 0.5}),
        ti._topic("vehicle_land_detected", [("bool", "landed")], ti._stamps(1.0), lambda s: {"landed": not ti._airborne(s)}),
    ]
    log = write_ulog(tmp_path / "v112.ulg", topics, {"MPC_THR_HOVER": 0.5, "CA_ROTOR_COUNT": 4.0})
    summary = inspect_log(str(log))
    thrust = summary.role("thrust")
    assert thrust.source == "actuator_controls_0.control[3]" and "before the mixer" in thrust.note, thrust
    assert summary.missing() == []
    text, choices, _ = build_airframe(str(log), 2.0, str(tmp_path / "v.toml"))
    assert choices.thrust_source == "collective" and "actuator_controls_0.control[3]" in choices.thrust_reason
    assert "before the mixer" in choices.thrust_reason and "before the mixer" in text
    assert main(["inspect", str(log)]) == 0
    assert "actuator_controls_0.control[3]" in capsys.readouterr().out


def test_the_battery_scale_is_named_only_where_px4_applied_it(tmp_path, px4_flight):
    """MC_BAT_SCALE_EN set: the rate controller's actuator_controls_0 carries the scale, the attitude
    setpoint's thrust does not; the note names the first and not the second."""
    cols, _ = px4_flight
    for layout, named in (("v1.12", True), ("v1.8", False)):
        path = _px4_layout(tmp_path / f"{layout}.ulg", cols, layout, params={"MC_BAT_SCALE_EN": 1.0})
        _, flight, _ = replay_ulog(_collective(), str(path), rate_hz=100.0)
        assert any("MC_BAT_SCALE_EN is set" in n for n in flight.notes) == named, flight.notes
        role = inspect_log(str(path)).role("thrust")
        assert ("battery scale" in role.note) == named, role


def _single_thrust_setpoint(cols) -> Topic:
    """vehicle_thrust_setpoint with one message: too short to read, as the readers require two."""
    return Topic("vehicle_thrust_setpoint", STAMP + [("float[3]", "xyz")],
                 [dict(r, **{"xyz[2]": -HOVER}) for r in _rows(cols, [], [])[:1]])


@pytest.mark.parametrize("layout, extra", [("v1.14", False), ("v1.12", False), ("v1.8", False), ("v1.12", True)])
def test_inspect_takes_the_thrust_source_replay_takes(tmp_path, px4_flight, layout, extra):
    """On every PX4 layout built here (and v1.12 with a one-message vehicle_thrust_setpoint, which the
    readers skip), inspect's thrust role and the setpoint its airborne spans come from (no
    vehicle_land_detected in these logs) are the source replay's note names."""
    cols, _ = px4_flight
    path = _px4_layout(tmp_path / "l.ulg", cols, layout, extra=(_single_thrust_setpoint(cols),) if extra else ())
    _, flight, _ = replay_ulog(_collective(), str(path), rate_hz=100.0)
    taken = [n.split(" ")[3].rstrip(":") for n in flight.notes if n.startswith("collective thrust from ")]
    summary = inspect_log(str(path))
    assert len(taken) == 1 and summary.role("thrust").source == taken[0], (taken, summary.role("thrust"))
    assert summary.airborne_source == f"{taken[0]} above half the hover thrust (no vehicle_land_detected)"


def _one_line(capsys, *needles: str) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and all(n in err for n in needles), err
    return err


def test_a_px4_field_layout_the_reader_does_not_know_is_one_line_exit_2(tmp_path, capsys):
    """vehicle_local_position logged with renamed velocity fields: the line names the topic and the
    field it lacks, not a missing topic."""
    _, cols = _flight()
    renamed = Topic("vehicle_local_position", STAMP + [("float", f) for f in ("vel_n", "vel_e", "vel_d")],
                    _rows(cols, ["vel_n", "vel_e", "vel_d"], ["vel_n", "vel_e", "vel_d"]))
    topics = [renamed, Topic("vehicle_attitude", STAMP + [("float[4]", "q")],
                             _rows(cols, ["q_w", "q_x", "q_y", "q_z"], [f"q[{i}]" for i in range(4)]))]
    path = write_ulog(tmp_path / "renamed.ulg", topics)
    assert main(["replay", str(M300), str(path)]) == 2
    _one_line(capsys, str(path), "vehicle_local_position", "without field vx, vy, vz", "layout")


def test_mixer_outputs_are_refused_as_a_collective_thrust_in_one_line(tmp_path, capsys):
    """A collective airframe on a log whose only throttle is the mixer's per-motor output: refused, the
    line naming that topic as not read."""
    _, cols = _flight()
    motors = Topic("actuator_outputs", STAMP + [("float[16]", "output")],
                   [dict(r, **{f"output[{i}]": 1500.0 for i in range(4)}) for r in _rows(cols, [], [])])
    path = _px4_layout(tmp_path / "mixer.ulg", cols, "none", extra=(motors,))
    af = tmp_path / "coll.toml"
    from dobwind.model.airframe_toml import dumps
    from tests.helpers import airframe_dict
    af.write_text(dumps(airframe_dict(thrust={"source": "collective"}, mass=8.0)))
    assert main(["replay", str(af), str(path)]) == 2
    _one_line(capsys, "actuator_controls_0.control[3]", "actuator_outputs is logged", "not read")


# ---- ArduPilot: the per-core and per-ESC names of firmware before 4.1 ----

OLD_EKF3 = {("XKF1", 0): "XKF1", ("XKF1", 1): "XKF6", ("XKQ", 0): "XKQ1", ("XKQ", 1): "XKQ2",
            ("XKF2", 0): "XKF2", ("XKF2", 1): "XKF7", ("XKF4", 0): "XKF4", ("XKF4", 1): "XKF9"}
EKF2_NAMES = {"XKF1": "NKF1", "XKQ": "NKQ", "XKF2": "NKF2", "XKF4": "NKF4"}
OLD_EKF2 = {(EKF2_NAMES[new], core): old.replace("X", "N") for (new, core), old in OLD_EKF3.items()}


def _ekf2(messages: dict, rows: list) -> tuple[dict, list]:
    """The same log with EKF2's names in 4.1's layout (NKF1, NKQ, NKF2, NKF4 with field C)."""
    return ({EKF2_NAMES.get(n, n): m for n, m in messages.items()}, [(EKF2_NAMES.get(n, n), v) for n, v in rows])


def _pre41(messages: dict, rows: list, names: dict | None = None) -> tuple[dict, list]:
    """The same log as ArduPilot 4.0 writes it: one name per EKF core (no field C) and per ESC (no
    field Instance), the IMU's second instance as IMU2. ``names``: OLD_EKF3 (default) or OLD_EKF2."""
    names = names or OLD_EKF3
    out_msgs = {}
    for name, (fmt, columns) in messages.items():
        if "C" in columns:
            for (new, core), old in names.items():
                if new == name:
                    out_msgs[old] = (fmt.replace("B", "", 1), [c for c in columns if c != "C"])
        elif name == "ESC":
            for k in range(4):
                out_msgs[f"ESC{k + 1}"] = (fmt.replace("B", "", 1), [c for c in columns if c != "Instance"])
        elif name == "IMU":
            out_msgs["IMU"] = out_msgs["IMU2"] = (fmt.replace("B", "", 1), [c for c in columns if c != "I"])
        else:
            out_msgs[name] = (fmt, columns)
    out_rows = []
    for name, v in rows:
        if "C" in v:
            name, v = names[(name, v["C"])], {k: x for k, x in v.items() if k != "C"}
        elif name == "ESC":
            name, v = f"ESC{v['Instance'] + 1}", {k: x for k, x in v.items() if k != "Instance"}
        elif name == "IMU":
            name, v = ("IMU" if v["I"] == 0 else "IMU2"), {k: x for k, x in v.items() if k != "I"}
        out_rows.append((name, v))
    return out_msgs, out_rows


def test_an_ardupilot_40_layout_replays_as_its_41_twin(tmp_path):
    """XKF1/XKF6, XKQ1/XKQ2, XKF2/XKF7 and ESC1..ESC4 (core 1 and IMU2 holding nonsense): the same
    inputs and estimate as the 4.1 layout, and the note names what was relabelled."""
    af, cols = df._flight()
    rows = df._rows(af, cols)
    new = replay_autopilot(af, str(write_dataflash(tmp_path / "new.bin", df.MESSAGES, rows)), rate_hz=50.0)
    old = replay_autopilot(af, str(write_dataflash(tmp_path / "old.bin", *_pre41(df.MESSAGES, rows))), rate_hz=50.0)
    for key in new[1].log.columns:
        np.testing.assert_array_equal(old[1].log.columns[key], new[1].log.columns[key], err_msg=key)
    np.testing.assert_array_equal(old[2].outputs, new[2].outputs)
    assert old[1].autopilot_wind[0] == "ArduPilot XKF2"
    np.testing.assert_allclose(old[1].autopilot_wind[2][:, 0], df.f32(cols["wind_n"]), atol=1e-6)
    said = " ".join(old[1].notes)
    assert "XKQ1 as XKQ C 0" in said and "XKF6 as XKF1 C 1" in said and "ESC1, ESC2, ESC3, ESC4 as ESC Instance 0, 1, 2, 3" in said


@pytest.mark.parametrize("layout", ["EKF3 before 4.1", "EKF2", "EKF2 before 4.1"])
def test_a_lane_switch_is_followed_in_every_ekf_layout(tmp_path, layout):
    """From 9 s core 1 holds the good data and the PI of XKF4 (XKF4/XKF9 before 4.1; EKF2: NKF4, or
    NKF4/NKF9) says it is primary: the replay equals the equivalent CSV, as for the EKF3 4.1 layout's
    lane switch (test_dataflash). Core 0 holds fifty times the north velocity after the switch."""
    af, cols = df._flight()
    messages = dict(df.MESSAGES, XKF4=("QBB", ["TimeUS", "C", "PI"]))
    log = (messages, df._switch_primary(df._rows(af, cols), 9_000_000, with_xkf4=True))
    if layout.startswith("EKF2"):
        log = _ekf2(*log)
    if layout.endswith("before 4.1"):
        log = _pre41(*log, names=OLD_EKF2 if layout.startswith("EKF2") else OLD_EKF3)
    _, flight, traj = replay_autopilot(af, str(write_dataflash(tmp_path / "s.bin", *log)), rate_hz=50.0)
    _, ref_log, ref = replay(af, str(df._equivalent_csv(tmp_path / "s.csv", af, cols)))
    assert flight.log.rows == ref_log.rows
    assert np.max(np.abs(traj.outputs - ref.outputs)) <= 1e-5
    ekf, marker = ("EKF2", "NKF4") if layout.startswith("EKF2") else ("EKF3", "XKF4")
    assert any(f"{ekf} primary core from {marker}.PI: 1 switch(es) among cores 0, 1" in n for n in flight.notes)
    # Replay names the streams as the log does: both cores' quaternion messages were read.
    quaternion = {"EKF3 before 4.1": "XKQ1/XKQ2", "EKF2": "NKQ", "EKF2 before 4.1": "NKQ1/NKQ2"}[layout]
    assert quaternion in [name for name, _, _ in flight.silences], flight.silences


def test_inspect_and_init_name_the_relabelled_ardupilot_messages(tmp_path):
    af, cols = df._flight(rate=20.0)
    path = write_dataflash(tmp_path / "old.bin", *_pre41(df.MESSAGES, df._rows(af, cols)))
    s = inspect_log(str(path))
    # The roles name the messages as the log holds them, read under the 4.1 names.
    assert s.role("attitude").source == "XKQ1.Q1..Q4" and s.role("velocity").source == "XKF1.VN..VD"
    assert s.role("rpm").source == "ESC1/ESC2/ESC3/ESC4.RPM" and s.role("autopilot_wind").source == "XKF2.VWN..VWE"
    assert s.vehicle.rotors == 4 and s.missing() == []
    assert any("XKQ1 as XKQ C 0" in n for n in s.notes), s.notes
    text, _, _ = build_airframe(str(path), 3.0, str(tmp_path / "v.toml"))
    assert "# layout: an older ArduPilot layout" in text and "ESC1, ESC2, ESC3, ESC4 as ESC Instance" in text
    # The 4.1 layout's starter says nothing of the sort.
    current, _, _ = build_airframe(str(write_dataflash(tmp_path / "new.bin", df.MESSAGES, df._rows(af, cols))), 3.0,
                                   str(tmp_path / "w.toml"))
    assert "# layout:" not in current


def test_an_ardupilot_field_layout_the_reader_does_not_know_is_one_line_exit_2(tmp_path, capsys):
    af, cols = df._flight(rate=20.0)
    messages = dict(df.MESSAGES, XKF1=("QBfff", ["TimeUS", "C", "VelN", "VelE", "VelD"]))
    rows = [(n, {"TimeUS": v["TimeUS"], "C": v["C"], "VelN": v["VN"], "VelE": v["VE"], "VelD": v["VD"]})
            if n == "XKF1" else (n, v) for n, v in df._rows(af, cols)]
    path = write_dataflash(tmp_path / "renamed.bin", messages, rows)
    assert main(["replay", str(M300), str(path)]) == 2
    _one_line(capsys, str(path), "message XKF1", "without field VN, VE, VD", "layout")
    with pytest.raises(Exception, match="XKF1"):
        read_autopilot(str(path), af)


# ---- ROS 2 bags of PX4 v1.13 and earlier: the microRTPS bridge's topic names and VehicleOdometry ----

# px4_msgs' VehicleOdometry before v1.14, reduced to what the reader reads: vx vy vz and frames numbered
# from LOCAL_FRAME_NED = 0 (v1.14: velocity[3], VELOCITY_FRAME_NED = 1).
OLD_ODOMETRY = ("uint64 timestamp\nuint64 timestamp_sample\nuint8 LOCAL_FRAME_NED=0\nuint8 BODY_FRAME_FRD=3\n"
                "uint8 local_frame\nfloat32 x\nfloat32 y\nfloat32 z\nfloat32[4] q\nuint8 velocity_frame\n"
                "float32 vx\nfloat32 vy\nfloat32 vz\n")


def _micrortps(src, dst, frame: int = 0):
    """The bag ``src`` (test_rosbag._px4_bag) as the microRTPS bridge of PX4 v1.13 wrote it: every
    /fmu/out/NAME as /fmu/NAME/out, vehicle_odometry in the old layout with velocity_frame ``frame``: 0
    NED; 3 body FRD (the velocity rotated into the body); 1 an earth FRD frame of arbitrary heading (the
    NED values, labelled so). The other messages are copied byte for byte."""
    from rosbags.rosbag2 import Reader, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from dobwind.io.rosbag import _typestore, rotate

    old = get_typestore(Stores.ROS2_HUMBLE)
    old.register(get_types_from_msg(OLD_ODOMETRY, "px4_msgs/msg/VehicleOdometry"))
    with Reader(src) as reader, Writer(dst, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        store = _typestore(str(src), reader.connections)
        out = {}
        for conn in reader.connections:
            name = "/fmu/" + conn.topic[len("/fmu/out/"):] + "/out"
            out[conn.id] = writer.add_connection(name, conn.msgtype, typestore=old if "odometry" in name else store)
        for conn, stamp, raw in reader.messages():
            if "odometry" in conn.topic:
                m = store.deserialize_cdr(raw, conn.msgtype)
                v = np.asarray(m.velocity, dtype=np.float32)
                if frame == 3:  # the same velocity, expressed in the body frame (q: body to NED)
                    q = np.asarray(m.q, dtype=float)
                    v = rotate(q[None] * np.array([1.0, -1.0, -1.0, -1.0]), v[None].astype(float))[0].astype(np.float32)
                msg = old.types["px4_msgs/msg/VehicleOdometry"](m.timestamp, m.timestamp_sample, 0, 0.0, 0.0, 0.0,
                                                                 m.q, frame, *v)
                raw = old.serialize_cdr(msg, msg.__msgtype__)
            writer.write(out[conn.id], stamp, raw)
    return dst


@pytest.mark.parametrize("frame", [0, 3])
def test_a_px4_113_micrortps_bag_replays_as_the_current_layout(tmp_path, frame):
    pytest.importorskip("rosbags")
    from tests import test_rosbag as rb

    af, cols = rb._flight()
    current = rb._px4_bag(tmp_path / "current", af, cols, "mcap")
    _, ref_flight, ref = replay_autopilot(af, str(current), rate_hz=50.0)
    _, flight, traj = replay_autopilot(af, str(_micrortps(current, tmp_path / "rtps", frame)), rate_hz=50.0)
    assert np.all(traj.status == ref.status)
    tolerance = 1e-5 if frame == 3 else 0.0  # NED: the same float32 values; body: rotated there and back
    assert np.max(np.abs(traj.outputs - ref.outputs)) <= tolerance
    assert any("velocity /fmu/vehicle_odometry/out" in n for n in flight.notes), flight.notes


def test_an_old_odometry_frame_without_a_heading_is_one_line_exit_2(tmp_path, capsys):
    """px4_msgs before v1.14, velocity_frame 1 (LOCAL_FRAME_FRD: an arbitrary heading): refused in one
    line naming the field and the frames that can be read, never read as NED (1 is NED in v1.14)."""
    pytest.importorskip("rosbags")
    from tests import test_rosbag as rb

    af, cols = rb._flight()
    bag = _micrortps(rb._px4_bag(tmp_path / "current", af, cols, "mcap"), tmp_path / "rtps", frame=1)
    assert main(["replay", str(M300), str(bag)]) == 2
    _one_line(capsys, "vehicle_odometry.velocity_frame", "is 1: only NED (0)", "before v1.14")


def test_esc_messages_stamped_in_milliseconds_replay_alike(tmp_path):
    """Older firmware stamped ESC1..ESC8 in TimeMS: read as TimeUS = 1000 TimeMS (the 20 Hz rows fall on
    whole milliseconds), the replay equals the one with microsecond stamps; never a KeyError."""
    af, cols = df._flight(rate=20.0)
    msgs, rows = _pre41(df.MESSAGES, df._rows(af, cols))
    micro = replay_autopilot(af, str(write_dataflash(tmp_path / "us.bin", msgs, rows)), rate_hz=20.0)[2]
    msgs = {**msgs, **{f"ESC{k}": ("If", ["TimeMS", "RPM"]) for k in range(1, 5)}}
    rows = [(n, {"TimeMS": v["TimeUS"] // 1000, "RPM": v["RPM"]} if n.startswith("ESC") else v) for n, v in rows]
    milli = replay_autopilot(af, str(write_dataflash(tmp_path / "ms.bin", msgs, rows)), rate_hz=20.0)[2]
    np.testing.assert_array_equal(milli.outputs, micro.outputs)


def _without_definitions(src, dst):
    """The bag ``src`` as rosbag2 before Iron stored it (sqlite3, no message definitions): what a
    microRTPS-era (PX4 v1.13, ROS 2 Foxy) recording holds."""
    import sqlite3

    from rosbags.rosbag2 import Reader, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from dobwind.io.rosbag import _typestore

    old = get_typestore(Stores.ROS2_HUMBLE)
    old.register(get_types_from_msg(OLD_ODOMETRY, "px4_msgs/msg/VehicleOdometry"))
    with Reader(src) as reader, Writer(dst, version=8, storage_plugin=StoragePlugin.SQLITE3) as writer:
        store = _typestore(str(src), reader.connections)
        ids = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=old if "odometry" in c.topic else store)
               for c in reader.connections}
        for conn, stamp, raw in reader.messages():
            writer.write(ids[conn.id], stamp, raw)
    with sqlite3.connect(next(dst.glob("*.db3"))) as db:
        db.execute("DELETE FROM message_definitions")
    return dst


def test_an_old_odometry_without_its_definition_names_the_topic_and_the_cause(tmp_path, capsys):
    """A v1.13 bag with no definitions of its own is decoded with the shipped (v1.14) px4_msgs, which
    its VehicleOdometry does not fit: one line naming the topic and that the bag carries no definition,
    not "not a readable ROS 2 bag"."""
    pytest.importorskip("rosbags")
    from tests import test_rosbag as rb

    af, cols = rb._flight()
    rtps = _micrortps(rb._px4_bag(tmp_path / "current", af, cols, "mcap"), tmp_path / "rtps")
    bag = _without_definitions(rtps, tmp_path / "foxy")
    assert main(["replay", str(M300), str(bag)]) == 2
    err = _one_line(capsys, "topic /fmu/vehicle_odometry/out", "px4_msgs/msg/VehicleOdometry", "carries none")
    assert "not a readable ROS 2 bag" not in err
