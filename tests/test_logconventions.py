"""CSV replay's checks of a log's conventions (dobwind/replay/logconventions.py): the slips that leave every
sample inside the step's bounds, so that its rows are trusted with a wrong wind, are said on stderr.

The medians and RMS figures are pinned on synthetic logs whose answer is known in closed form; the slips
themselves on a simulated flight, where a valid log must stay silent."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dobwind.cli.app import main
from dobwind.io.logs import FlightLog
from dobwind.model.airframe import load_airframe
from dobwind.replay.logconventions import ConventionChecks, ConventionLimits
from dobwind.simulate.simulate import simulate

M300 = "m300"
YAW_WORDS = "yaw_ref and the attitude's yaw"
ACC_WORDS = "do not describe one motion"


def _write(path, cols: dict[str, np.ndarray]) -> str:
    names = list(cols)
    rows = np.column_stack([cols[n] for n in names])
    path.write_text(",".join(names) + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    return str(path)


@pytest.fixture(scope="module")
def flight() -> dict[str, np.ndarray]:
    return simulate(load_airframe(M300), "outdoor", seed=3, hold_s=4.0)


def _degrees(c):
    c["yaw_ref"] = np.degrees(c["yaw_ref"])


def _conjugate(c):
    for k in ("q_x", "q_y", "q_z"):
        c[k] = -c[k]


def _in_g(c):
    for k in ("acc_n", "acc_e", "acc_d"):
        c[k] = c[k] / 9.80665


def _body_velocity(c):
    rot = Rotation.from_quat(np.column_stack([c["q_x"], c["q_y"], c["q_z"], c["q_w"]]))
    v = rot.inv().apply(np.column_stack([c["vel_n"], c["vel_e"], c["vel_d"]]))
    c["vel_n"], c["vel_e"], c["vel_d"] = v[:, 0], v[:, 1], v[:, 2]


def _replay(tmp_path, capsys, cols, *extra) -> tuple[str, str]:
    log = _write(tmp_path / "log.csv", cols)
    capsys.readouterr()
    assert main(["replay", M300, log, *extra]) == 0
    captured = capsys.readouterr()
    return captured.out, captured.err


def test_a_valid_log_says_nothing(tmp_path, capsys, flight):
    _, err = _replay(tmp_path, capsys, dict(flight))
    assert YAW_WORDS not in err and ACC_WORDS not in err


@pytest.mark.parametrize("slip, words", [(_degrees, YAW_WORDS), (_conjugate, YAW_WORDS), (_in_g, ACC_WORDS),
                                         (_body_velocity, ACC_WORDS)])
def test_a_slip_is_said_in_one_line_naming_the_log(tmp_path, capsys, flight, slip, words):
    cols = {k: v.copy() for k, v in flight.items()}
    slip(cols)
    out, err = _replay(tmp_path, capsys, cols, "--json")
    said = [line for line in err.splitlines() if words in line]
    assert len(said) == 1 and said[0].startswith(f"dobwind replay: warning: {tmp_path / 'log.csv'}: ")
    check = "yaw_ref" if words == YAW_WORDS else "acceleration"
    assert check in [f["check"] for f in json.loads(out)["plausibility"]]


def test_the_netcdf_output_checks_the_same(tmp_path, capsys, flight):
    pytest.importorskip("netCDF4")
    cols = {k: v.copy() for k, v in flight.items()}
    _degrees(cols)
    _, err = _replay(tmp_path, capsys, cols, "-o", str(tmp_path / "e.nc"))
    assert YAW_WORDS in err


def _yaw_log(offset_deg: np.ndarray, rate_hz: float = 20.0) -> FlightLog:
    """A level vehicle turning at 10 deg/s, yaw_ref ahead of it by ``offset_deg`` (one per row)."""
    t = np.arange(len(offset_deg)) / rate_hz
    yaw = np.radians(10.0 * t)
    q = np.column_stack([np.cos(yaw / 2), 0 * t, 0 * t, np.sin(yaw / 2)])
    cols = {"t": t, "yaw_ref": yaw + np.radians(offset_deg)} | {f"q_{c}": q[:, i] for i, c in enumerate("wxyz")}
    return FlightLog("yaw.csv", cols | {k: 0 * t for k in ("vel_n", "vel_e", "vel_d", "acc_n", "acc_e", "acc_d")})


@pytest.mark.parametrize("median", [40.0, 50.0, 170.0])
def test_the_yaw_difference_is_its_median_whatever_the_rest(median):
    """Half the rows at the median or below, half above by up to 180 deg (wrapped): the finding's value is
    the median, to the histogram's 1 deg bin, and only beyond the limit is it a finding."""
    rng = np.random.default_rng(1)
    low = rng.uniform(0.0, median, 601)
    high = rng.uniform(median, 180.0, 600)
    offset = np.r_[low, [median], high] * rng.choice([-1, 1], 1202)
    checks = ConventionChecks(load_airframe(M300))
    checks.add(FlightLog("yaw.csv", _yaw_log(offset).columns), np.zeros(1202, dtype=np.int64))
    found = [f for f in checks.findings() if f.check == "yaw_ref"]
    assert ConventionLimits().yaw_median_deg == 45.0   # docs/robustness.md says it
    if median <= 45.0:
        assert not found
    else:
        assert len(found) == 1 and found[0].value == pytest.approx(median, abs=1.0)


