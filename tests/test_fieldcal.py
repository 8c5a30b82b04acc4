"""fit from autopilot logs (issue #36): the wind truth three ways, on flights the project simulates.

The truths are pinned by closed forms (a wind FROM 270 deg blows east; SITL's square-root profile at a
quarter of T_ALT is half the speed), the --truth sitl fit on a DataFlash log written here from a
simulated box flight must read the simulator's wind back through its own replay, and --wind unknown
must find a box flight's wind and refuse a flight whose nose never turns."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.core.errors import CheckFailed, InputError
from dobwind.calibrate.fieldtruth import LogTime, SteadyWind, WindSeries, flight_of, parse_wind, read_truth_csv, with_truth
from dobwind.io.logs import FlightLog, write_csv
from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.model.status import accepted
from dobwind.replay.replay import replay_ulog
from dobwind.simulate.simulate import simulate
from dobwind.calibrate.sitlwind import read_sitl_log
from dobwind.io.sitlwind import PROFILE_LINEAR, PROFILE_NONE, PROFILE_SQRT, profile_speed, sitl_wind_ned
from dobwind.calibrate import windsolve
from dobwind.calibrate.windsolve import GroupWinds, estimate_winds
from tests.dataflash_writer import write_dataflash
from tests.helpers import airframe_dict

HOVER = 0.37
MESSAGES = {
    "XKF1": ("QBfff", ["TimeUS", "C", "VN", "VE", "VD"]),
    "XKQ": ("QBffff", ["TimeUS", "C", "Q1", "Q2", "Q3", "Q4"]),
    "CTUN": ("Qff", ["TimeUS", "ThO", "ThH"]),
    "ATT": ("Qf", ["TimeUS", "DesYaw"]),
    "EV": ("QB", ["TimeUS", "Id"]),
    "BARO": ("QBf", ["TimeUS", "I", "Alt"]),
    "PARM": ("QNf", ["TimeUS", "Name", "Value"]),
}
XKF2 = {"XKF2": ("QBff", ["TimeUS", "C", "VWN", "VWE"])}  # ArduPilot's own wind estimate


def _airframe(tmp_path):
    """A 10 Hz collective-thrust quad (the rates an ArduPilot log has), its law an uncalibrated guess."""
    doc = airframe_dict(thrust={"source": "collective"}, mass=3.0, name="field")
    doc["observer"].update(sample_time=0.1, acceleration="velocity")
    doc["limits"] = {**doc.get("limits", {}), "max_dt": 0.25}
    path = tmp_path / "field.toml"
    path.write_text(dumps(doc))
    return path, parse_airframe(dumps(doc), str(path))


@pytest.fixture(scope="module")
def box(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("field")
    path, af = _airframe(tmp)
    cols = simulate(af, "box", seed=5, hold_s=6.0, rate_hz=10.0)
    return tmp, path, af, cols


def _mean_wind(cols) -> np.ndarray:
    return np.array([cols["wind_n"].mean(), cols["wind_e"].mean()])


def _from_deg(ne) -> float:
    return math.degrees(math.atan2(-ne[1], -ne[0])) % 360


def _dataflash(path, af, cols, params: dict[str, float] | None, later: tuple = (),
               altitude_m=lambda t_s: 20.0, inactive_xkf2: bool = False) -> str:
    """``later``: more (message, fields) rows, put in time order (a parameter changed in flight);
    ``altitude_m``: BARO.Alt at a log time (s); ``inactive_xkf2``: an autopilot wind of zero on every row."""
    rows = [("PARM", {"TimeUS": 500_000, "Name": k, "Value": v}) for k, v in (params or {}).items()]
    rows.append(("EV", {"TimeUS": 1_000_000, "Id": 28}))  # NOT_LANDED: airborne from the start
    mg = af.mass_kg * af.gravity_mps2
    for k, t in enumerate(cols["t"]):
        us = 1_000_000 + int(round(t * 1e6))
        rows.append(("XKF1", {"TimeUS": us, "C": 0, "VN": cols["vel_n"][k], "VE": cols["vel_e"][k], "VD": cols["vel_d"][k]}))
        rows.append(("XKQ", {"TimeUS": us, "C": 0, **{f"Q{i + 1}": cols[f"q_{c}"][k] for i, c in enumerate("wxyz")}}))
        if inactive_xkf2:
            rows.append(("XKF2", {"TimeUS": us, "C": 0, "VWN": 0.0, "VWE": 0.0}))
        rows.append(("CTUN", {"TimeUS": us, "ThO": cols["thrust"][k] / mg * HOVER, "ThH": HOVER}))
        rows.append(("ATT", {"TimeUS": us, "DesYaw": np.degrees(cols["yaw_ref"][k])}))
        rows.append(("BARO", {"TimeUS": us, "I": 0, "Alt": float(altitude_m(us * 1e-6))}))
    if later:
        rows = sorted([*rows, *later], key=lambda row: row[1]["TimeUS"])
    return str(write_dataflash(path, {**MESSAGES, **(XKF2 if inactive_xkf2 else {})}, rows))


# --- closed forms -------------------------------------------------------------------------------------

@pytest.mark.parametrize("text, ned", [("5@270", (0.0, 5.0, 0.0)), ("3@0,1", (-3.0, 0.0, -1.0)),
                                       ("2.5@90,-0.5", (0.0, -2.5, 0.5)), ("4@180", (4.0, 0.0, 0.0))])
def test_a_steady_wind_blows_away_from_where_it_comes_from(text, ned):
    np.testing.assert_allclose(parse_wind(text).vector(), ned, atol=1e-12)


@pytest.mark.parametrize("text", ["5", "5@", "@90", "fast@90", "-1@90", "500@0", "5@90,200", "5@400", "5@-10",
                                  "5@360.5", "1e400@90", "5@1e400", "5@90,1e400", "5@90,-1e400", "nan@90", "5@inf"])
def test_a_bad_wind_is_an_input_error_naming_the_option(text):
    with pytest.raises(InputError) as caught:
        parse_wind(text)
    assert caught.value.source == "--wind" and text in str(caught.value)


@pytest.mark.parametrize("text, part", [("5@400", "direction 400 deg"), ("-2@90", "speed -2 m/s"),
                                        ("5@90,-150", "updraft -150 m/s")])
def test_fit_refuses_a_wind_out_of_range_in_one_line_naming_the_field(box, tmp_path, capsys, text, part):
    """A mast bearing is 0-360: 400 is a typo, not 40 (it was silently wrapped before); the line says which
    field is wrong, and nothing is read or written."""
    _, path, _, _ = box
    out = tmp_path / "never.toml"
    assert main(["fit", str(path), "x.csv", f"--wind={text}", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--wind" in err and part in err and "Traceback" not in err
    assert not out.exists()



@pytest.mark.parametrize("text", ["-2@90", "-2.5@90,1", "-1e-3@0"])
def test_a_negative_wind_given_as_its_own_word_reaches_the_speed_check(box, tmp_path, capsys, text):
    """`--wind -2@90` (not `--wind=-2@90`): argparse took the value for an option and said only "expected
    one argument"; now the speed check's own line says what is wrong."""
    _, path, _, _ = box
    out = tmp_path / "never.toml"
    assert main(["fit", str(path), "x.csv", "--wind", text, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"'{text}'" in err and "speed -" in err and "must be in [0, 100]" in err, err
    assert not out.exists()


def test_the_same_log_twice_is_refused_naming_it(box, tmp_path, capsys):
    """`fit A LOG LOG --wind 3@90 --wind 5@0`: the truth is keyed by the log, so the second wind was dropped
    without a word (one wind_truth.per_log line); the same file under a second name is the same log."""
    _, path, af, cols = box
    log = _dataflash(tmp_path / "one.bin", af, cols, None)
    (tmp_path / "link.bin").symlink_to(log)
    out = tmp_path / "never.toml"
    for again in (log, str(tmp_path / "link.bin")):
        assert main(["fit", str(path), log, again, "--wind", "3@90", "--wind", "5@0", "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith(f"dobwind fit: {again}: is given twice") and "Traceback" not in err
    assert not out.exists()

def test_a_bearing_of_360_is_north():
    np.testing.assert_allclose(parse_wind("4@360").vector(), parse_wind("4@0").vector(), atol=1e-12)
    assert parse_wind("4@360").from_deg == 0.0


def test_sitl_profiles_in_closed_form():
    speed, t_alt, coef = np.full(5, 10.0), np.full(5, 60.0), np.full(5, 0.01)
    alt = np.array([-5.0, 0.0, 15.0, 60.0, 120.0])
    np.testing.assert_allclose(profile_speed(speed, alt, np.full(5, PROFILE_SQRT), t_alt, coef),
                               [0.0, 0.0, 5.0, 10.0, 10.0])   # 10 sqrt(15 / 60) = 5
    np.testing.assert_allclose(profile_speed(speed, alt, np.full(5, PROFILE_LINEAR), t_alt, coef),
                               [9.35, 9.4, 9.55, 10.0, 10.6])
    np.testing.assert_allclose(profile_speed(speed, alt, np.full(5, PROFILE_NONE), t_alt, coef), speed)


def test_a_truth_file_is_interpolated_and_rows_outside_its_span_are_not_used(tmp_path):
    truth = tmp_path / "mast.csv"
    write_csv(truth, ["t", "speed", "from_deg"], np.array([[101.0, 2.0, 90.0], [103.0, 4.0, 90.0]]), ["%g"] * 3)
    series = read_truth_csv(str(truth))
    assert isinstance(series, WindSeries)
    t = np.arange(0.0, 5.0, 0.5)   # log time 100 .. 104.5 s
    log = FlightLog("f.csv", {"t": t, "vel_n": np.ones(len(t))})
    out = with_truth("f.csv", LogTime(log, 100.0), series)
    inside = (t >= 1.0) & (t <= 3.0)
    # From 90 deg (east) the air moves west: wind_e = -speed, linear in time between the rows.
    np.testing.assert_allclose(out.columns["wind_e"][inside], -(2.0 + (t[inside] - 1.0)), atol=1e-12)
    assert np.all(np.isnan(out.columns["vel_n"][~inside])) and np.all(out.columns["vel_n"][inside] == 1.0)


def test_a_truth_file_without_wind_columns_is_refused(tmp_path):
    bad = tmp_path / "bad.csv"
    write_csv(bad, ["t", "gust"], np.array([[0.0, 1.0], [1.0, 2.0]]), ["%g"] * 2)
    with pytest.raises(InputError) as caught:
        read_truth_csv(str(bad))
    assert "wind_n" in str(caught.value)


# --- the three ways, on simulated flights --------------------------------------------------------------

@pytest.mark.parametrize("way", ["sitl", "wind"])
def test_fit_from_a_dataflash_log_reads_the_simulator_wind_back(box, capsys, way):
    """The simulator's wind goes into SIM_WIND_* (no profile) or --wind; the fitted airframe replayed over
    the log reads its mean within 0.3 m/s and 3 deg, where the uncalibrated guess is far off."""
    tmp, path, af, cols = box
    mean = _mean_wind(cols)
    speed, from_deg = float(np.hypot(*mean)), _from_deg(mean)
    params = {"SIM_WIND_SPD": speed, "SIM_WIND_DIR": from_deg, "SIM_WIND_T": 1.0, "SIM_WIND_TURB": 0.3}
    log = _dataflash(tmp / f"box_{way}.bin", af, cols, params)
    out = tmp / f"fit_{way}.toml"
    truth = ["--truth", "sitl"] if way == "sitl" else ["--wind", f"{speed:.4f}@{from_deg:.4f}", "--json"]
    code = main(["fit", str(path), log, *truth, "-o", str(out), "--model", "drag-heading", "--hover-noise", "0"])
    printed = capsys.readouterr()
    assert code == 0, printed.err
    if way == "sitl":  # the simulator's turbulence is not in the log: the truth is its mean, and fit says so
        assert "SIM_WIND_TURB 0.3 > 0" in printed.err and "approximate" in printed.err
        # the text report says, for the log, that its airflow came from the simulator's parameters
        assert "wind truth per log" in printed.out
        assert f"  {log}: the wind the simulator was told to blow" in printed.out and "--truth sitl" in printed.out
        assert "estimated" not in printed.out.split("wind truth per log")[1].split("self-check")[0]
    else:
        record = json.loads(printed.out)["wind_truth"]
        assert "(--wind)" in record["truth"]
        assert record["per_log"][log].startswith("a known steady wind on every airborne row (--wind)")
        assert f"{float(f'{speed:.4f}'):g} m/s from {float(f'{from_deg:.4f}'):g} deg" in record["per_log"][log]
    text = out.read_text()
    assert text.startswith("# calibrated by `dobwind fit` from " + log)
    assert ("SIM_WIND_SPD" in text) if way == "sitl" else ("(--wind)" in text)
    errors = {}
    for name, airframe in (("fitted", load_airframe(out)), ("guess", af)):
        model, flight, traj = replay_ulog(airframe, log)
        wind = traj.outputs[:, model.outputs.slice("wind_ned")][accepted(traj.status)]
        errors[name] = float(np.hypot(*(wind[:, :2].mean(axis=0) - mean)))
        if name == "fitted":
            assert abs(float(np.mean(np.hypot(wind[:, 0], wind[:, 1]))) - speed) < 0.3
            assert abs((_from_deg(wind[:, :2].mean(axis=0)) - from_deg + 180) % 360 - 180) < 3.0
    assert errors["fitted"] < 0.3 < errors["guess"], errors


def test_truth_sitl_refuses_a_log_without_the_parameters(box, capsys, tmp_path):
    _, path, af, cols = box
    log = _dataflash(tmp_path / "plain.bin", af, {k: v[:200] for k, v in cols.items()}, None)
    out = tmp_path / "never.toml"
    assert main(["fit", str(path), log, "--truth", "sitl", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "SIM_WIND_SPD" in err and log in err and not out.exists()


@pytest.fixture(scope="module")
def box_solution(box, _solve_memo):
    """The box flight as a CSV log, its (path, LogTime) list and the joint solution on it (its solve kept
    in the module's memo: the 1-sigma refusal below asks it again under another limit)."""
    tmp, _, af, cols = box
    csv = tmp / "box.csv"
    write_csv(csv, list(cols), np.column_stack([cols[k] for k in cols]), ["%.9g"] * len(cols))
    flights = [(str(csv), flight_of(str(csv), af, None))]
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(windsolve, "_solve_with_thrust_scale", _solve_memo)
        return csv, flights, estimate_winds(af, flights)


def test_wind_unknown_finds_the_wind_of_a_box_flight(box, box_solution):
    """Legs along four tracks, nose first: the joint solution is the simulator's mean wind within 0.25 m/s."""
    _, _, af, cols = box
    csv, _, solution = box_solution
    (group,) = solution.groups
    assert np.hypot(*(np.array(group.wind_ne) - _mean_wind(cols))) < 0.25, (group, _mean_wind(cols))
    assert group.sigma_mps < 0.5
    # As a truth: that wind on every row of the log.
    wind, known = GroupWinds(solution).wind(str(csv), flight_of(str(csv), af, None))
    assert known.all() and np.allclose(wind[:, :2], group.wind_ne) and np.all(wind[:, 2] == 0)


def test_a_refusal_on_the_wind_1_sigma_says_how_long_a_flight_would_do(box, box_solution, monkeypatch, shared_solves):
    """A flight that spans enough headings but leaves the wind 1-sigma above the limit is told the flight
    time at which it would reach the limit, span x (sigma / limit)^2 (a mean's 1-sigma falls as
    1/sqrt(time)): here the limit is set to half the box's own 1-sigma, so four times its span."""
    af = box[2]
    _, flights, solution = box_solution
    (group,) = solution.groups
    monkeypatch.setattr(windsolve, "MAX_WIND_SIGMA_MPS", group.sigma_mps / 2)
    with pytest.raises(CheckFailed) as refused:
        estimate_winds(af, flights)
    span = group.t_end_s - group.t_start_s
    assert f"about {4 * span:.0f} s of such flight instead of {span:.0f} s" in str(refused.value)
    assert windsolve.flight_time_needed_s(0.3, 0.5, 80.0) == 80.0   # already within the limit: no longer flight


def test_wind_unknown_refuses_a_flight_whose_nose_never_turns(box, tmp_path, capsys):
    """The same legs and speeds with one heading: the wind trades with the force offset and the law, so
    fit exits 1 with one line naming the headings flown, and writes nothing."""
    _, path, af, _ = box
    # 3 s holds, not the box's 6: the solve of an unidentifiable flight takes long, half the rows still
    # give a 1-sigma of 12 m/s against the 0.5 limit (6 s: 11 m/s) and the same heading count
    cols = simulate(af, "one-heading", seed=5, hold_s=3.0, rate_hz=10.0)
    csv = tmp_path / "one.csv"
    names = [k for k in cols if not k.startswith("wind_")]
    write_csv(csv, names, np.column_stack([cols[k] for k in names]), ["%.9g"] * len(names))
    out = tmp_path / "never.toml"
    assert main(["fit", str(path), str(csv), "--wind", "unknown", "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not identify the wind" in err and "headings in 1 of 8 45-deg sectors (need 3)" in err
    assert not out.exists()


@pytest.mark.parametrize("argv, option", [(["--wind", "3@90", "--truth", "sitl"], "--truth"),
                                          (["--wind", "3@90", "--still-air"], "--still-air"),
                                          (["--wind", "3@90", "--segment-s", "30"], "--segment-s"),
                                          (["--wind", "3@90", "--wind", "2@0"], "--wind"),
                                          (["--wind", "unknown", "--wind", "unknown"], "--wind"),
                                          (["--wind", "3@90", "--rate", "10"], "--rate")])
def test_conflicting_truth_options_exit_2_naming_the_option(box, tmp_path, capsys, argv, option):
    _, path, _, _ = box
    assert main(["fit", str(path), "x.csv", *argv, "-o", str(tmp_path / "n.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and option in err


def test_a_steady_wind_is_the_same_on_every_row():
    log = FlightLog("f.csv", {"t": np.arange(3.0)})
    wind, known = SteadyWind(2.0, 45.0).wind("f.csv", LogTime(log, 0.0))
    assert known.all() and np.allclose(wind, [[-math.sqrt(2), -math.sqrt(2), 0.0]] * 3)


def test_no_usable_rows_is_a_check_failure(box):
    _, _, af, cols = box
    short = {k: v[:20] for k, v in cols.items()}
    with pytest.raises(CheckFailed):
        estimate_winds(af, [("short", LogTime(FlightLog("short", short), 0.0))])
    # shorter than the settling time: replay calls these rows valid (SETTLING), fit says why it uses none
    shorter = {k: v[:10] for k, v in cols.items()}
    with pytest.raises(CheckFailed, match=r"no airborne row of the logs is accepted and settled \(10 accepted, none"):
        estimate_winds(af, [("shorter", LogTime(FlightLog("shorter", shorter), 0.0))])


def test_sitl_wind_follows_the_barometer_altitude_in_the_log(tmp_path):
    """SIM_WIND_SPD 10 from 180 with the square law below 60 m, on a log whose BARO.Alt climbs 0 -> 60 m:
    the wind blows north at 10 sqrt(alt / 60) m/s; a PARM change in flight (DIR 90) takes effect at its time."""
    rows = [("PARM", {"TimeUS": 100_000, "Name": n, "Value": v})
            for n, v in (("SIM_WIND_SPD", 10.0), ("SIM_WIND_DIR", 180.0), ("SIM_WIND_T", 0.0), ("SIM_WIND_T_ALT", 60.0))]
    t = np.arange(0.0, 12.0, 0.5)
    rows += [("BARO", {"TimeUS": int(1e6 + k * 5e5), "I": 0, "Alt": 5.0 * k}) for k in range(len(t))]
    rows += [("BARO", {"TimeUS": int(1e6 + k * 5e5), "I": 1, "Alt": 999.0}) for k in range(len(t))]  # not instance 0
    rows.append(("PARM", {"TimeUS": 10_000_000, "Name": "SIM_WIND_DIR", "Value": 90.0}))
    log = read_sitl_log(str(write_dataflash(tmp_path / "sitl.bin", MESSAGES, sorted(rows, key=lambda r: r[1]["TimeUS"]))))
    assert log.altitude_source.startswith("BARO.Alt")
    clock = 1.0 + t
    wind = sitl_wind_ned(log, clock)
    speed = 10 * np.sqrt(np.minimum(5.0 * np.arange(len(t)) / 60.0, 1.0))
    before = clock < 10.0
    np.testing.assert_allclose(wind[before], np.column_stack([speed, 0 * speed, 0 * speed])[before], atol=1e-5)
    np.testing.assert_allclose(wind[~before][:, 1], -speed[~before], atol=1e-5)  # from the east: blows west


@pytest.fixture(scope="module")
def two_winds(box):
    """Two box flights in two different steady winds, one after the other in one CSV log: (its path, the
    first flight's and the second's columns, the second's start). Its two-segment solve is the module
    memo's (shared_solves): the refusal with several winds below asks it again under another limit."""
    tmp, _, af, first = box
    second = simulate(af, "box", seed=8, hold_s=6.0, rate_hz=10.0)
    shift = first["t"][-1] + 0.1
    cols = {k: np.concatenate([first[k], second[k] + (shift if k == "t" else 0)]) for k in first if k != "segment"}
    csv = tmp / "two_winds.csv"
    write_csv(csv, list(cols), np.column_stack([cols[k] for k in cols]), ["%.9g"] * len(cols))
    return csv, first, second, shift


def test_wind_unknown_per_segment_finds_each_segments_wind(box, two_winds, shared_solves):
    """Two box flights in two different steady winds, one after the other in one log: --segment-s of the
    first flight's length finds each one's wind (within 0.3 m/s), not their mean."""
    af = box[2]
    csv, first, second, shift = two_winds
    solution = estimate_winds(af, [(str(csv), flight_of(str(csv), af, None))], segment_s=shift)
    assert len(solution.groups) == 2 and solution.groups[0].t_end_s < shift <= solution.groups[1].t_start_s
    truths = [_mean_wind(first), _mean_wind(second)]
    assert np.hypot(*(truths[0] - truths[1])) > 1.0  # the winds differ: a mean would miss both
    for group, truth in zip(solution.groups, truths):
        assert np.hypot(*(np.array(group.wind_ne) - truth)) < 0.3, (group, truth)


def test_fit_with_the_wind_unknown_calibrates_a_box_flight_end_to_end(box, capsys, shared_solves):
    """fit --wind unknown on the box flight's CSV (its wind columns ignored): exit 0, the provenance names
    the winds found, and the fitted airframe replayed over the flight reads the simulator's mean wind
    within 0.3 m/s."""
    tmp, path, af, cols = box
    csv = tmp / "box_unknown.csv"
    write_csv(csv, list(cols), np.column_stack([cols[k] for k in cols]), ["%.9g"] * len(cols))
    out = tmp / "fit_unknown.toml"
    code = main(["fit", str(path), str(csv), "--wind", "unknown", "-o", str(out), "--model", "drag-heading",
                 "--hover-noise", "0", "--json"])
    printed = capsys.readouterr()
    assert code == 0, printed.err
    record = json.loads(printed.out)["wind_truth"]
    assert "--wind unknown" in record["truth"]
    # what the log's airflow was computed against: an estimated wind, not a known one, and where it held
    said = record["per_log"][str(csv)]
    assert said.startswith("not a known wind: estimated from this flight") and "identified" in said
    assert "identified (1-sigma within 0.5 m/s): t " in said and "segments" not in said
    assert "# wind truth: estimated jointly with the force-air law" in out.read_text()
    from dobwind.replay.replay import replay

    model, _, traj = replay(load_airframe(out), str(csv))
    wind = traj.outputs[:, model.outputs.slice("wind_ned")][accepted(traj.status)]
    assert np.hypot(*(wind[:, :2].mean(axis=0) - _mean_wind(cols))) < 0.3


def test_truth_sitl_needs_a_dataflash_log_and_a_truth_file_must_overlap_the_log(tmp_path):
    from dobwind.calibrate.sitlwind import read_sitl_log

    with pytest.raises(InputError) as caught:
        read_sitl_log(str(tmp_path / "flight.ulg"))
    assert ".bin" in caught.value.message
    series = WindSeries("mast.csv", np.array([500.0, 600.0]), np.zeros((2, 3)))
    log = FlightLog("f.csv", {"t": np.arange(0.0, 10.0)})
    with pytest.raises(InputError) as caught:
        with_truth("f.csv", LogTime(log, 0.0), series)
    assert "where the truth is known" in caught.value.message


def test_each_truth_says_what_it_gave_a_log(box_solution):
    """The per-log wording of fit's report for each source: a known steady wind, a time series with its
    span, a wind estimated per segment (identified, with its 1-sigma), the log's own columns and still air."""
    from dobwind.calibrate.fieldfit import FieldTruth, truth_lines
    from dobwind.calibrate.fieldtruth import PerLogWind

    steady = SteadyWind(6.5, 270.0, 0.2)
    assert steady.describe_log("a.ulg") == ("a known steady wind on every airborne row (--wind): 6.5 m/s from "
                                            "270 deg, updraft 0.2 m/s")
    per_log = PerLogWind((("a.ulg", steady), ("b.ulg", SteadyWind(3.0, 90.0))))
    assert "3 m/s from 90 deg" in per_log.describe_log("b.ulg") and "6.5" not in per_log.describe_log("b.ulg")
    series = WindSeries("mast.csv", np.array([100.0, 190.0]), np.zeros((2, 3)))
    assert series.describe_log("a.ulg") == ("a known wind time series (--truth mast.csv), interpolated on the "
                                            "log's clock; rows outside t 100..190 s not used")
    _, _, solution = box_solution
    (group,) = solution.groups
    two = type(solution)((group, type(group)(group.path, 500.0, 560.0, (0.0, -4.0), 0.31, 90)), solution.law,
                         solution.condition, solution.residual_rms_n)
    said = GroupWinds(two).describe_log(group.path)
    assert said.startswith("not a known wind: estimated from this flight") and "identified (1-sigma within 0.5 m/s) in all 2 segments: t " in said
    assert "t 500.0-560.0 s 4.00 m/s from 90 deg, 1-sigma 0.31 m/s" in said
    assert GroupWinds(two).describe_log("other.ulg").startswith("no wind estimated")
    from dobwind.calibrate.fieldfit import ESTIMATED_SELF_CHECK

    estimated = truth_lines(FieldTruth(GroupWinds(two), lambda p, af: None), [group.path], False)
    assert estimated[-1] == ESTIMATED_SELF_CHECK and "not with an independent truth" in estimated[-1]
    assert ESTIMATED_SELF_CHECK not in truth_lines(FieldTruth(steady, lambda p, af: None), ["a.ulg"], False)
    lines = truth_lines(FieldTruth(per_log, lambda p, af: None), ["a.ulg", "b.ulg"], False)
    assert lines[1].startswith("  a.ulg: a known steady wind") and lines[2].startswith("  b.ulg: a known steady wind")
    assert "wind_n/wind_e/wind_d columns" in truth_lines(None, ["t.csv"], False)[1]
    assert "zero wind (--still-air)" in truth_lines(None, ["t.csv"], True)[1]


def test_a_refusal_with_several_winds_says_which_were_identified(box, two_winds, monkeypatch, shared_solves):
    """Two segments (the two-winds log's, its solve shared with the test above), the limit set between
    their 1-sigmas: the refusal names the one identified and the one not, each with its span (one wind
    alone needs no list)."""
    af = box[2]
    csv, _, _, half = two_winds
    flights = [(str(csv), flight_of(str(csv), af, None))]
    solution = estimate_winds(af, flights, segment_s=half)
    sigmas = sorted(g.sigma_mps for g in solution.groups)
    assert len(sigmas) == 2 and sigmas[1] > sigmas[0] * 1.01, sigmas
    monkeypatch.setattr(windsolve, "MAX_WIND_SIGMA_MPS", (sigmas[0] + sigmas[1]) / 2)
    with pytest.raises(CheckFailed) as refused:
        estimate_winds(af, flights, segment_s=half)
    text = str(refused.value)
    good, bad = sorted(solution.groups, key=lambda g: g.sigma_mps)
    assert f"{csv} t {good.t_start_s:.1f}-{good.t_end_s:.1f} s {good.sigma_mps:.2g} m/s identified" in text
    assert f"{csv} t {bad.t_start_s:.1f}-{bad.t_end_s:.1f} s {bad.sigma_mps:.2g} m/s NOT identified" in text
    assert text.count("identified") == 2   # the two verdicts ("does not identify" is not one)
