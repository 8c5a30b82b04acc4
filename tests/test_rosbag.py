"""ROS 2 bag replay (PX4 over XRCE-DDS and mavros), on bags written here with rosbags: the replay equals
the replay of the equivalent CSV (the bag's values on the bag's clock) within 1e-5."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("rosbags")

from rosbags.rosbag2 import StoragePlugin, Writer  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

from dobwind.cli.app import main  # noqa: E402
from dobwind.io.logs import write_csv  # noqa: E402
from dobwind.model.airframe import load_airframe  # noqa: E402
from dobwind.model.status import STATUS_LANDED, accepted  # noqa: E402
from dobwind.replay.replay import replay, replay_autopilot  # noqa: E402
from dobwind.io.rosbag import _typestore  # noqa: E402
from dobwind.simulate.simulate import simulate  # noqa: E402
from tests.helpers import M300  # noqa: E402

T0_US = 5_000_000
ENU_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # its own inverse
FLU_FRD = np.diag([1.0, -1.0, -1.0])


def _flight():
    """On a uniform clock (replay resamples onto one); tests comparing row for row replay at 50 Hz."""
    af = load_airframe(M300)
    cols = simulate(af, "tunnel", seed=5, hold_s=4.0, rate_hz=50.0)
    return af, {**cols, "t": np.arange(len(cols["t"])) / 50.0}


def _matrices(cols):
    return Rotation.from_quat(np.column_stack([cols["q_x"], cols["q_y"], cols["q_z"], cols["q_w"]])).as_matrix()


def _specific_force(af, cols):
    """Body FRD specific force from the simulated NED acceleration: R^T (a - g e3)."""
    acc = np.column_stack([cols["acc_n"], cols["acc_e"], cols["acc_d"] - af.gravity_mps2])
    return np.einsum("kji,kj->ki", _matrices(cols), acc)


def _writer(path, storage):
    return Writer(path, version=9, storage_plugin=StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3)


# A reduced vehicle_local_position for the writer: the reader must use the definition the bag stores
# (MCAP and rosbag2 v9 keep one per connection), since the message's layout changes between PX4 versions.
LOCAL_POSITION = "uint64 timestamp\nuint64 timestamp_sample\nbool v_xy_valid\nfloat32 vx\nfloat32 vy\nfloat32 vz\n"


def _px4_bag(path, af, cols, storage, *, esc=True, landed_until=None, hover=None, v1=(), local_position=False,
             converging_until: float = 0.0):
    """``converging_until``: hover_thrust_estimate reads 0.30, not valid, before this time (s), then ``hover``."""
    store = _typestore(str(path), [])
    if local_position:
        from rosbags.typesys import get_types_from_msg

        store.register(get_types_from_msg(LOCAL_POSITION, "px4_msgs/msg/VehicleLocalPosition"))
    T = store.types
    sf = _specific_force(af, cols).astype(np.float32)
    f = np.float32
    with _writer(path, storage) as w:
        conns = {r: w.add_connection(f"/fmu/out/{r}" + ("_v1" if r in v1 else ""), f"px4_msgs/msg/{m}", typestore=store)
                 for r, m in (
            ("vehicle_local_position", "VehicleLocalPosition") if local_position else ("vehicle_odometry", "VehicleOdometry"),
            ("vehicle_attitude", "VehicleAttitude"),
            ("sensor_combined", "SensorCombined"), ("wind", "Wind"), ("esc_status", "EscStatus"),
            ("vehicle_land_detected", "VehicleLandDetected"), ("vehicle_thrust_setpoint", "VehicleThrustSetpoint"),
            ("hover_thrust_estimate", "HoverThrustEstimate"))
            if (esc or r != "esc_status") and (landed_until is not None or r != "vehicle_land_detected")
            and (hover is not None or r not in ("vehicle_thrust_setpoint", "hover_thrust_estimate"))}
        for k, t in enumerate(cols["t"]):
            us = T0_US + int(round(t * 1e6))
            q = np.array([cols[f"q_{c}"][k] for c in "wxyz"], dtype=f)
            z3 = np.zeros(3, dtype=f)
            msgs = {
                "vehicle_odometry": T["px4_msgs/msg/VehicleOdometry"](
                    us, us, 1, z3, q, 1, np.array([cols["vel_n"][k], cols["vel_e"][k], cols["vel_d"][k]], dtype=f),
                    z3, z3, z3, z3, 0, 0),
                "vehicle_attitude": T["px4_msgs/msg/VehicleAttitude"](us, us, q, np.zeros(4, dtype=f), 0),
                "vehicle_local_position": T["px4_msgs/msg/VehicleLocalPosition"](
                    us, us, True, f(cols["vel_n"][k]), f(cols["vel_e"][k]), f(cols["vel_d"][k])) if local_position else None,
                "sensor_combined": T["px4_msgs/msg/SensorCombined"](us, z3, 0, 0, sf[k], 0, 0, 0, 0, 0),
                "wind": T["px4_msgs/msg/Wind"](us, us, f(cols["wind_n"][k]), f(cols["wind_e"][k]), 0, 0, 0, 0, 0, 0, 0),
            }
            if esc:
                reports = [T["px4_msgs/msg/EscReport"](us, 0, int(round(cols[f"rpm_{i + 1}"][k])) if i < 4 else 0,
                                                       0, 0, 0, 0, 0, 0, 0, 101 + i, 0, 0) for i in range(8)]
                msgs["esc_status"] = T["px4_msgs/msg/EscStatus"](us, k % 65536, 4, 0, 15, 15, reports)
            if hover is not None:
                xyz = np.array([0.0, 0.0, -cols["thrust"][k] / (af.mass_kg * af.gravity_mps2) * hover], dtype=f)
                msgs["vehicle_thrust_setpoint"] = T["px4_msgs/msg/VehicleThrustSetpoint"](us, us, xyz)
                if k % 10 == 0:
                    ready = bool(t >= converging_until)
                    msgs["hover_thrust_estimate"] = T["px4_msgs/msg/HoverThrustEstimate"](
                        us, us, f(hover if ready else 0.30), 0, 0, 0, 0, 0, ready)
            if landed_until is not None and k % 10 == 0:
                on = t < landed_until
                msgs["vehicle_land_detected"] = T["px4_msgs/msg/VehicleLandDetected"](us, on, on, on)
            for role, msg in msgs.items():
                if role in conns:
                    w.write(conns[role], us * 1000, store.serialize_cdr(msg, msg.__msgtype__))
    return path


def _mavros_bag(path, af, cols, storage, velocity_topic="/mavros/local_position/velocity_local"):
    store = _typestore(str(path), [])
    T = store.types
    r_enu_flu = np.einsum("ij,kjl,lm->kim", ENU_NED, _matrices(cols), FLU_FRD)
    q_enu = Rotation.from_matrix(r_enu_flu).as_quat()  # x y z w
    sf_flu = _specific_force(af, cols) @ FLU_FRD
    Time, Header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    V3, Tw = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Twist"]
    with _writer(path, storage) as w:
        c_vel = w.add_connection(velocity_topic, "geometry_msgs/msg/TwistStamped", typestore=store)
        c_imu = w.add_connection("/mavros/imu/data", "sensor_msgs/msg/Imu", typestore=store)
        c_esc = w.add_connection("/mavros/esc_status/status", "mavros_msgs/msg/ESCStatus", typestore=store)
        for k, t in enumerate(cols["t"]):
            ns = T0_US * 1000 + int(round(t * 1e9))
            h = Header(Time(ns // 1_000_000_000, ns % 1_000_000_000), "base_link")
            vel = T["geometry_msgs/msg/TwistStamped"](h, Tw(V3(cols["vel_e"][k], cols["vel_n"][k], -cols["vel_d"][k]), V3(0, 0, 0)))
            imu = T["sensor_msgs/msg/Imu"](h, T["geometry_msgs/msg/Quaternion"](*q_enu[k]), np.zeros(9), V3(0, 0, 0), np.zeros(9),
                                           V3(*sf_flu[k]), np.zeros(9))
            items = [T["mavros_msgs/msg/ESCStatusItem"](h, int(round(cols[f"rpm_{i + 1}"][k])), 0.0, 0.0) for i in range(4)]
            esc = T["mavros_msgs/msg/ESCStatus"](h, items)
            for conn, msg in ((c_vel, vel), (c_imu, imu), (c_esc, esc)):
                w.write(conn, ns, store.serialize_cdr(msg, msg.__msgtype__))
    return path


def _equivalent_csv(path, af, cols, single, hover=None):
    """The bag's values as a CSV: float32 for px4_msgs, whole rpm, normalised q, a = R sf + g e3."""
    cast = (lambda x: np.asarray(x, dtype=np.float32).astype(float)) if single else (lambda x: np.asarray(x, dtype=float))
    q = np.column_stack([cast(cols[f"q_{c}"]) for c in "wxyz"])
    q /= np.linalg.norm(q, axis=1)[:, None]
    sf = cast(_specific_force(af, cols))
    r = Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()
    acc = np.einsum("kij,kj->ki", r, sf) + np.array([0.0, 0.0, af.gravity_mps2])
    # px4_msgs stamp in microseconds, mavros headers in nanoseconds (as the bag writers above do).
    ticks = T0_US + np.round(cols["t"] * 1e6) if single else T0_US * 1000 + np.round(cols["t"] * 1e9)
    out = {"t": (ticks - ticks[0]) * (1e-6 if single else 1e-9), "vel_n": cast(cols["vel_n"]), "vel_e": cast(cols["vel_e"]), "vel_d": cast(cols["vel_d"]),
           "acc_n": acc[:, 0], "acc_e": acc[:, 1], "acc_d": acc[:, 2], **{f"q_{c}": q[:, i] for i, c in enumerate("wxyz")},
           **{f"rpm_{i}": np.round(cols[f"rpm_{i}"]) for i in range(1, 5)}}
    if hover is not None:  # newtons = m g (normalized setpoint) / (hover thrust), from the float32 fields
        setpoint = cast(cols["thrust"] / (af.mass_kg * af.gravity_mps2) * hover)
        out["thrust"] = af.mass_kg * af.gravity_mps2 * setpoint / cast(hover)
    names = list(out)
    write_csv(path, names, np.column_stack([out[n] for n in names]), ["%.17g"] * len(names))
    return path