def test_rejected_rows_and_a_short_log_are_not_judged():
    af = load_airframe(M300)
    offset = np.full(400, 90.0)   # 20 s at 20 Hz
    checks = ConventionChecks(af)
    status = np.where(np.arange(400) < 350, 1, 0)   # NONFINITE: 2.5 s accepted, under yaw_min_s
    checks.add(_yaw_log(offset), status)
    assert not checks.findings()
    checks.add(_yaw_log(offset), np.zeros(400, dtype=np.int64))
    assert [f.check for f in checks.findings()] == ["yaw_ref"]


def test_chunks_combine_as_the_whole_log():
    """The acceleration figure over two chunks is the time-weighted RMS of each chunk's: a chunk whose
    acceleration is off by a 0.2 Hz sinusoid of amplitude a reads a / sqrt(2) |H|^2, its clean twin 0."""
    t = np.arange(0.0, 120.0, 0.02)
    a = 0.8
    vel = np.column_stack([2 * np.sin(0.3 * t), 1.5 * np.cos(0.2 * t)])
    acc = np.column_stack([0.6 * np.cos(0.3 * t), -0.3 * np.sin(0.2 * t)])
    bad = acc + a * np.column_stack([np.sin(2 * np.pi * 0.2 * t), np.cos(2 * np.pi * 0.2 * t)])
    level = {"q_w": 1 + 0 * t, "q_x": 0 * t, "q_y": 0 * t, "q_z": 0 * t, "vel_d": 0 * t, "acc_d": 0 * t}

    def log(acc_ne):
        return FlightLog("a.csv", {"t": t, "vel_n": vel[:, 0], "vel_e": vel[:, 1], "acc_n": acc_ne[:, 0],
                                   "acc_e": acc_ne[:, 1]} | level)

    checks = ConventionChecks(load_airframe(M300))   # its highest cutoff: 0.5 Hz
    checks.add(log(bad), np.zeros(len(t), dtype=np.int64))
    checks.add(log(acc), np.zeros(len(t), dtype=np.int64))
    (found,) = checks.findings()
    one = a / math.sqrt(2) / (1 + (0.2 / 0.5) ** 4)
    assert found.check == "acceleration" and found.value == pytest.approx(one / math.sqrt(2), rel=0.03)
    assert found.count == 2 * len(t)


def _rpm_in_rad_per_s(c):
    for k in ("rpm_1", "rpm_2", "rpm_3", "rpm_4"):
        c[k] = c[k] * 2 * math.pi / 60


@pytest.mark.parametrize("slip", [None, _degrees, _rpm_in_rad_per_s])
def test_report_warns_of_a_csv_log_as_replay_does(tmp_path, capsys, flight, slip):
    """`report` on a CSV log said none of replay's warnings (rpm in rad/s: a thrust 0.1x the weight, a yaw_ref
    in degrees): the page showed a confident wind. Its stderr lines are now replay's, and the page has them."""
    cols = {k: v.copy() for k, v in flight.items()}
    if slip is not None:
        slip(cols)
    _, replay_err = _replay(tmp_path, capsys, cols)
    said = [line.split("warning: ", 1)[1] for line in replay_err.splitlines() if "warning: " in line]
    assert bool(said) == (slip is not None)
    page = tmp_path / "r.html"
    assert main(["report", M300, str(tmp_path / "log.csv"), "-o", str(page)]) == 0
    err = capsys.readouterr().err
    assert [line.split("warning: ", 1)[1] for line in err.splitlines() if "warning: " in line] == said
    text = page.read_text()
    assert all(line.split(": ", 1)[1][:60].replace("'", "&#39;") in text for line in said)
