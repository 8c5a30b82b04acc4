"""What `dobwind inspect` says must be true for the log and agree with itself and with replay (issue #36,
a new user's pass): each case is a project-made DataFlash log built to show one contradiction found on
the field logs."""
from __future__ import annotations

from pathlib import Path

import pytest

from dobwind.cli.app import main
from dobwind.inspect.anylog import inspect_log
from tests.dataflash_writer import write_dataflash
from tests.test_inspect import _ardupilot_log

pytest.importorskip("pymavlink")

T0_US = 1_000_000


def _ekf2_plane_log(path: Path, *, tho: float | None) -> Path:
    """An EKF2 log (NKF1, NKQ1) at 25 Hz, 10 s, no EV events; CTUN with ThO (a copter's, at `tho`) or, when
    tho is None, ArduPlane's CTUN without ThO."""
    ctun = ("Qfff", ["TimeUS", "ThO", "ThH", "NavRoll"]) if tho is not None else ("Qf", ["TimeUS", "NavRoll"])
    messages = {"NKF1": ("Qfff", ["TimeUS", "VN", "VE", "VD"]), "NKQ1": ("Qffff", ["TimeUS", "Q1", "Q2", "Q3", "Q4"]),
                "IMU": ("Qfff", ["TimeUS", "AccX", "AccY", "AccZ"]), "CTUN": ctun}
    rows: list = []
    for k in range(250):
        us = T0_US + k * 40_000
        rows += [("NKF1", {"TimeUS": us, "VN": 1.0}), ("NKQ1", {"TimeUS": us, "Q1": 1.0}),
                 ("IMU", {"TimeUS": us, "AccZ": -9.8}),
                 ("CTUN", {"TimeUS": us, **({"ThO": tho, "ThH": 0.35} if tho is not None else {})})]
    return write_dataflash(path, messages, rows)


def test_an_ekf2_log_names_its_own_quaternion_and_a_ctun_without_tho_is_no_ground_source(tmp_path):
    s = inspect_log(str(_ekf2_plane_log(tmp_path / "plane.bin", tho=None)))
    assert s.role("attitude").source.startswith("NKQ1.")
    # The NED acceleration is the IMU rotated by the quaternion replay reads: NKQ1 here, never XKQ.
    assert "NKQ1" in s.role("acceleration").source and "XKQ" not in s.role("acceleration").source
    # dataflash._ground reads the ground from CTUN.ThO only; inspect must not claim a CTUN ground source.
    assert s.role("ground").source is None and "CTUN.ThO" in s.role("ground").note
    assert s.airborne_s is None and "no CTUN.ThO" in s.airborne_source


def test_unusable_esc_rpm_is_said_on_the_rpm_role_with_its_rate(tmp_path, capsys):
    """SITL logs ESC messages with RPM 0 in flight: the role listing must not read as if rpm were used."""
    log = _ardupilot_log(tmp_path / "a.bin", esc_rpm=False)
    s = inspect_log(str(log))
    rpm = s.role("rpm")
    assert rpm.source == "ESC.RPM" and rpm.note.startswith("logged, not usable")
    assert s.stream(rpm.stream) is not None and s.stream(rpm.stream).rate_hz == pytest.approx(10.0, rel=1e-4)
    assert "0 % of the airborne reports" in rpm.note and "at least 0 %" not in rpm.note
    # Usable rpm keeps an empty note.
    assert inspect_log(str(_ardupilot_log(tmp_path / "b.bin", esc_rpm=True))).role("rpm").note == ""
    assert main(["inspect", str(log)]) == 0
    assert "logged, not usable" in capsys.readouterr().out


def test_hover_thrust_is_not_called_an_airborne_median_when_nothing_was_airborne(tmp_path):
    on_ground = inspect_log(str(_ekf2_plane_log(tmp_path / "g.bin", tho=0.0)))
    assert on_ground.airborne_s == 0.0
    assert on_ground.vehicle.hover_thrust == pytest.approx(0.35)
    assert "airborne median" not in on_ground.vehicle.hover_source
    flying = inspect_log(str(_ekf2_plane_log(tmp_path / "f.bin", tho=0.4)))
    assert flying.airborne_s > 9.0 and flying.vehicle.hover_source == "CTUN.ThH (airborne median)"


def test_init_does_not_print_zero_rotors_when_the_count_is_unknown(tmp_path, capsys):
    """A collective-thrust log without ESC, CA_ROTOR_COUNT or actuator_motors: the file's comment said
    "rotors: not used" while the summary printed "rotors 0"."""
    pytest.importorskip("pyulog")
    from tests.test_inspect import _px4_log

    log = _px4_log(tmp_path / "f.ulg", esc=False, rotor_param=0)
    assert main(["init", str(log), "--mass", "2", "-o", str(tmp_path / "v.toml")]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.strip().startswith("rotors"))
    assert line.split()[1:] != ["0"] and "unknown" in line
    assert "# rotors: not used" in (tmp_path / "v.toml").read_text()


@pytest.mark.parametrize("command", [["inspect"], ["init", "--mass", "2", "-o", "OUT.toml"],
                                     ["report", "AIRFRAME", "-o", "OUT.html"]])
def test_a_plain_folder_is_named_as_a_folder_not_as_a_missing_metadata_file(command, tmp_path, capfd):
    """A user who points a command at a folder of logs got "not a readable ROS 2 bag (FileNotFoundError:
    Expected metadata file 'DIR' does not exist.)"."""
    pytest.importorskip("rosbags")
    from tests.helpers import M300

    folder = tmp_path / "flights"
    folder.mkdir()
    _ardupilot_log(folder / "a.bin", esc_rpm=False)
    args = [a.replace("OUT", str(tmp_path / "out")).replace("AIRFRAME", str(M300)) for a in command]
    argv = [args[0], *args[1:2], str(folder), *args[2:]] if args[0] == "report" else [args[0], str(folder), *args[1:]]
    assert main(argv) == 2
    out, err = capfd.readouterr()
    assert out == "" and err.count("\n") == 1 and str(folder) in err
    assert "metadata.yaml" in err and "FileNotFoundError" not in err and "folder" in err