@pytest.mark.parametrize("setup, storage", [("px4", "mcap"), ("px4", "db3"), ("mavros", "mcap"), ("mavros", "db3")])
def test_bag_replay_equals_the_equivalent_csv(tmp_path, setup, storage):
    af, cols = _flight()
    bag = tmp_path / f"{setup}_bag"
    (_px4_bag if setup == "px4" else _mavros_bag)(bag, af, cols, storage)
    model, flight, traj = replay_autopilot(af, str(bag), rate_hz=50.0)
    _, log, ref = replay(af, str(_equivalent_csv(tmp_path / "same.csv", af, cols, single=setup == "px4")))
    assert flight.log.rows == log.rows and np.all(accepted(traj.status))
    np.testing.assert_array_equal(traj.status, ref.status)
    assert np.max(np.abs(traj.outputs - ref.outputs)) <= 1e-5


def test_px4_1_16_topic_names_with_v1_are_found(tmp_path):
    """PX4 1.16 publishes some topics as <name>_v1: the same flight under those names replays alike."""
    af, cols = _flight()
    plain = replay_autopilot(af, str(_px4_bag(tmp_path / "plain", af, cols, "mcap")))[2]
    renamed = ("vehicle_odometry", "vehicle_attitude", "esc_status")
    _, flight, traj = replay_autopilot(af, str(_px4_bag(tmp_path / "v1", af, cols, "mcap", v1=renamed)))
    assert np.all(accepted(traj.status))
    np.testing.assert_array_equal(traj.outputs, plain.outputs)
    assert any("/fmu/out/vehicle_odometry" in n for n in flight.notes)


@pytest.mark.parametrize("storage", ["mcap", "db3"])
def test_px4_bag_with_vehicle_local_position_instead_of_odometry(tmp_path, storage):
    """No vehicle_odometry: the velocity comes from vehicle_local_position (vx, vy, vz, NED), read with
    the bag's own definition, and replays exactly like the odometry bag of the same flight."""
    af, cols = _flight()
    plain = replay_autopilot(af, str(_px4_bag(tmp_path / "odom", af, cols, storage)))[2]
    _, flight, traj = replay_autopilot(af, str(_px4_bag(tmp_path / "lpos", af, cols, storage, local_position=True,
                                                        v1=("vehicle_local_position",))))
    assert np.all(accepted(traj.status))
    np.testing.assert_array_equal(traj.outputs, plain.outputs)
    assert any("velocity /fmu/out/vehicle_local_position_v1" in n for n in flight.notes)


def test_px4_bag_without_esc_status_says_what_to_add(tmp_path, capsys):
    af, cols = _flight()
    bag = _px4_bag(tmp_path / "noesc", af, cols, "mcap", esc=False)
    assert main(["replay", str(M300), str(bag)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "/fmu/out/esc_status" in err and "dds_topics.yaml" in err


def test_px4_bag_land_detector_flags_the_ground(tmp_path):
    af, cols = _flight()
    _, flight, traj = replay_autopilot(af, str(_px4_bag(tmp_path / "land", af, cols, "mcap", landed_until=3.0)))
    t = flight.log.time_s
    assert np.all(traj.status[t < 2.95] == STATUS_LANDED) and np.all(accepted(traj.status[t > 3.25]))


def test_topic_names_are_overridable(tmp_path, capsys):
    af, cols = _flight()
    bag = _mavros_bag(tmp_path / "renamed", af, cols, "mcap", velocity_topic="/drone1/velocity_local")
    assert main(["replay", str(M300), str(bag)]) == 2
    assert "/mavros/local_position/velocity_local" in capsys.readouterr().err
    assert main(["replay", str(M300), str(bag), "--topic", "velocity=/drone1/velocity_local"]) == 0
    capsys.readouterr()
    assert main(["replay", str(M300), str(bag), "--topic", "speed=/x"]) == 2
    assert "roles" in capsys.readouterr().err


def test_topic_names_from_the_airframe_file(tmp_path, capsys):
    from dobwind.model.airframe_toml import dump_airframe
    from dobwind.model.airframe import parse_airframe

    af, cols = _flight()
    bag = _mavros_bag(tmp_path / "renamed", af, cols, "db3", velocity_topic="/drone1/velocity_local")
    text = M300.read_text() + '\n[ros2_topics]\nvelocity = "/drone1/velocity_local"\nland = "/fmu/out/x"\n'
    path = tmp_path / "m300_ros.toml"
    path.write_text(text)
    assert main(["replay", str(path), str(bag)]) == 0  # land is a PX4 role: ignored for mavros
    capsys.readouterr()
    # fit rewrites the airframe: the table survives a dump and reload.
    again = parse_airframe(dump_airframe(parse_airframe(text, "<t>")), "<t2>")
    assert dict(again.ros2_topics) == {"velocity": "/drone1/velocity_local", "land": "/fmu/out/x"}
    path.write_text(M300.read_text() + '\n[ros2_topics]\nvelocity = "drone1/velocity_local"\n')
    assert main(["replay", str(path), str(bag)]) == 2
    err = capsys.readouterr().err
    assert "ros2_topics.velocity" in err and err.count("\n") == 1



def test_a_bag_whose_hover_estimate_is_never_valid_says_so(tmp_path):
    """Never valid (a short flight): the bag has no MPC_THR_HOVER to fall back on, so the unconverged
    estimates scale the thrust, and a note says so (the ULog path names its fallback too)."""
    from dobwind.model.airframe import parse_airframe
    from dobwind.model.airframe_toml import dumps
    from tests.helpers import airframe_dict

    af = parse_airframe(dumps(airframe_dict(thrust={"source": "collective"}, mass=8.0, name="coll")), "<c>")
    _, cols = _flight()
    for until, said in ((1e9, True), (2.0, False)):
        bag = _px4_bag(tmp_path / f"never{until:g}", af, cols, "mcap", esc=False, hover=0.45, converging_until=until)
        _, flight, _ = replay_autopilot(af, str(bag), rate_hz=50.0)
        assert any("hover_thrust_estimate never valid" in n for n in flight.notes) == said, flight.notes

def test_px4_bag_collective_thrust_equals_the_equivalent_csv(tmp_path, capsys):
    from dobwind.model.airframe import parse_airframe
    from dobwind.model.airframe_toml import dumps
    from tests.helpers import airframe_dict

    af = parse_airframe(dumps(airframe_dict(thrust={"source": "collective"}, mass=8.0, name="coll")), "<c>")
    _, cols = _flight()
    # The hover estimator converging (not valid, 0.30) for the first 2 s: only valid estimates scale the thrust.
    bag = _px4_bag(tmp_path / "coll", af, cols, "mcap", esc=False, hover=0.45, converging_until=2.0)
    model, flight, traj = replay_autopilot(af, str(bag), rate_hz=50.0)
    csv = _equivalent_csv(tmp_path / "coll.csv", af, cols, single=True, hover=0.45)
    _, log, ref = replay(af, str(csv))
    np.testing.assert_allclose(flight.log.columns["thrust"], log.columns["thrust"], rtol=1e-6)
    assert np.all(accepted(traj.status)) and np.max(np.abs(traj.outputs - ref.outputs)) <= 1e-5
    # Without the thrust topics (PX4's default DDS set): exit 2 naming the topic to add.
    af_path = tmp_path / "coll.toml"
    af_path.write_text(dumps(airframe_dict(thrust={"source": "collective"}, mass=8.0, name="coll")))
    assert main(["replay", str(af_path), str(_px4_bag(tmp_path / "plain", af, cols, "mcap", esc=False))]) == 2
    err = capsys.readouterr().err
    assert "/fmu/out/vehicle_thrust_setpoint" in err and "dds_topics.yaml" in err
